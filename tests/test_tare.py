"""Re-tare: shifted offsets recovered from a short recording; the file keeps the history."""

import re

import numpy as np
import pytest

from fts_calib import Calibration, ConfigError, UnknownToolConfiguration, load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import save_calibration
from fts_calib.robot.tool import load_tool
from fts_calib.service.retare_job import tare_recording
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sources.recording import RecordingWriter

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.3, 0.7])
SHIFT = np.array([0.8, -0.3, 0.25, 0.02, -0.015, 0.01])  # [N, N·m]: the offsets drifted by this
# The shipped sensor's noise on the wrench, sigma_W = sqrt((C diag(s^2) C^T)_jj), is at most
# 3.8e-3 N (Fz) and 5.6e-5 N m (Mx); a mean of 1,500 samples has sigma_W / sqrt(1500), at most
# 9.7e-5 N: 5 sigma of it, for any seed.
ATOL_SHIFT = 5e-4  # [N]


@pytest.fixture(scope="module")
def setup():
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    return sensor, Calibration(sensor.C_bar, sensor.D, provenance={"method": "test"})


def _recording(path, sensor, ur5, wrench, rng, rows=1500):
    drifted = type(sensor)(**{**sensor.__dict__, "D": sensor.D + SHIFT})
    t = np.arange(rows) / 1000.0
    with RecordingWriter(path, ur5.joint_names) as writer:
        writer.write(t, np.tile(HOME, (rows, 1)), drifted.channels(np.tile(wrench, (rows, 1)), rng=rng), "A")
    return path


def test_re_tare_with_nothing_mounted_recovers_the_shift(tmp_path, setup, ur5, rng):
    sensor, cal = setup
    path = _recording(tmp_path / "tare.csv", sensor, ur5, np.zeros(6), rng)
    result = tare_recording(cal, path)
    np.testing.assert_allclose(result.calibration.D - cal.D, SHIFT, atol=ATOL_SHIFT)
    assert np.all(np.abs(result.calibration.D - cal.D - SHIFT) < 5 * result.estimate.stderr_D)
    entry = result.calibration.offset_history[-1]
    assert entry["D"] == cal.D.tolist() and "re-tare from tare.csv, nothing mounted (1,500 samples)" == entry["reason"]


def test_re_tare_with_a_known_tool_on(tmp_path, setup, ur5, rng):
    sensor, cal = setup
    tool = load_tool(resolve("paper_tool", "configs"))
    weight = tool.configuration("B").static_wrench(ur5.g_sensor(HOME, tool.gravity))
    path = _recording(tmp_path / "tare_b.csv", sensor, ur5, weight, rng)
    result = tare_recording(cal, path, ur5, tool, "B")
    np.testing.assert_allclose(result.calibration.D - cal.D, SHIFT, atol=ATOL_SHIFT)


def test_cli_tare_updates_the_file_and_keeps_the_history(tmp_path, setup, ur5, rng, capsys):
    sensor, cal = setup
    file = save_calibration(cal, tmp_path / "cal.yaml")
    path = _recording(tmp_path / "tare.csv", sensor, ur5, np.zeros(6), rng)
    assert main(["tare", "--calibration", str(file), str(path)]) == 0
    assert "old D" in capsys.readouterr().out
    assert main(["tare", "--calibration", str(file), str(path)]) == 0
    updated = load_calibration(file)
    assert len(updated.offset_history) == 2 and updated.offset_history[0]["D"] == cal.D.tolist()
    np.testing.assert_allclose(updated.D - cal.D, SHIFT, atol=ATOL_SHIFT)
    assert (
        main(["tare", "--calibration", str(file), str(path), "--configuration", "A", "--tool", "paper_tool"]) == ExitCode.RECORDING
    )  # no robot: orientations
    assert "no --robot given, so the recording must give the sensor's orientation" in capsys.readouterr().err


def test_re_tare_from_a_live_window(setup, rng):
    """Nothing mounted: strain messages on loopback during a live window, the shift recovered."""
    import socket
    import threading
    import time

    from fts_calib.service.retare_job import tare_live
    from fts_calib.sources.udp import Strain, encode

    sensor, cal = setup
    drifted = type(sensor)(**{**sensor.__dict__, "D": sensor.D + SHIFT})
    strains = drifted.channels(np.zeros((2000, 6)), rng=rng)
    bound, listening, stop = [], threading.Event(), threading.Event()
    rate_hz = 5000.0  # a fast sensor: the 2,000 samples take 0.4 s of the 0.8 s window

    def on_listening(address):  # tare_live bound port 0: this is the port it got
        bound.append(address)
        listening.set()

    def send():
        if not listening.wait(60.0) or not bound:  # no receiver: nothing to send to
            return
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            start = time.monotonic()
            for k, strain in enumerate(strains):
                ahead = start + k / rate_hz - time.monotonic()  # the sensor's schedule, or the end of the test
                if k % 50 == 0 and ahead > 0 and stop.wait(ahead):
                    return
                sock.sendto(encode(Strain(k / rate_hz, tuple(strain))), bound[0])

    sender = threading.Thread(target=send)
    sender.start()
    try:
        result = tare_live(cal, "127.0.0.1", 0, 0.8, on_listening=on_listening)
    finally:
        stop.set()
        listening.set()
        sender.join(timeout=60.0)
    assert result.estimate.samples_used > 100
    # at least 100 samples: the mean's noise is at most sigma_W / 10 = 3.8e-4 N; 5 sigma of it
    np.testing.assert_allclose(result.calibration.D - cal.D, SHIFT, atol=2e-3)
    assert np.all(np.abs(result.calibration.D - cal.D - SHIFT) < 5 * result.estimate.stderr_D)
    reason = result.calibration.offset_history[-1]["reason"]
    assert f"live window of 0.8 s on udp://127.0.0.1:{bound[0][1]}," in reason and bound[0][1] != 0, reason


