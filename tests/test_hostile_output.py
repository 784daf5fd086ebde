"""Hostile and careless use, round 3 (issue 21, part B): no silent wrong result, nothing overwritten that is not ours.

Each test is a case that exited 0 with a wrong or empty result, replaced or left behind a file
that was not fts-calib's, or gave advice that sent the user the wrong way. Every one checks
the first line of the message and the exit code.
"""

import errno
import json
import os
import re
import stat
import subprocess
import sys
import threading

import numpy as np
import pytest

from fts_calib import FtsCalibWarning
from fts_calib._version import __version__
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core import files as outputs
from fts_calib.core.files import OutputLock
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import Calibration, save_calibration
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingWriter

from .helpers import live_calibrate


def _error_line(capsys):
    """Stderr of a failed command: its error line (warnings before it are allowed)."""
    lines = [line for line in capsys.readouterr().err.strip().splitlines() if "error:" in line]
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture(scope="module")
def sensor():
    return load_simulated_sensor(resolve("sensor", "configs"))


@pytest.fixture
def cal_file(tmp_path, sensor):
    return save_calibration(Calibration(sensor.C_bar, sensor.D, provenance={"method": "test"}), tmp_path / "cal.yaml")


def _leftovers(folder):
    """Temporary and lock files left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name.endswith((".tmp", ".lock", ".probe")))


# -- outputs: devices, FIFOs and standard output are written in place ---------------------------


def test_export_to_dev_null_keeps_the_device(cal_file, capsys):
    before = os.stat("/dev/null")
    if not stat.S_ISCHR(before.st_mode):
        pytest.skip("this machine's /dev/null is not a character device (something replaced it before this test)")
    assert main(["export", "--format", "json", "--calibration", str(cal_file), "-o", "/dev/null"]) == ExitCode.OK
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode), "/dev/null was replaced by a regular file"
    assert (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)
    assert "wrote /dev/null (json)" in capsys.readouterr().out


def test_export_into_a_fifo_writes_through_it(tmp_path, cal_file):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    received = []

    def read():
        with open(fifo, "rb") as handle:  # opening blocks until the writer opens: no sleep needed
            received.append(handle.read())

    reader = threading.Thread(target=read)
    reader.start()
    code = main(["export", "--format", "json", "--calibration", str(cal_file), "-o", str(fifo)])
    reader.join(timeout=30)
    assert code == ExitCode.OK
    assert stat.S_ISFIFO(os.stat(fifo).st_mode), "the FIFO was replaced by a regular file"
    assert json.loads(received[0])["D"] == pytest.approx(list(load_simulated_sensor(resolve("sensor", "configs")).D))
    assert _leftovers(tmp_path) == []


def test_export_to_standard_output(cal_file, capsys):
    assert main(["export", "--format", "json", "--calibration", str(cal_file), "-o", "-"]) == ExitCode.OK
    captured = capsys.readouterr()
    assert "C_bar" in json.loads(captured.out)  # the export alone on standard output
    assert captured.err.strip() == "wrote standard output (json)"


def test_a_block_device_or_socket_is_refused(tmp_path):
    import socket

    path = tmp_path / "sock"
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(path))
    try:
        with pytest.raises(OSError, match="it is a socket, not a file"):
            outputs.atomic_write_text(path, "x")
    finally:
        server.close()
    assert stat.S_ISSOCK(os.stat(path).st_mode)


# -- one writer per output ---------------------------------------------------------------------------------

HOLDER = """
import sys
from fts_calib.core.files import OutputLock
lock = OutputLock(sys.argv[1]).acquire()
print("held", flush=True)
sys.stdin.read()
"""


def _holder(path):
    """A process that holds the lock of ``path`` until killed or its stdin closes."""
    process = subprocess.Popen([sys.executable, "-c", HOLDER, str(path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "held"
    return process


def test_a_second_live_run_on_the_same_output_is_refused_naming_the_first(tmp_path, capsys):
    output = tmp_path / "cal.yaml"
    first = _holder(output)
    try:
        code = main(live_calibrate(output, "--quiet"))
        line = _error_line(capsys)
        assert code == ExitCode.OUTPUT_IN_USE
        assert line.startswith(f"fts-calib calibrate: error: {output} is being written by another fts-calib run (process {first.pid})")
        # its checkpoint too, when given on its own
        code = main(
            [
                "calibrate",
                "--robot",
                "ur5",
                "--tool",
                "paper_tool",
                "x.csv",
                "-o",
                str(tmp_path / "other.yaml"),
                "--checkpoint",
                str(output),
            ]
        )
        assert code == ExitCode.OUTPUT_IN_USE and f"process {first.pid}" in _error_line(capsys)
    finally:
        first.kill()  # a crash: no chance to release anything
        first.wait()
    with OutputLock(output):  # the kernel released the lock of the dead process
        pass
    assert not output.exists() and _leftovers(tmp_path) == []


def test_a_writer_is_refused_while_another_process_writes_the_file(tmp_path, cal_file):
    target = tmp_path / "copy.yaml"
    first = _holder(target)
    try:
        with pytest.raises(outputs.OutputInUse, match=f"process {first.pid}"):
            outputs.atomic_write_text(target, "x")
    finally:
        first.stdin.close()  # an orderly end releases it as well
        first.wait()
    outputs.atomic_write_text(target, "x")
    assert target.read_text() == "x" and _leftovers(tmp_path) == []


# -- a disk that fills during a write leaves nothing behind -----------------------------------------------


class _FullDisk:
    """A file object whose writes (and the flush of a buffered close) fail with ENOSPC."""

    def __init__(self, handle):
        self._handle = handle

    def write(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def flush(self):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def close(self):
        self._handle.close()
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # a buffered close flushes into the full disk

    def __getattr__(self, name):
        return getattr(self._handle, name)


@pytest.fixture
def full_disk(monkeypatch):
    real = os.fdopen
    monkeypatch.setattr(outputs.os, "fdopen", lambda fd, mode: _FullDisk(real(fd, mode)))


def test_a_full_disk_leaves_no_temporary_file(tmp_path, sensor, cal_file, full_disk, capsys):
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(OSError, match="No space left"):
        save_calibration(Calibration(sensor.C_bar, sensor.D), out / "cal.yaml")
    with pytest.raises(OSError, match="No space left"), RecordingWriter(out / "rec.csv.gz", ["j1"], 8) as writer:
        writer.write(np.zeros(3), np.zeros((3, 1)), np.zeros((3, 8)), "A")
    code = main(["export", "--format", "json", "--calibration", str(cal_file), "-o", str(out / "cal.json")])
    assert code == ExitCode.FILE_ACCESS
    assert _error_line(capsys) == f"fts-calib export: error: cannot write {out / 'cal.json'}: No space left on device"
    assert sorted(p.name for p in out.iterdir()) == [], "a failed write left a file behind"


# -- tare: refused before the file is touched when the window is not a tare window -------------------------

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.3, 0.7])


def _still_poses(path, sensor, kin, wrench_of, rng, poses=4, rows=500):
    """Still windows at ``poses`` wrist orientations (1 kHz), the load at each from ``wrench_of(joints)``."""
    t0, times, joints, strains = 0.0, [], [], []
    for k in range(poses):
        q = HOME + np.array([0, 0, 0, 0, 0.6 * k, -0.5 * k])
        times.append(t0 + np.arange(rows) / 1000.0)
        joints.append(np.tile(q, (rows, 1)))
        strains.append(sensor.channels(np.tile(wrench_of(q), (rows, 1)), rng=rng))
        t0 += rows / 1000.0 + 1.0  # a second between the windows: the move is not in the file
    with RecordingWriter(path, kin.joint_names) as writer:
        writer.write(np.concatenate(times), np.vstack(joints), np.vstack(strains), "A")
    return path


def test_tare_of_the_calibration_recording_is_refused_and_the_file_untouched(tmp_path, sensor, cal_file, ur5_recording, capsys):
    before = cal_file.read_bytes()
    code = main(["tare", "--calibration", str(cal_file), str(ur5_recording)])
    line = _error_line(capsys)
    assert code == ExitCode.RESULT_REFUSED
    assert line.startswith("fts-calib tare: error: refused to re-tare (nothing written): the window is not still: "), line
    assert "rejected by joint speed: " in line and "at least 50 % must" in line, line
    assert cal_file.read_bytes() == before


def test_tare_with_a_tool_on_as_if_nothing_were_mounted_is_refused(tmp_path, sensor, cal_file, ur5, paper_tool, rng, capsys):
    """Still at four orientations with configuration A on: its 19.6 N turns with gravity, noise is ~4 mN."""
    weight = paper_tool.configuration("A")
    path = _still_poses(tmp_path / "on.csv", sensor, ur5, lambda q: weight.static_wrench(ur5.g_sensor(q, paper_tool.gravity)), rng)
    before = cal_file.read_bytes()
    code = main(["tare", "--calibration", str(cal_file), str(path)])
    line = _error_line(capsys)
    assert code == ExitCode.RESULT_REFUSED
    assert line.startswith("fts-calib tare: error: refused to re-tare (nothing written): the load does not fit 'nothing mounted': "), line
    assert cal_file.read_bytes() == before
    # named as another configuration: refused as well; named right: accepted (the check refuses no good window)
    args = ["tare", "--calibration", str(cal_file), str(path), "--robot", "ur5", "--tool", "paper_tool", "-o"]
    assert main([*args, str(tmp_path / "b.yaml"), "--configuration", "B"]) == ExitCode.RESULT_REFUSED
    assert "the load does not fit ''RIM calibration tool' configuration B mounted'" in _error_line(capsys)
    assert main([*args, str(tmp_path / "a.yaml"), "--configuration", "A"]) == ExitCode.OK
    assert not (tmp_path / "b.yaml").exists() and (tmp_path / "a.yaml").exists()


def test_tare_keeps_the_fields_of_a_newer_version(tmp_path, sensor, cal_file, ur5, rng):
    import yaml

    data = yaml.safe_load(cal_file.read_text())
    data["thermal_model"] = {"kind": "linear", "gain": [0.1, 0.2, 0.3, 0.0, 0.0, 0.0]}  # a field this version does not know
    cal_file.write_text(yaml.safe_dump(data, sort_keys=False))
    path = _still_poses(tmp_path / "still.csv", sensor, ur5, lambda q: np.zeros(6), rng, poses=1, rows=1500)
    assert main(["tare", "--calibration", str(cal_file), str(path)]) == ExitCode.OK
    after = yaml.safe_load(cal_file.read_text())
    assert after["thermal_model"] == data["thermal_model"]
    assert after["D"] != data["D"] and len(after["offset_history"]) == 1


# -- round 4 (issue 33, cases 16-19): messages that name what is wrong, sensor and calibration files ------------------


def test_a_typo_of_channels_full_lists_full_and_names_it(tmp_path, capsys):
    """Case 16: 'channels: fulll' listed the layouts without 'full' (the sensor file's own value)."""
    sensor = tmp_path / "sensor.yaml"
    sensor.write_text(resolve("sensor", "configs").read_text() + "channels: fulll\n")
    code = main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", "--sensor", str(sensor), "r.csv", "-o", str(tmp_path / "c.yaml")])
    assert code == ExitCode.FILE == 4
    assert _error_line(capsys) == (
        f"fts-calib calibrate: error: {sensor}: field 'channels': is 'fulll' but expected maltese-cross-8, wrench-6, full or "
        "{projection: 6 x n rows} (did you mean 'full'?)"
    )
    assert not (tmp_path / "c.yaml").exists()


def test_the_ati_export_of_a_linear_calibration_of_the_raw_channels_names_the_layout(tmp_path, ur5_recording, capsys):
    """Case 16: it advised 'calibrate with --model linear', which the calibration was."""
    sensor = tmp_path / "full.yaml"
    sensor.write_text(resolve("sensor", "configs").read_text() + "channels: full\n")
    cal = tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", "--sensor", str(sensor), "--model", "linear", str(ur5_recording)]
    assert main([*argv, "-o", str(cal), "--quiet"]) == ExitCode.OK
    capsys.readouterr()
    assert main(["export", "--format", "ati", "--calibration", str(cal), "-o", str(tmp_path / "c.cal")]) == ExitCode.CONFIG == 3
    assert _error_line(capsys) == (
        "fts-calib export: error: the ATI export (its UserAxis rows) holds one matrix C (wrench = C strain + D) but this "
        "calibration is a linear model of the raw channels (8 features per axis): use the c-header or json export, or calibrate "
        "with the sensor's channel layout (the sensor file's channels: maltese-cross-8, wrench-6 or a projection, not full)"
    )
    assert not (tmp_path / "c.cal").exists()


def test_a_refused_connection_to_a_ur_names_the_host_the_port_and_rtde(tmp_path, monkeypatch, capsys):
    """Case 17: nothing listening at the controller's address: it said 'Connection refused' alone, exit 14."""
    import socket
    import sys
    import types

    from fts_calib.sources import ur

    monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=lambda host: None))
    with socket.socket() as probe:  # a port nothing listens on: bound, then closed
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    monkeypatch.setattr(ur, "RTDE_PORT", port)
    argv = ["--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "c.yaml")]
    for command, sources in (("calibrate", ["ur://127.0.0.1", "udp://127.0.0.1:0"]), ("live", ["--ur", "127.0.0.1"])):
        extra = ["--sensor", "factory_sensor"] if command == "live" else []
        assert main([command, *sources, *argv, *extra]) == ExitCode.FILE_ACCESS == 14
        assert _error_line(capsys) == (
            f"fts-calib {command}: error: cannot connect to the UR controller at 127.0.0.1:{port} (RTDE): Connection refused; "
            "is 127.0.0.1 the robot's controller, with RTDE enabled?"
        )
    assert not list(tmp_path.iterdir())


def test_a_full_disk_while_a_checkpoint_is_written_names_it_and_keeps_the_last(tmp_path, ur5_recording, monkeypatch, capsys):
    """Case 18: 'No space left on device' without the file; the checkpoint before it and the calibration stay as they were."""
    checkpoint, cal = tmp_path / "run.checkpoint.json", tmp_path / "cal.yaml"
    argv = ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording), "-o", str(cal), "--checkpoint", str(checkpoint)]
    assert main([*argv, "--quiet"]) == ExitCode.OK
    before = {path.name: path.read_bytes() for path in (checkpoint, cal)}
    real = os.fdopen
    monkeypatch.setattr(outputs.os, "fdopen", lambda fd, mode: _FullDisk(real(fd, mode)))
    assert main([*argv, "--restart", "--quiet"]) == ExitCode.FILE_ACCESS == 14
    assert _error_line(capsys) == f"fts-calib calibrate: error: cannot write {checkpoint}: No space left on device"
    assert {path.name: path.read_bytes() for path in (checkpoint, cal)} == before
    assert _leftovers(tmp_path) == []


