"""A UR calibration through the real ``ur_rtde`` client and the RTDE controller on loopback, against an offline ``calibrate``.

Configuration A, then B and C with ``--resume`` after the controller rebooted during the change to
B (its clock 0.4 s on B's first sample, going on through C): each run is ``calibrate ur://127.0.0.1``
(the built-in sensor's wrench as the channels) against :class:`tests.rtde_server.ControllerProcess`;
then the rows the client read, at the times the runs gave them, go through ``calibrate`` of a
recording. Used by tests/test_rtde_client.py (1 kHz, every other row) and bench/bench_rtde.py.
"""

from __future__ import annotations

import contextlib
import io
import re
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fts_calib.app.cli import main
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import Calibration, load_calibration
from fts_calib.model.sensor_config import load_sensor_config
from fts_calib.planning.motion import Plan, plan_sweeps
from fts_calib.planning.sweeps import SweepPattern, sweep_ranges, wrist_ranges
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.collision import CollisionChecker
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.sim.runs import simulate_batches
from fts_calib.sim.sensor import SimulatedSensor, simulated_sensor
from fts_calib.sources import ur
from fts_calib.sources.writer import RecordingWriter

from .rtde_server import ControllerProcess, Script

ARM = ["--robot", "ur5", "--tool", "paper_tool", "--sensor", "factory_sensor"]
#: The controller's clock on B's first sample, after its reboot during the change to B [s].
RESTART_AT_S = 0.4


def short_ur5_plan() -> Plan:
    """A short UR5 calibration motion (3 levels x 4 stops, 100 Hz) for all three configurations."""
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    pattern = SweepPattern(levels=3, stops=4, dwell=0.4)
    checker = CollisionChecker(kin, tool.shape, kin.sweep_joints[0])
    home = np.array([1.3485, -2.092, -0.6562, -1.9642, 0.0, 0.0])
    ranges = wrist_ranges(kin, checker, home, sweep_ranges(kin, home, pattern.margin), 0.02).ranges
    return plan_sweeps(kin, home, ranges, pattern, 100.0)


def factory_runs_of(plan: Plan, seed: int) -> tuple[SimulatedSensor, dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """``plan`` through the simulated factory-calibrated sensor (clock from 5,000 s): the sensor, and per configuration
    the times [s] (n,), joints [rad] (n, 6) and raw wrench [N, N·m] (n, 6)."""
    path = resolve("factory_sensor", "configs")
    sensor = simulated_sensor(load_sensor_config(path), path)
    kin = Kinematics(load_robot(resolve("ur5", "robots")))
    tool = load_tool(resolve("paper_tool", "configs"))
    trajectories = [TrajectoryFile(plan.joint_names, plan.time, plan.q, plan.qd, plan.qdd, c.name) for c in tool.configurations]
    batches = list(simulate_batches(kin, tool, trajectories, sensor, np.random.default_rng(seed), start_time=5000.0))
    runs = {}
    for k, name in enumerate(tool.names):
        rows = [b for b in batches if b.configuration[0] == k]
        time_, q, wrench = (np.concatenate([getattr(b, column) for b in rows]) for column in ("time", "joints", "channels"))
        runs[name] = (time_, q, wrench)
    return sensor, runs


@contextlib.contextmanager
def reading_rows() -> Iterator[list[float]]:
    """The controller times of the samples the poller reads (each once), in order, while the context lasts."""
    read: list[float] = []
    poll = ur.RtdePoller.poll

    def recording(self):
        fresh = poll(self)
        if fresh:
            read.append(self._last)
        return fresh

    ur.RtdePoller.poll = recording  # type: ignore[method-assign]
    try:
        yield read
    finally:
        ur.RtdePoller.poll = poll  # type: ignore[method-assign]


def calibrate_ur(name: str, out: Path, *options: str, idle_s: float = 0.5) -> int:
    """`calibrate ur://127.0.0.1` of configuration ``name`` into ``out``; ends ``idle_s`` after the last new sample."""
    return main(["calibrate", "ur://127.0.0.1", *ARM, "--configuration", name, "-o", str(out), "--idle-timeout", str(idle_s), *options])


@dataclass
class Case:
    """What the runs gave.

    Attributes:
        codes: Each run's exit status, by configuration.
        texts: Each run's standard output, by configuration.
        sent: Data packages the controller sent, by configuration.
        read: Samples the client read, by configuration.
        requests: The package types the controller received, by configuration.
        wall_s: Each run's wall time [s], by configuration.
        live: The calibration of the runs (None when the last did not write one).
        offline: The calibration of ``calibrate`` of the same rows (None likewise).
    """

    codes: dict[str, int] = field(default_factory=dict)
    texts: dict[str, str] = field(default_factory=dict)
    sent: dict[str, int] = field(default_factory=dict)
    read: dict[str, int] = field(default_factory=dict)
    requests: dict[str, list[str]] = field(default_factory=dict)
    wall_s: dict[str, float] = field(default_factory=dict)
    live: Calibration | None = None
    offline: Calibration | None = None


def run_case(
    runs: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
    joint_names: Sequence[str],
    workdir: Path,
    period_s: float,
    step: int = 1,
    start: Callable[[Script, Path], ControllerProcess] = ControllerProcess,
) -> Case:
    """The three runs through the real client, then ``calibrate`` of the rows it read (see the module docstring).

    Args:
        runs: Per configuration (A, B, C): controller times [s] (n,), joints [rad] (n, 6), wrench [N, N·m] (n, 6).
        joint_names: The robot's joints (the recording's columns).
        workdir: A folder for the calibrations, the checkpoint and the recording.
        period_s: Wall time between two data packages [s].
        step: Send every ``step``-th row.
        start: Starts the controller (the tests' skips when its port is taken).
    """
    case, out = Case(), workdir / "ur.yaml"
    restart = runs["B"][0][0] - RESTART_AT_S
    rows: dict[str, tuple[np.ndarray, np.ndarray, float]] = {}
    with reading_rows() as read:
        for k, (name, (stamps, q, wrench)) in enumerate(runs.items()):
            stamps = (stamps if k == 0 else stamps - restart)[::step]
            before, began, output = len(read), time.perf_counter(), io.StringIO()
            with start(Script(stamps, q[::step], wrench[::step], period_s=period_s), workdir) as arm, contextlib.redirect_stdout(output):
                case.codes[name] = calibrate_ur(name, out, "--quiet", *(["--resume"] if k else []))
            case.wall_s[name], case.texts[name] = time.perf_counter() - began, output.getvalue()
            case.sent[name], case.requests[name] = arm.summary["sent"], arm.summary["requests"]
            shift = re.search(r"its times re-based by ([-+0-9.]+) s", case.texts[name])
            rows[name] = (stamps, np.asarray(read[before:]), float(shift[1]) if shift else 0.0)
            case.read[name] = len(read) - before
    if case.codes[name]:
        return case
    recording = workdir / "read.csv"
    with RecordingWriter(recording, joint_names, n_channels=6) as writer:
        for name, (_, q, wrench) in runs.items():  # the rows read, at the times the runs gave them
            stamps, times, shift = rows[name]
            kept = np.isin(stamps, times)
            writer.write(stamps[kept] + shift, q[::step][kept], wrench[::step][kept], name)
    offline = workdir / "offline.yaml"
    with contextlib.redirect_stdout(io.StringIO()):
        if main(["calibrate", *ARM, str(recording), "-o", str(offline), "--quiet"]) == 0:
            case.live, case.offline = load_calibration(out), load_calibration(offline)
    return case
