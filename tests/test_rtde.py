"""UR arms through RTDE, tested with a fake receive interface (no network, no ur_rtde)."""

import socket
import sys
import threading
import types

import numpy as np
import pytest

from fts_calib import ConfigError, PoorFit
from fts_calib.app.calibrate import format_rtde
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.model.calibration import load_calibration
from fts_calib.model.channels import WRENCH_6
from fts_calib.session.calibration_run import LiveRunner
from fts_calib.session.session import CalibrationSession
from fts_calib.sources.batch import SampleBatch
from fts_calib.sources.live_feed import LiveFeed, StreamEnd
from fts_calib.sources.recording import RecordingReader
from fts_calib.sources.synchronizer import Synchronizer
from fts_calib.sources.udp import End, Joints, Strain, ToolChange, UdpReceiver, encode
from fts_calib.sources.ur import RtdePoller, connect_ur

from .helpers import FakeRtdeServer, wait_for

JOINTS = [f"j{k}" for k in range(1, 7)]
PERIOD_S = 0.002  # [s] e-Series controller cycle (500 Hz)
ATOL_JOINT = 1e-12  # [rad] linear motion, interpolated linearly: exact to rounding


class FakeUR:
    """The three methods of rtde_receive.RTDEReceiveInterface, replaying given controller samples.

    A sample stays the latest for ``reads`` calls of getTimestamp (the poller reads faster
    than the controller publishes); after the last one the controller falls silent.
    """

    def __init__(self, time, q, wrench, reads=3):
        self.time, self.q, self.wrench, self.reads = np.asarray(time), np.asarray(q), np.asarray(wrench), reads
        self.calls = 0

    @property
    def _index(self):
        return min(max(self.calls - 1, 0) // self.reads, len(self.time) - 1)

    def getTimestamp(self):  # noqa: N802 (ur_rtde's names)
        self.calls += 1
        return float(self.time[self._index])

    def getActualQ(self):  # noqa: N802
        return list(self.q[self._index])

    def getFtRawWrench(self):  # noqa: N802
        return list(self.wrench[self._index])


def _linear_run(n, t0=1234.5):
    """Controller samples: every joint moving at its own constant speed, a wrench counting up."""
    time = t0 + PERIOD_S * np.arange(n)
    speed = np.linspace(-0.3, 0.4, 6)  # [rad/s]
    q = (time - t0)[:, None] * speed + np.linspace(0.1, 0.6, 6)
    wrench = np.arange(n)[:, None] + np.arange(6) / 10
    return time, q, wrench, speed


def _poll_all(poller, fake):
    while fake.calls < fake.reads * len(fake.time) + 5:
        poller.poll()


def test_each_controller_sample_is_read_once_with_the_built_in_wrench():
    time, q, wrench, _ = _linear_run(400)
    fake = FakeUR(time, q, wrench, reads=3)
    poller = RtdePoller(fake, JOINTS, wrench=True)
    sync = Synchronizer(JOINTS, configurations=["A"])
    sync.add_tool(-np.inf, "A")
    _poll_all(poller, fake)
    assert poller.samples == 400 and poller.drain(sync) == 400
    batch = sync.pop(final=True)
    np.testing.assert_array_equal(batch.time, time)  # the controller's clock, untouched
    np.testing.assert_array_equal(batch.joints, q)
    np.testing.assert_array_equal(batch.channels, wrench)
    assert not sync.dropped and poller.offset_s == 0.0


def test_controller_samples_without_six_joint_angles_are_counted_and_skipped():
    time, q, wrench, _ = _linear_run(100)
    fake = FakeUR(time, q, wrench, reads=1)
    short = fake.getActualQ
    fake.getActualQ = lambda: short()[:5] if fake.calls % 10 == 0 else short()  # noqa: N802 (a glitching controller)
    poller = RtdePoller(fake, JOINTS, wrench=True)
    sync = Synchronizer(JOINTS, configurations=["A"])
    sync.add_tool(-np.inf, "A")
    _poll_all(poller, fake)
    assert poller.drain(sync) == 100 and poller.malformed == 10
    assert len(sync.pop(final=True).time) == 90
    assert "10 skipped (not 6 joint angles)" in format_rtde(poller)


def test_joints_on_the_host_clock_for_strains_that_come_over_udp(rng):
    """The offset is the smallest host - controller difference seen: delays only add to it."""
    time, q, wrench, speed = _linear_run(500)
    fake = FakeUR(time, q, wrench, reads=1)
    delays = rng.uniform(0.0002, 0.003, 600)  # [s] network and scheduling delay of each read
    offset = 10_000.0  # [s] host clock minus controller clock
    reads = iter(range(600))
    poller = RtdePoller(fake, JOINTS, wrench=False, host_clock=lambda: float(time[fake._index] + offset + delays[next(reads)]))
    sync = Synchronizer(JOINTS, configurations=["A"])
    sync.add_tool(-np.inf, "A")
    _poll_all(poller, fake)
    assert poller.offset_s == pytest.approx(offset + delays[:500].min(), abs=1e-9)
    poller.drain(sync)
    t_strain = offset + time[10] + np.linspace(0.0, 0.8, 50)  # strain datagrams stamped with the host's clock
    for t in t_strain:
        sync.add_strain(t, [0.0] * 8)
    batch = sync.pop(final=True)
    # the joint stamps are late by the smallest delay: P(min of 500 draws in [0.2, 3] ms > 0.3 ms) = (2.7 / 2.8)^500 = 1e-8
    lag = poller.offset_s - offset
    assert 0.0002 <= lag < 0.0003, lag
    expected = (t_strain - lag - offset - time[0])[:, None] * speed + np.linspace(0.1, 0.6, 6)
    np.testing.assert_allclose(batch.joints, expected, rtol=0, atol=1e-9)


def test_datagrams_beside_rtde():
    poller = RtdePoller(FakeUR(*_linear_run(3)[:3]), JOINTS, wrench=True)
    sync = Synchronizer(JOINTS, configurations=["A", "B"])
    _poll_all(poller, poller.receiver)
    poller.drain(sync)
    poller.route(Joints(0.0, dict.fromkeys(JOINTS, 0.0)), sync)
    poller.route(Strain(0.0, (1.0,) * 6), sync)
    assert poller.ignored == 2 and sync.joint_messages == 3 and sync.strain_messages == 3
    poller.route(ToolChange(99.0, "B"), sync)  # stamped by another clock: effective from the latest sample
    assert sync._tool_at(np.array([poller.latest_s]))[0] == "B"


def test_without_ur_rtde_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "rtde_receive", None)  # import fails
    with pytest.raises(ConfigError, match=r"pip install 'fts-calib\[ur\]'"):
        connect_ur("192.168.1.10")