def test_a_field_this_version_does_not_know_is_named_as_ignored(tmp_path, cal_file, capsys):
    """Case 19: export dropped 'temperature_compensation' without a word, exit 0; now a warning names the field and the file."""
    cal_file.write_text(cal_file.read_text() + "temperature_compensation:\n  coefficients: [0.1, 0.2]\n")
    out = tmp_path / "cal.json"
    assert main(["export", "--format", "json", "--calibration", str(cal_file), "-o", str(out)]) == ExitCode.OK
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"fts-calib: warning: {cal_file}: field 'temperature_compensation' not known to fts-calib {__version__} (a newer "
        "version's?): ignored here (no computation and no export uses it), kept as it is when fts-calib rewrites the file (tare)"
    ]
    assert "temperature_compensation" not in out.read_text()


# -- bags whose joint stamps are on another clock ------------------------------------------------------------


def _bag(path, csv, stamp, rows=2000):
    """The first ``rows`` rows of ``csv`` as a bag, each joint state stamped ``stamp(k, t)`` and logged at t."""
    from fts_calib.sim.robot_log import BagWriter
    from fts_calib.sources.source import open_recording

    with open_recording(csv, None, None) as reader, BagWriter(path) as writer:
        batch = next(iter(reader))
        names, tools = reader.joint_names, reader.tool_names
        writer.configuration(float(batch.time[0]), tools[int(batch.configuration[0])])
        for k, (t, joints, channels) in enumerate(zip(batch.time[:rows], batch.joints[:rows], batch.channels[:rows], strict=True)):
            writer.joints(stamp(k, float(t)), names, joints, log_t=float(t))
            writer.channels(float(t), channels)
    return path


