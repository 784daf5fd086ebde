"""UR arms through the real ``ur_rtde`` client, against an RTDE controller on loopback (tests/rtde_server.py).

``ur_rtde``'s ``RTDEReceiveInterface(host)`` takes no port: the controller binds 127.0.0.1:30004
and a test skips, saying why, when that port is taken (or ``ur_rtde`` is not installed).
"""

import re
import socket

import numpy as np
import pytest
import yaml

from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.recording import RecordingReader

from .netft_box import NetFtBox
from .netft_box import Script as NetFtScript
from .rtde_case import calibrate_ur, reading_rows, run_case
from .rtde_server import RTDE_PORT, ControllerProcess, Script

UR5_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]

pytest.importorskip("rtde_receive", reason="ur_rtde is not installed (pip install 'fts-calib[ur]')")

#: Wall time between two data packages [s]: the controller's stamps keep the rows' own rate.
PERIOD_S = 0.001


def controller(script: Script, tmp_path) -> ControllerProcess:
    """The RTDE controller in its own process; the test skips when 127.0.0.1:30004 is taken."""
    try:
        return ControllerProcess(script, tmp_path)
    except OSError as exc:
        pytest.skip(f"the RTDE controller needs 127.0.0.1:{RTDE_PORT} (ur_rtde connects to no other port): {exc}")


@pytest.fixture
def rows_read():
    """The controller times of the samples the poller reads (each once), in order."""
    with reading_rows() as read:
        yield read


@pytest.mark.slow  # streams three runs of 1,502 controller samples at 1 kHz through the real client (about 9 s)
def test_the_real_client_across_a_controller_restart_calibrates_as_calibrate_of_its_rows(factory_runs, ur5, tmp_path):
    """`calibrate ur://` for A, then --resume with B and C after the controller rebooted (its clock near 0 again).

    The resumed runs re-base the restarted clock instead of skipping every sample as before the
    checkpoint, and the calibration is the one of an offline `calibrate` of the rows the client read.
    """
    sensor, runs = factory_runs
    case = run_case(runs, ur5.joint_names, tmp_path, PERIOD_S, step=2, start=controller)
    for name, text in case.texts.items():
        assert case.requests[name][:2] == ["V", "V"] and "O" in case.requests[name]  # the probe, then ur_rtde
        assert "before the checkpoint (already counted)" not in text, text  # the reason of samples skipped
        if name != "A":  # B's first sample near 0.4 s; C's where B's clock went on (both before the checkpoint's last)
            assert re.search(r"the stream's clock restarted since the checkpoint \(its first sample at \d+\.\d{3} s", text), text
    assert case.codes["C"] == ExitCode.OK, case.texts["C"]
    live, batch = case.live, case.offline
    assert live is not None and batch is not None
    assert live.quality.samples_seen == batch.quality.samples_seen == sum(case.read.values())
    # the same rows by another path: the filter learns its noise floor batch by batch (20 ms live, the
    # whole file offline), so a borderline sample may be kept by one and not the other (bench/bench_rtde.py:
    # 3e-10 to 1.4e-4 of C_bar's largest coefficient over 5 runs on a quiet machine; with the suite's other
    # worker busy, batches differ more: 298 kept live against 319 offline, and 175 against 197, were seen):
    # kept counts within 25 %, C_bar within two of its standard errors (mostly the same samples)
    used, used_offline = live.quality.samples_used, batch.quality.samples_used
    assert abs(used - used_offline) <= 0.25 * used_offline
    assert np.all(np.abs(live.C_bar - batch.C_bar) <= 2.0 * batch.quality.stderr_C_bar)
    z = np.abs(live.C_bar - sensor.C_bar) / live.quality.stderr_C_bar
    assert z.max() <= 5.0, z.max()  # and the truth within 5 standard errors (36 coefficients: P < 3e-5)