def test_re_tare_from_a_serial_line(setup, rng):
    """Nothing mounted: ADC codes on a serial line (a pseudo-terminal), scaled to raw units: the shift recovered."""
    import os
    import threading
    import time

    from fts_calib.service.retare_job import tare_live

    sensor, cal = setup
    drifted = type(sensor)(**{**sensor.__dict__, "D": sensor.D + SHIFT})
    codes = np.round(drifted.channels(np.zeros((2000, 6)), rng=rng) / sensor.lsb).astype(np.int64)
    master, slave = os.openpty()
    lines = [b",".join(b"%d" % v for v in row) + b"\n" for row in codes]

    done = threading.Event()

    def write() -> None:  # a sensor streams until the window is taken, whenever the reader starts
        k = 0
        while not done.is_set():
            os.write(master, b"".join(lines[k : k + 50]))  # 50 lines every 10 ms: 5 kHz
            k = (k + 50) % len(lines)
            time.sleep(0.01)

    writer = threading.Thread(target=write)
    writer.start()
    try:
        result = tare_live(cal, "", 0, 0.8, device=f"serial://{os.ttyname(slave)}?channels=8&scale={sensor.lsb!r}")
    finally:
        done.set()
        writer.join()
        os.close(master)
        os.close(slave)
    assert result.estimate.samples_used > 100
    np.testing.assert_allclose(result.calibration.D - cal.D, SHIFT, atol=2e-3)
    assert np.all(np.abs(result.calibration.D - cal.D - SHIFT) < 5 * result.estimate.stderr_D)
    assert "live window of 0.8 s on serial://" in result.calibration.offset_history[-1]["reason"]


def test_a_live_window_with_nothing_sent_says_so_without_rank_words(setup):
    from fts_calib.core.exceptions import InsufficientExcitation
    from fts_calib.service.retare_job import tare_live

    _, cal = setup
    with pytest.raises(InsufficientExcitation) as caught:
        tare_live(cal, "127.0.0.1", 0, 0.05)
    text = str(caught.value)
    assert text.startswith("insufficient data: no datagram at all on udp://127.0.0.1:") and "rank" not in text, text
    assert "is the sender running, to this port?" in text


def test_re_tare_with_a_tool_needs_its_configuration_and_the_kinematics(tmp_path, setup, ur5, rng):
    sensor, cal = setup
    tool = load_tool(resolve("paper_tool", "configs"))
    path = _recording(tmp_path / "tare.csv", sensor, ur5, np.zeros(6), rng, rows=20)
    with pytest.raises(ConfigError, match=r"is mounted: give its configuration, one of \['A', 'B', 'C'\]"):
        tare_recording(cal, path, ur5, tool)
    with pytest.raises(UnknownToolConfiguration, match="'Z' is not in the tool file; configurations: A, B, C"):
        tare_recording(cal, path, ur5, tool, "Z")
    with pytest.raises(ConfigError, match="its load depends on the orientation, so give the kinematics"):
        tare_recording(cal, path, None, tool, "A")


def test_cli_tare_with_nothing_mounted_warns_when_the_offsets_moved_by_a_tool_weight(tmp_path, setup, ur5, rng, capsys):
    """The 2 kg configuration A still on the sensor, re-tared as if nothing were mounted."""
    sensor, cal = setup
    tool = load_tool(resolve("paper_tool", "configs"))
    weight = tool.configuration("A").static_wrench(ur5.g_sensor(HOME, tool.gravity))  # 19.6 N along gravity
    file = save_calibration(cal, tmp_path / "cal.yaml")
    path = _recording(tmp_path / "mounted.csv", sensor, ur5, weight, rng)
    assert main(["tare", "--calibration", str(file), str(path), "--tool", "paper_tool"]) == 0  # the calibration records no tool
    err = capsys.readouterr().err
    assert "about the weight of configuration A of 'RIM calibration tool' (2 kg, 19.62 N)" in err, err
    # nothing on the sensor: no warning (the offsets moved by SHIFT only)
    fresh = save_calibration(cal, tmp_path / "fresh.yaml")
    assert main(["tare", "--calibration", str(fresh), str(_recording(tmp_path / "empty.csv", sensor, ur5, np.zeros(6), rng))]) == 0
    assert "about the weight" not in capsys.readouterr().err