@pytest.fixture
def true_cal(tmp_path, sensor):
    return save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "true.yaml")


def _validate(cal, bag, *extra):
    return main(["validate", "--calibration", str(cal), "--robot", "ur5", "--tool", "paper_tool", str(bag), "--max-error", "0.2", *extra])


def test_joint_stamps_that_do_not_move_are_named_with_the_way_out(tmp_path, ur5_recording, true_cal, capsys):
    """A log of simulated time: header stamps 0 while the log time runs (before: 'hold the arm still at the stops')."""
    bag = _bag(tmp_path / "sim_time", ur5_recording, lambda k, t: 0.0)
    code = main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(bag), "-o", str(tmp_path / "c.yaml"), "--quiet"])
    line = _error_line(capsys)
    assert code == ExitCode.RECORDING
    assert line.startswith(f"fts-calib calibrate: error: {bag}, topic '/joint_states': the joints' header stamps do not move: "), line
    assert line.endswith("read the joints at the bag's log time: --joint-stamps log"), line
    assert not (tmp_path / "c.yaml").exists()
    # the way out: every sample placed and compared
    assert _validate(true_cal, bag, "--joint-stamps", "log") == ExitCode.OK
    assert "over 2,000 of 2,000 samples (100 %)" in capsys.readouterr().out