def test_a_controller_that_does_not_answer(monkeypatch):
    def refuse(host):
        raise RuntimeError("One of the RTDE input registers are already in use!")

    monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=refuse))
    with FakeRtdeServer() as server:  # the handshake answered, then ur_rtde refuses
        monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
        with pytest.raises(ConnectionError, match="UR controller at 127.0.0.1 .*already in use"):
            connect_ur("127.0.0.1")


def test_a_robot_that_is_not_a_six_joint_arm_is_refused():
    with pytest.raises(ConfigError, match="six joints"):
        RtdePoller(FakeUR(*_linear_run(2)[:3]), JOINTS[:5], wrench=False)


def test_live_ur_with_the_built_in_sensor_one_run_per_configuration(tmp_path, monkeypatch, factory_runs, capsys):
    """`live --ur HOST --ur-wrench --configuration X`, then --resume with the next: C_bar to within its standard errors."""
    sensor, runs = factory_runs
    out = tmp_path / "ur.yaml"
    server = FakeRtdeServer()
    monkeypatch.setattr("fts_calib.sources.ur.RTDE_PORT", server.port)
    for k, (name, run) in enumerate(runs.items()):
        fake = FakeUR(*run, reads=1)
        monkeypatch.setitem(sys.modules, "rtde_receive", types.SimpleNamespace(RTDEReceiveInterface=lambda host, fake=fake: fake))
        options = ["--ur", "127.0.0.1", "--ur-wrench", "--sensor", "factory_sensor", "--configuration", name]
        timing = ["--listen", "127.0.0.1:0", "--idle-timeout", "0.3", "--quiet", *(["--resume"] if k else [])]
        code = main(["live", "--robot", "ur5", "--tool", "paper_tool", *options, "-o", str(out), *timing])
        text = capsys.readouterr().out
        assert f"RTDE: {len(run[0]):,} controller samples" in text, text
    server.close()
    assert code == ExitCode.OK, text
    cal = load_calibration(out)
    assert cal.quality.samples_seen == sum(len(run[0]) for run in runs.values())
    z_C = np.abs(cal.C_bar - sensor.C_bar) / cal.quality.stderr_C_bar
    z_D = np.abs(cal.D - sensor.D) / cal.quality.stderr_D
    assert z_C.max() <= 5.0 and z_D.max() <= 5.0, (z_C.max(), z_D.max())  # 42 coefficients at 5 sigma: P < 3e-5


def test_ur_wrench_needs_a_six_channel_sensor(tmp_path):
    assert (
        main(
            [
                "calibrate",
                "ur://ur.invalid",  # alone: the channels are its built-in wrench, which the 8-bridge sensor file cannot read
                "--robot",
                "ur5",
                "--tool",
                "paper_tool",
                "-o",
                str(tmp_path / "c.yaml"),
            ]
        )
        == ExitCode.CONFIG
    )