def test_tare_reports_the_drift_since_the_calibration_run_through_every_re_tare(tmp_path, setup, ur5, rng, capsys):
    """Two re-tares: the second's drift is measured from the calibration's offsets, not from the first re-tare's."""
    import dataclasses

    sensor, cal = setup
    dated = dataclasses.replace(cal, provenance={"method": "test", "time": "2026-01-01T08:00:00Z"})
    first = tare_recording(dated, _recording(tmp_path / "t1.csv", sensor, ur5, np.zeros(6), rng))
    np.testing.assert_allclose(first.since_calibration, SHIFT, atol=ATOL_SHIFT)
    half = dataclasses.replace(first.calibration, D=cal.D + SHIFT / 2)  # a hand-edited D in between
    second = tare_recording(half, _recording(tmp_path / "t2.csv", sensor, ur5, np.zeros(6), rng))
    np.testing.assert_allclose(second.since_calibration, SHIFT, atol=ATOL_SHIFT)  # against the calibration run's D
    np.testing.assert_allclose(second.calibration.D - half.D, SHIFT / 2, atol=ATOL_SHIFT)  # the change since the last D
    assert second.elapsed_s > 0 and len(second.calibration.offset_history) == 2
    no_zone = dataclasses.replace(cal, provenance={"method": "test", "time": "2026-01-01T08:00:00"})  # hand-written, no zone: UTC
    assert tare_recording(no_zone, tmp_path / "t1.csv").elapsed_s == pytest.approx(first.elapsed_s, abs=60.0)
    file = save_calibration(dated, tmp_path / "cal.yaml")
    assert main(["tare", "--calibration", str(file), str(tmp_path / "t1.csv")]) == 0
    printed = capsys.readouterr().out
    assert "since calibration" in printed and "drift since the calibration" in printed
    drift = re.search(r"largest force drift Fx ([+-][0-9.]+) N", printed)
    assert drift is not None and abs(float(drift.group(1)) - SHIFT[0]) <= ATOL_SHIFT + 5e-5, printed  # printed to 4 decimals


@pytest.mark.parametrize("command", ["tare", "payload", "validate"])
def test_a_recording_of_another_width_than_the_calibration_names_both(tmp_path, ur5_recording, capsys, command):
    """Before: tare and payload said 'strain.shape=(20, 8) but expected (6,) or (N, 6)' without the file;
    validate told the user to pick a --sensor, which it does not read the layout from."""
    from fts_calib.model.channels import WRENCH_6

    cal = save_calibration(Calibration(np.eye(6), np.zeros(6), layout=WRENCH_6), tmp_path / "w6.yaml")
    out = tmp_path / "out.yaml"
    args = {
        "tare": ["tare", "--calibration", str(cal), str(ur5_recording), "-o", str(out)],
        "payload": ["payload", "--calibration", str(cal), "--robot", "ur5", str(ur5_recording), "-o", str(out)],
        "validate": ["validate", "--calibration", str(cal), "--robot", "ur5", "--tool", "paper_tool", str(ur5_recording)],
    }[command]
    assert main(args) == ExitCode.ARRAY
    err = capsys.readouterr().err.strip().splitlines()
    expected = f"{ur5_recording} has 8 channels but the calibration's layout wrench-6 has 6; give the calibration of this sensor"
    assert len(err) == 1 and expected in err[0], err
    assert not out.exists()


def test_tare_takes_a_live_source_as_a_recording_and_one_source_only(tmp_path, capsys):
    """tare SOURCE: udp://HOST:PORT is a live window (its old spelling --listen warned); two sources, or none, are refused."""
    import shutil

    cal = shutil.copy(resolve("paper_table1_calibration", "configs"), tmp_path / "cal.yaml")
    tare = ["tare", "--calibration", str(cal), "--seconds", "0.1"]
    assert main([*tare, "udp://127.0.0.1:0"]) == ExitCode.EXCITATION  # nothing sent in the window
    captured = capsys.readouterr()
    assert re.match(r"listening on udp://127\.0\.0\.1:\d+ for 0\.1 s: hold the sensor still", captured.out), captured.out
    assert "no datagram at all on udp://127.0.0.1:" in captured.err and "warning" not in captured.err, captured.err
    assert main([*tare, "--listen", "127.0.0.1:0"]) == ExitCode.EXCITATION
    assert "--listen 127.0.0.1:0 is now the source udp://127.0.0.1:0" in capsys.readouterr().err
    assert main([*tare, "a.csv", "udp://127.0.0.1:0"]) == ExitCode.CONFIG
    assert "one source to re-tare from, not 2" in capsys.readouterr().err
    assert main(tare) == ExitCode.CONFIG
    assert "give a recording or a live feed udp://HOST:PORT to re-tare from" in capsys.readouterr().err
    assert not load_calibration(cal).offset_history, "a refused re-tare wrote the file"