def test_joint_stamps_hours_from_the_log_time_say_the_offset(tmp_path, ur5_recording, true_cal, capsys):
    """Before: 'strain before the first joint sample' and 'the notes above', not printed; replay sent 1 datagram and exit 0."""
    import socket

    bag = _bag(tmp_path / "late", ur5_recording, lambda k, t: t + 3 * 3600.0)
    assert _validate(true_cal, bag) == ExitCode.RECORDING
    expected = "the joints' header stamps are +10800.000 s (+3.00 h) from the channels' clock (the bag's log time)"
    assert expected in _error_line(capsys)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver:  # somewhere to send to
        receiver.bind(("127.0.0.1", 0))
        to = f"127.0.0.1:{receiver.getsockname()[1]}"
        assert main(["replay", str(bag), "--to", to, "--speed", "0"]) == ExitCode.RECORDING
        assert expected in _error_line(capsys)
        assert main(["replay", str(bag), "--to", to, "--speed", "0", "--joint-stamps", "log"]) == ExitCode.OK
    assert "sent 4,021 datagrams" in capsys.readouterr().out  # 2,000 joints and strains, a tool message a second (20 s), the end


def test_a_validation_or_replay_of_a_sliver_of_the_recording_fails(tmp_path, ur5_recording, true_cal, capsys):
    """Stamps right for the first 300 joint states, then stuck at 0: 15 % of the samples can be placed."""
    import socket

    bag = _bag(tmp_path / "stuck", ur5_recording, lambda k, t: t if k < 300 else 0.0)
    assert _validate(true_cal, bag) == ExitCode.CHECK_FAILED
    captured = capsys.readouterr()
    line = [x for x in captured.err.splitlines() if "error:" in x][0]
    assert line == (
        "fts-calib validate: error: only 300 of 2,000 samples (15 %) were compared, below --min-coverage 0.5 (skipped: strain "
        "after the last joint sample: 1,700): the errors would describe a sliver of the recording; nothing is validated"
    ), line
    assert "over 300 of 2,000 samples (15 %)" in captured.out  # the fraction is stated in the report too
    assert _validate(true_cal, bag, "--min-coverage", "0.1") == ExitCode.OK
    assert (
        main(["validate", "--calibration", str(true_cal), "--robot", "ur5", "--tool", "paper_tool", str(bag), "--min-coverage", "2"])
        == ExitCode.CONFIG
    )
    assert "min_coverage=2.0 but expected a share in [0, 1]" in _error_line(capsys)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver:
        receiver.bind(("127.0.0.1", 0))
        code = main(["replay", str(bag), "--to", f"127.0.0.1:{receiver.getsockname()[1]}", "--speed", "0"])
    assert code == ExitCode.RECORDING
    assert "could be replayed, below 50 %: the receiver was sent a sliver of the recording" in _error_line(capsys)


