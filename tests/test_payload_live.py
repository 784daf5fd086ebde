"""``payload --motion --listen``: a simulated motion replayed as datagrams gives the payload of the
recording; a silent feed times out (exit 18) naming the address; the options are checked."""

import threading

import numpy as np
import pytest

from fts_calib.app import payload_motion
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve
from fts_calib.feeds.replay import ReplayOptions, replay
from fts_calib.model.calibration import Calibration, save_calibration
from fts_calib.planning.payload_excitation import payload_excitation
from fts_calib.robot.tool import load_tool
from fts_calib.service.payload_motion_recording import identify_payload_from_motion
from fts_calib.sim.drift import OffsetDrift
from fts_calib.sim.payload_motion import simulate_payload_motion
from fts_calib.sim.sensor import load_simulated_sensor

HOME = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])  # [rad] tests/test_payload_motion.py's pose
LATENCY_S, JOINT_NOISE = 0.008, 1e-5  # [s], [rad] joints late and noisy (issue 22's)
PAIRS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def _derived(mass, com, inertia):
    return np.concatenate([[mass], com, [inertia[i, j] for i, j in PAIRS]])


def test_a_motion_replayed_as_datagrams_gives_the_payload_of_its_recording(tmp_path, ur5, rng, monkeypatch, capsys):
    """The 1.4 kg validation payload turned by the wrist for 9.7 s (joints 8 ms late, 1e-5 rad of noise on a
    20-bit encoder, the sensor's noise and 24-bit ADC, offsets drifting) replayed at 4x as datagrams: the
    synchronizer pairs every strain sample with the joints of its own stamp (interpolation with weight 0),
    so the live payload is the recording's to 0.01 of its standard errors (seen: identical; JSON carries
    the floats exactly), and within the issue's targets. The progress and the summary are shown."""
    payload = load_tool(resolve("validation_tool", "configs")).configurations[0]
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    motion = payload_excitation(ur5, HOME, seconds=10.0, amplitude=1.0)
    path = simulate_payload_motion(
        tmp_path / "moving.csv", ur5, payload, sensor, motion, rng, LATENCY_S, JOINT_NOISE, drift=OffsetDrift.typical()
    )
    calibration = Calibration(sensor.C_bar, sensor.D)
    reference = identify_payload_from_motion(path, ur5, calibration).estimate
    cal = save_calibration(calibration, tmp_path / "cal.yaml")

    bound, listening = [], threading.Event()
    original = payload_motion.collect_motion

    def collect(*args):  # the CLI's collection, telling the sender the port it bound
        shown = args[7]

        def on_listening(address):
            shown(address)
            bound.append(address)
            listening.set()

        return original(*args[:7], on_listening, *args[8:])

    monkeypatch.setattr(payload_motion, "collect_motion", collect)
    sent = {}

    def send():
        if listening.wait(60.0) and bound:
            sent["stats"] = replay(path, *bound[0], ReplayOptions(speed=4.0))

    sender = threading.Thread(target=send)
    sender.start()
    out = tmp_path / "gripper.yaml"
    try:
        args = ["payload", "--motion", "--listen", "127.0.0.1:0", "--idle-timeout", "20", "--calibration", str(cal), "--robot", "ur5"]
        code = main([*args, "-o", str(out), "--name", "gripper"])
    finally:
        listening.set()
        sender.join(timeout=60.0)
    captured = capsys.readouterr()
    assert code == ExitCode.OK, captured.err
    assert f"listening on udp://127.0.0.1:{bound[0][1]} until the sender's end or Ctrl-C" in captured.out and bound[0][1] != 0
    assert "ended by the sender" in captured.out and "0 malformed" in captured.out, captured.out
    assert "motion " in captured.err and "turned about the sensor's x" in captured.err, captured.err
    written = load_tool(out).configuration("gripper")
    live = _derived(written.mass, written.p_sensor_com, written.inertia_com)
    recorded = _derived(reference.mass, reference.com, reference.inertia_com)
    assert np.all(np.abs(live - recorded) <= 0.01 * reference.stderr), (live - recorded) / reference.stderr
    assert abs(written.mass - payload.mass) <= 0.005 * payload.mass
    assert np.max(np.abs(written.p_sensor_com - payload.p_sensor_com)) <= 1e-3
    assert np.linalg.norm(written.inertia_com - payload.inertia_com, 2) <= 0.1 * np.linalg.norm(payload.inertia_com, 2)


def test_a_silent_feed_times_out_with_exit_18_naming_the_address(tmp_path, capsys):
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    out = tmp_path / "gripper.yaml"
    args = ["payload", "--motion", "--listen", "127.0.0.1:0", "--idle-timeout", "0.3", "--calibration", str(cal), "--robot", "ur5"]
    assert main([*args, "-o", str(out)]) == ExitCode.TIMEOUT == 18
    captured = capsys.readouterr()
    port = captured.out.split("listening on udp://127.0.0.1:")[1].split(" ")[0]
    assert int(port) != 0
    expected = f"no answer within 0.3 s: waited for the first datagram on udp://127.0.0.1:{port}; check that the sender runs"
    assert expected in captured.err and "Traceback" not in captured.err, captured.err
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--listen", "5005"], "--listen collects a continuous motion: add --motion"),
        (["--motion", "--listen", "5005", "rec.csv"], "give a recording or --listen HOST:PORT, not both"),
        (["--motion"], "give a recording, or --motion --listen HOST:PORT"),
        (["--motion", "rec.csv", "--seconds", "5"], "--seconds is the length of a live motion: it goes with --listen"),
    ],
)
def test_the_source_options_are_checked_before_any_waiting(tmp_path, capsys, extra, says):
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    cal = save_calibration(Calibration(sensor.C_bar, sensor.D), tmp_path / "cal.yaml")
    assert main(["payload", "--calibration", str(cal), "--robot", "ur5", "-o", str(tmp_path / "p.yaml"), *extra]) == ExitCode.CONFIG
    assert says in capsys.readouterr().err