@pytest.mark.slow  # streams the 9,012-row recording over loopback (about 2 s); its seeded noise is swept in test_calibrate.py
def test_live_with_rtde_joints_and_strain_datagrams_gives_the_calibration_of_calibrate(ur5, paper_tool, ur5_recording):
    """An external sensor: joints from RTDE (on the host's clock), strains and tools over UDP, into one session."""
    with RecordingReader(ur5_recording, ur5.joint_names, paper_tool.names) as reader:
        rows = SampleBatch.concatenate(list(reader))
    # the rows at 128 Hz, a pause of 200 samples between configurations: stamps k / 128 s are exact
    # binary fractions, so the host's clock (the controller's + 100 s) is exact too
    controller_t = (np.arange(len(rows)) + 200 * rows.configuration) / 128.0
    host_minus_controller = 100.0  # [s]
    fake = FakeUR(controller_t, rows.joints, np.zeros((len(rows), 6)), reads=1)
    poller = RtdePoller(fake, ur5.joint_names, wrench=False, host_clock=lambda: float(fake.time[fake._index]) + host_minus_controller)
    receiver = UdpReceiver("127.0.0.1", 0)
    session = CalibrationSession(ur5, paper_tool, source="test")
    sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
    runner = LiveRunner(session, LiveFeed(receiver, sync, poller, end=StreamEnd(idle_timeout_s=30.0)))
    result = {}
    thread = threading.Thread(target=lambda: result.update(stats=runner.run()))
    thread.start()
    try:
        host_t = controller_t + host_minus_controller
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.sendto(encode(Joints(host_t[0], dict.fromkeys(ur5.joint_names, 0.0))), receiver.address)  # RTDE gives the joints
            current = None
            for k, (t, strain, code) in enumerate(zip(host_t, rows.channels, rows.configuration, strict=True)):
                if code != current:
                    current = code
                    sock.sendto(encode(ToolChange(t, paper_tool.names[code])), receiver.address)
                sock.sendto(encode(Strain(t, tuple(strain))), receiver.address)
                if k % 200 == 0:
                    wait_for(lambda k=k: runner.stats.strain >= k - 1000, "the receiver to keep up")
            wait_for(lambda: poller.samples == len(rows), "every controller sample read")
            sock.sendto(encode(End()), receiver.address)
        thread.join(timeout=60)
    finally:
        receiver.close()
    assert not thread.is_alive(), "the live run did not end"
    assert result["stats"].ended and poller.ignored == 1 and poller.offset_s == host_minus_controller
    assert not sync.dropped, sync.dropped
    direct = CalibrationSession(ur5, paper_tool, source="test")
    direct.add_samples(SampleBatch(host_t, rows.joints, rows.channels, rows.configuration))
    got, reference = session.solve(), direct.solve()
    # every strain placed at a joint stamp of its own: the same samples fed to a session at once
    # keep the same samples and give C to rounding
    assert got.quality.samples_used == reference.quality.samples_used
    assert np.all(np.abs(got.C - reference.C) <= 1e-6 * reference.quality.stderr_C)


def test_samples_nobody_drains_are_dropped_and_counted(monkeypatch):
    monkeypatch.setattr("fts_calib.sources.ur.MAX_PENDING", 50)
    poller = RtdePoller(FakeUR(*_linear_run(80)[:3], reads=1), JOINTS, wrench=True)
    _poll_all(poller, poller.receiver)
    sync = Synchronizer(JOINTS)
    assert poller.samples == 80 and poller.dropped == 30 and poller.drain(sync) == 50  # the newest 50 kept
    assert sync.joint_messages == 50


class LostUR(FakeUR):
    """A controller that stops answering after its samples (the connection is lost)."""

    def getTimestamp(self):  # noqa: N802
        if self.calls >= len(self.time):
            raise RuntimeError("RTDE receive interface: connection lost")
        return super().getTimestamp()


def test_a_lost_connection_ends_the_live_run_with_what_was_read(ur5, paper_tool):
    time, q, wrench, _ = _linear_run(300)
    poller = RtdePoller(LostUR(time, q, wrench, reads=1), ur5.joint_names, wrench=True)
    receiver = UdpReceiver("127.0.0.1", 0)
    session = CalibrationSession(ur5, paper_tool, source="test", layout=WRENCH_6)  # the built-in sensor's wrench
    sync = Synchronizer(ur5.joint_names, ur5.continuous, configurations=paper_tool.names)
    sync.add_tool(-np.inf, "A")
    try:
        stats = LiveRunner(session, LiveFeed(receiver, sync, poller, end=StreamEnd(idle_timeout_s=30.0))).run()
    finally:
        receiver.close()
    assert "connection lost" in str(poller.error) and not stats.ended
    assert poller.samples == 300 and session.progress().seen == 300  # every sample read reached the session


def test_a_wrench_in_the_base_frame_is_refused_by_the_fit_check(factory_runs, ur5, paper_tool):
    """Why getFtRawWrench (fixed to the flange) and not getActualTCPForce (base orientation): C_bar is constant."""
    _, runs = factory_runs
    session = CalibrationSession(ur5, paper_tool, source="test", layout=WRENCH_6)
    for k, (time, q, wrench) in enumerate(runs.values()):
        R = ur5.R_world_sensor(q)  # the same wrench, expressed in the base frame
        w_base = np.hstack([np.einsum("nij,nj->ni", R, wrench[:, :3]), np.einsum("nij,nj->ni", R, wrench[:, 3:])])
        session.add_samples(SampleBatch(time, q, w_base, np.full(len(time), k)))
    with pytest.raises(PoorFit, match="fit poor"):
        session.solve()