# -- advice that names what is really missing ---------------------------------------------------------------


@pytest.fixture(scope="module")
def drifting_csv(tmp_path_factory):
    """The README's drifting example: the shipped UR5 plan, OffsetDrift.typical() (a warm-up: the temperature follows time)."""
    from fts_calib.core.resources import data_dir
    from fts_calib.core.resources import resolve as find
    from fts_calib.planning.trajectory_files import read_trajectory
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.drift import OffsetDrift
    from fts_calib.sim.runs import simulate_recording

    kin, tool = Kinematics(load_robot(find("ur5", "robots"))), load_tool(find("paper_tool", "configs"))
    trajectories = [read_trajectory(data_dir("trajectories") / "ur5" / f"{name}.csv.gz") for name in tool.names]
    sensor = load_simulated_sensor(find("sensor", "configs"))
    path = tmp_path_factory.mktemp("drift") / "drifting_run.csv"
    return simulate_recording(path, kin, tool, trajectories, sensor, np.random.default_rng(0), drift=OffsetDrift.typical())


def test_drift_offsets_name_the_columns_the_data_cannot_separate(tmp_path, drifting_csv, capsys):
    """Before: 'rank 11 of 12 ... more quasi-static samples'."""
    code = main(
        [
            "calibrate",
            "--robot",
            "ur5",
            "--tool",
            "paper_tool",
            str(drifting_csv),
            "-o",
            str(tmp_path / "c.yaml"),
            "--quiet",
            "--offsets",
            "drift",
        ]
    )
    assert code == ExitCode.EXCITATION
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("NO CALIBRATION: insufficient excitation: the information matrix has rank 11 of 12"), last
    assert "the offset columns 'time^1' and 'temperature' cannot be told apart: the temperature followed time" in last or (
        "the offset columns 'temperature' and 'time^1' cannot be told apart: the temperature followed time" in last
    ), last
    assert "more quasi-static samples" not in last
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(drifting_csv), "-o", str(tmp_path / "c.yaml"), "--quiet"])
        == ExitCode.OK
    )