def test_a_lost_connection_ends_the_run_with_what_was_read(factory_runs, tmp_path, rows_read, capsys):
    """The controller drops the connection halfway: ur_rtde only turns isConnected() false; the run ends like Ctrl-C."""
    _, runs = factory_runs
    time, q, wrench = (column[::2] for column in runs["A"])
    out = tmp_path / "ur.yaml"
    with controller(Script(time, q, wrench, period_s=PERIOD_S, close_after=len(time) // 2), tmp_path):
        code = calibrate_ur("A", out, idle_s=600)  # not the idle timeout: the lost connection ends it
    text, status = capsys.readouterr()
    lines = [line for line in status.replace("\r", "\n").splitlines() if line.startswith("elapsed")]
    assert lines, status
    for line in lines:  # the run's wall time (a few seconds), not the controller's stamps (5,000 s) nor epoch time
        assert 0.0 <= float(line.split()[1]) < 60.0, line
    assert "messages: 0 datagrams (0 joints, 0 strain, 0 tool) and " in text, text
    assert f"and {len(rows_read):,} RTDE controller samples (joints and wrench)" in text, text
    assert code == ExitCode.EXCITATION, text  # one configuration: checkpoint kept, as after Ctrl-C
    assert "the UR controller at 127.0.0.1:30004 closed the RTDE connection" in text, text
    assert f"the last sample at controller time {time[len(time) // 2 - 1]:.3f} s" in text, text
    assert 0 < len(rows_read) <= len(time) // 2
    assert f"samples: {len(rows_read):,} seen" in text  # every sample read is in the checkpoint
    assert (tmp_path / "ur.yaml.checkpoint.json").exists()


def test_a_refused_connection_exits_14_naming_host_and_port(tmp_path, capsys):
    """Nothing listens at 127.0.0.1:30004: the system's refusal, with the controller's address (exit 14)."""
    free = socket.socket()
    free.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # a connection of an earlier test may linger in TIME_WAIT
    try:
        free.bind(("127.0.0.1", RTDE_PORT))  # free now: nothing listens there (it stays free once closed)
    except OSError as exc:
        pytest.skip(f"127.0.0.1:{RTDE_PORT} is in use, a refused connection cannot be made: {exc}")
    finally:
        free.close()
    code = calibrate_ur("A", tmp_path / "ur.yaml", "--quiet")
    error = capsys.readouterr().err
    assert code == ExitCode.FILE_ACCESS == 14, error
    assert "cannot connect to the UR controller at 127.0.0.1:30004 (RTDE): Connection refused" in error, error


def test_live_ur_runs_the_real_client(factory_runs, tmp_path, rows_read, capsys):
    """`live --ur HOST --ur-wrench` (the old spelling of `calibrate ur://`): the same real client, every sample read counted."""
    _, runs = factory_runs
    time, q, wrench = (column[::4] for column in runs["A"])
    out = tmp_path / "ur.yaml"
    with controller(Script(time, q, wrench, period_s=PERIOD_S), tmp_path):
        options = ["--ur", "127.0.0.1", "--ur-wrench", "--sensor", "factory_sensor", "--configuration", "A", "--quiet"]
        timing = ["--listen", "127.0.0.1:0", "--idle-timeout", "0.5"]
        code = main(["live", "--robot", "ur5", "--tool", "paper_tool", *options, "-o", str(out), *timing])
    text = capsys.readouterr().out
    assert code == ExitCode.EXCITATION, text  # one configuration: C_bar needs three
    assert 0 < len(rows_read) <= len(time)
    assert f"RTDE: {len(rows_read):,} controller samples" in text, text
    assert f"samples: {len(rows_read):,} seen" in text, text


def test_record_netft_channels_with_the_joints_of_the_real_client(tmp_path, capsys):
    """`record netft://BOX ur://127.0.0.1`: the controller's joints through ur_rtde put on the host's clock beside the box's counts."""
    n = 1500  # 3 s of controller samples at 500 Hz, longer than the box's 0.8 s
    stamps = 1000.0 + 0.002 * np.arange(n)  # the controller's clock [s]
    speed = np.linspace(-0.05, 0.05, 6)  # [rad/s]
    q = 0.1 + (stamps - 1000.0)[:, None] * speed
    box = NetFtBox(NetFtScript(np.arange(6 * 800).reshape(800, 6), silent_after=800, period_s=0.001))
    out = tmp_path / "d.csv"
    try:
        with controller(Script(stamps, q, np.zeros((n, 6)), period_s=0.002), tmp_path):
            code = main(["record", box.url, "ur://127.0.0.1", "--robot", "ur5", "--configuration", "A", "-o", str(out), "--quiet"])
    finally:
        box.close()
    assert code == ExitCode.OK, capsys.readouterr().err
    with RecordingReader(out, UR5_JOINTS, None) as reader:
        rows = SampleBatch.concatenate(list(reader))
    assert len(rows.time) > 300
    joints = yaml.safe_load((tmp_path / "d.streams.yaml").read_text())["streams"]["joints"]
    assert joints["source"] == "RTDE"
    expected = 0.1 + (rows.time - joints["clock_offset_s"] - 1000.0)[:, None] * speed
    np.testing.assert_allclose(rows.joints, expected, atol=5e-4)  # 10 ms of the clocks' offset at 0.05 rad/s