def test_undetermined_columns_of_an_exact_collinearity():
    """Temperature exactly linear in time: one missing direction, mixing exactly the columns involved."""
    from fts_calib.model.least_squares import undetermined_columns

    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 200)
    names = ["Fx", "offset A", "time^1", "temperature", "empty"]
    X = np.column_stack([rng.normal(size=200), np.ones(200), t, 3.0 * t, np.zeros(200)])
    groups = undetermined_columns(X.T @ X, names)
    assert groups[0] == ["empty"]  # no data at all
    assert len(groups) == 2 and set(groups[1]) == {"time^1", "temperature"}, groups  # 3 t: time alone
    X[:, 3] = 1.0 + t  # the offset and time together: all three, each with a weight of a third of the largest or more
    assert set(undetermined_columns(X[:, :4].T @ X[:, :4], names[:4])[0]) == {"offset A", "time^1", "temperature"}
    assert undetermined_columns(X[:, :3].T @ X[:, :3], names[:3]) == []


def test_a_configuration_whose_temperature_is_empty_is_named(tmp_path, drifting_csv, capsys):
    """Before: 'check the tool file' (every row of configuration B skipped for its empty temperature)."""
    lines = drifting_csv.read_text().splitlines()
    head = lines[0].split(",")
    heat, tool = head.index("temperature"), head.index("tool")
    rows = [line.split(",") for line in lines[1:]]
    for cells in rows:
        if cells[tool] == "B":
            cells[heat] = ""
    path = tmp_path / "no_heat_b.csv"
    path.write_text("\n".join([lines[0], *(",".join(cells) for cells in rows)]) + "\n")
    n_b = sum(cells[tool] == "B" for cells in rows)
    code = main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(path), "-o", str(tmp_path / "c.yaml"), "--quiet"])
    printed = capsys.readouterr().out
    assert code in (ExitCode.POOR_FIT, ExitCode.EXCITATION)
    expected = (
        f"configuration B has no usable row in no_heat_b.csv: column 'temperature' is empty or not a number on {n_b:,} of its "
        f"{n_b:,} rows, so it is missing from the calibration; the temperature is needed on every row once the file has the "
        "column: fill it in, or remove the column"
    )
    assert expected in printed, printed
    assert "check the tool file" not in printed and not (tmp_path / "c.yaml").exists()


def test_fields_of_a_newer_version_survive_a_load_and_save_inside_quality_too(tmp_path, sensor):
    import yaml

    from fts_calib.model.calibration import Quality, load_calibration

    quality = Quality(10, 12, 7, 3.0, np.ones(6), np.zeros((6, 6)), np.zeros(6), np.zeros((6, 8)))
    path = save_calibration(Calibration(sensor.C_bar, sensor.D, quality=quality), tmp_path / "q.yaml")
    data = yaml.safe_load(path.read_text())
    data["quality"]["drift_residual"] = {"Fx": 0.01}  # fields a newer version writes
    data["health_v2"] = [1, 2, 3]
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.warns(FtsCalibWarning, match=r"fields 'health_v2', 'quality\.drift_residual' not known to fts-calib"):
        loaded = load_calibration(path)
    again = yaml.safe_load(save_calibration(loaded, tmp_path / "again.yaml").read_text())
    assert again["quality"]["drift_residual"] == {"Fx": 0.01} and again["health_v2"] == [1, 2, 3]
    assert again["quality"]["rank"] == 7 and again["D"] == data["D"]


def test_streams_that_do_not_overlap_say_so_and_refer_to_no_unprinted_notes(tmp_path, ur5_recording, capsys):
    """Joint stamps 0.9 s late (under the clock check's 1 s) on a 0.5 s bag: every channel sample before the first joint."""
    bag = _bag(tmp_path / "short", ur5_recording, lambda k, t: t + 0.9, rows=50)
    assert (
        main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(bag), "-o", str(tmp_path / "c.yaml"), "--quiet"])
        == ExitCode.EXCITATION
    )
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == (
        "NO CALIBRATION: no usable sample: every row was skipped before the filter (strain before the first joint sample: 50): "
        "no channel sample falls between two joint readings, so the two streams' stamps are on different clocks or do not "
        "overlap in time (a bag: read the joints at its log time with --joint-stamps log)"
    ), last


# -- round 4 (issue 33, cases 3, 5, 6 and 7): payload from motion, report, simulate --------------------------------------

PAYLOAD_HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] the UR5's payload pose of tests/test_payload.py


@pytest.fixture(scope="module")
def moving(tmp_path_factory, sensor):
    """A 9.7 s payload motion at 1 kHz (the 1.4 kg validation payload), joints 8 ms late with 1e-5 rad of noise, and the
    sensor's true calibration; the payload's true mass [kg] and inertia about its centre of mass [kg m^2]."""
    from fts_calib.payload.inertia_motion import payload_excitation
    from fts_calib.robot.definition import load_robot
    from fts_calib.robot.kinematics import Kinematics
    from fts_calib.robot.tool import load_tool
    from fts_calib.sim.payload_run import simulate_payload_motion

    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    folder = tmp_path_factory.mktemp("moving")
    motion = payload_excitation(kin, PAYLOAD_HOME, seconds=10.0, amplitude=1.0)
    path = simulate_payload_motion(folder / "moving.csv", kin, payload, sensor, motion, np.random.default_rng(5), 0.008, 1e-5)
    calibration = save_calibration(Calibration(sensor.C_bar, sensor.D), folder / "true.yaml")
    return path, calibration, payload.mass, payload.inertia_com


def _payload(calibration, recording, output):
    return main(["payload", "--calibration", str(calibration), "--robot", "ur5", str(recording), "-o", str(output)])


def _without_rows(source, target, rows):
    """``source`` with strain_4 emptied on the data rows ``rows`` (0-based): each such row is refused as malformed."""
    lines = source.read_text().splitlines()
    column = lines[0].split(",").index("strain_4")
    for k in rows:
        cells = lines[1 + k].split(",")
        cells[column] = ""
        lines[1 + k] = ",".join(cells)
    target.write_text("\n".join(lines) + "\n")
    return len(lines) - 1


def test_payload_motion_with_a_channel_missing_every_tenth_row_is_refused_naming_the_gaps(tmp_path, moving, capsys):
    """Case 3: every joint-rate window (51 samples) holds a gap: none is left to fit, and the message says why."""
    path, calibration, *_ = moving
    n = len(path.read_text().splitlines()) - 1
    removed = range(0, n, 10)
    _without_rows(path, tmp_path / "gaps.csv", removed)
    assert _payload(calibration, tmp_path / "gaps.csv", tmp_path / "p.yaml") == ExitCode.PAYLOAD
    left = n - len(removed)
    # the first row removed is no gap (nothing before it); the 25 samples at each end are left out whatever the gaps
    assert _error_line(capsys) == (
        f"fts-calib payload: error: {tmp_path / 'gaps.csv'}: no motion left to fit: {left - 50:,} of {left:,} samples left out, "
        f"within 25 ms of {len(removed) - 1} gap(s) in the samples (rows refused or datagrams lost; their joint rates would "
        "come from uneven windows), after t = 0.009, 0.019, 0.029, ... s; record the motion again without gaps"
    )
    assert not (tmp_path / "p.yaml").exists()


def test_payload_motion_with_a_few_rows_missing_leaves_out_their_windows_and_says_so(tmp_path, moving, capsys):
    """Case 3: 21 rows refused, 0.4 s apart: the 25 samples each side of each gap are left out (uneven joint-rate windows,
    which biased the inertia by 5 standard errors before) and counted; the inertia stays within 4 standard errors."""
    path, calibration, mass, inertia = moving
    removed = range(1000, 9001, 400)
    n = _without_rows(path, tmp_path / "few.csv", removed)
    assert _payload(calibration, tmp_path / "few.csv", tmp_path / "p.yaml") == ExitCode.OK
    out = capsys.readouterr().out
    left = n - len(removed)
    assert f"  {len(removed) * 50:,} of {left:,} samples left out, within 25 ms of {len(removed)} gap(s) in the samples" in out, out
    assert re.search(rf"payload from {left - 50 - len(removed) * 50:,} samples of motion", out), out
    found = re.search(r"mass ([\d.]+) ± ([\d.e-]+) kg", out)
    assert abs(float(found.group(1)) - mass) <= 4 * float(found.group(2)) + 5e-5, out  # + half the last digit printed
    for k, axis in enumerate("xyz"):
        value, stderr = (float(v) for v in re.search(rf"I{axis}{axis} ([+-][\d.]+) ± ([\d.e-]+)", out).groups())
        assert abs(value - inertia[k, k]) <= 4 * stderr + 5e-7, (axis, value, inertia[k, k], stderr)


def test_a_payload_heavier_than_the_sensor_range_is_refused_and_nothing_written(tmp_path, moving, capsys):
    """Case 5: the channels scaled x100 (another unit, another gain): a 140 kg payload on a 50 N sensor; before, written."""
    path, calibration, mass, _ = moving
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    columns = [header.index(f"strain_{k}") for k in range(1, 9)]
    scaled = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for c in columns:
            cells[c] = repr(100.0 * float(cells[c]))
        scaled.append(",".join(cells))
    (tmp_path / "x100.csv").write_text("\n".join(scaled) + "\n")
    output = tmp_path / "p.yaml"
    output.write_text("an existing tool file\n")
    assert _payload(calibration, tmp_path / "x100.csv", output) == ExitCode.RESULT_REFUSED
    line = _error_line(capsys)
    found = re.fullmatch(
        r"fts-calib payload: error: refused \(nothing written\): the payload identified weighs ([\d,]+) N \(([\d.]+) kg\), "
        r"([\d.]+) times the sensor's force full scale of 50 N \(the sensor file's\): the sensor carried it, so its weight lies "
        r"within its range; are the recording's channels in another unit or scale than the calibration's, or is the "
        r"calibration another sensor's\?",
        line,
    )
    assert found, line
    assert abs(float(found.group(2)) - 100 * mass) < 0.01 * 100 * mass  # the scale shows in the mass (the offsets scale too)
    assert output.read_text() == "an existing tool file\n"


def test_report_of_a_recording_of_another_sensor_than_the_calibration_is_refused(tmp_path, ur5_recording, capsys):
    """Case 6: a 6-channel calibration and an 8-channel recording: before, exit 0 and a page of blank residuals."""
    from fts_calib.model.channels import WRENCH_6

    six = save_calibration(Calibration(np.eye(6), np.zeros(6), layout=WRENCH_6, provenance={"method": "test"}), tmp_path / "six.yaml")
    argv = ["report", str(six), str(ur5_recording), "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "r.html")]
    assert main(argv) == ExitCode.ARRAY
    assert _error_line(capsys) == (
        f"fts-calib report: error: {ur5_recording} has 8 channels but the calibration {six} of layout wrench-6 has 6; give the "
        "recording this calibration was made from (or the calibration of the recording's sensor)"
    )
    assert not (tmp_path / "r.html").exists()


@pytest.mark.parametrize("option", ["--poses-only", "--pose-files"])
def test_simulating_still_poses_of_a_plan_that_never_stops_is_refused(tmp_path, ur5, capsys, option):
    """Case 7: a smooth plan (every joint on a sinusoid) has no stop: before, '--poses-only' wrote a 6-row recording."""
    from fts_calib.planning.trajectory_files import write_trajectory

    t = np.arange(0.0, 2.0, 0.01)  # [s] 100 Hz
    w = 2 * np.pi * 0.5  # [rad/s]
    q = PAYLOAD_HOME + 0.2 * np.sin(w * t)[:, None]
    qd, qdd = 0.2 * w * np.cos(w * t)[:, None] * np.ones(6), -0.2 * w * w * np.sin(w * t)[:, None] * np.ones(6)
    qd[0] += 1e-9  # [rad/s] never exactly 0: the first sample is no stop either
    folder = tmp_path / "smooth"
    folder.mkdir()
    for name in "ABC":
        write_trajectory(folder / f"{name}.csv", ur5.joint_names, t, q, qd, qdd, name)
    output = tmp_path / ("poses" if option == "--pose-files" else "poses.csv")
    argv = ["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", str(folder), "-o", str(output), option]
    assert main(argv) == ExitCode.CONFIG
    assert _error_line(capsys) == (
        f"fts-calib simulate: error: {option}: the trajectories of {folder} never hold still for 0.1 s (a continuous or smooth "
        f"plan has no stops), so there is no static pose to record; plan with 'fts-calib trajectory --motion stop', or leave "
        f"out {option} to record the motion"
    )
    assert not output.exists()
