"""A short motion that shows a payload's inertia: jerk-limited moves of the three wrist joints together.

For :mod:`fts_calib.payload.moving`: the inertia is seen only through angular
acceleration about each axis of the sensor frame, and the centre of mass and mass through
gravity seen from several directions. The three last joints (on a 6-axis arm, the wrist)
move together from stop to stop, rest to rest, without dwelling, along ruckig segments within
the robot definition's velocity, acceleration and jerk limits
(:func:`fts_calib.planning.motion.sample_motion`): every start and stop is a burst of angular
acceleration about a different axis. No collision check: check the motion on the robot or
with the planner's tools before running it. Angles in [rad], times in [s].
"""

from __future__ import annotations

import numpy as np

from ..core.exceptions import TrajectoryError
from ..planning.motion import sample_motion
from ..robot.kinematics import Kinematics

#: Stops of the moving joints, in units of the amplitude: every pair of joints turns both ways.
PATTERN = np.array(
    [
        [1.0, -1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [-1.0, -1.0, -1.0],
        [0.0, 1.0, 1.0],
        [1.0, -1.0, 0.0],
        [-1.0, 0.0, 1.0],
        [0.0, 0.0, 0.0],
    ]
)


def payload_excitation(
    kin: Kinematics, home, seconds: float = 8.0, amplitude: float = 0.6, rate_hz: float = 1000.0, joints=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A jerk-limited multi-joint motion from ``home`` of at most ``seconds`` (see the module docstring).

    Args:
        kin: Kinematics (joint names and limits).
        home: Start and end pose [rad]. Shape (n_joints,).
        seconds: Longest duration [s]; the pattern's stops are taken in order while they fit.
        amplitude: Swing of each moving joint about home [rad].
        rate_hz: Sample rate [Hz].
        joints: Names of the three moving joints; the last three of the robot when None.

    Returns:
        ``(time (N,), q, qd, qdd (N, n_joints))`` in [s, rad, rad/s, rad/s^2].

    Raises:
        TrajectoryError: Not even the first stop fits in ``seconds``, or ruckig refusing a segment.
    """
    names = list(kin.joint_names[-3:] if joints is None else joints)
    if len(names) != PATTERN.shape[1]:
        raise TrajectoryError(f"joints={names} but expected {PATTERN.shape[1]} joint names", "invalid joints")
    home = np.asarray(home, dtype=float)
    index = [kin.joint_names.index(name) for name in names]
    best = None
    for count in range(1, len(PATTERN) + 1):
        stops = home[index] + amplitude * PATTERN[:count]
        motion = sample_motion(kin, home, names, stops, 0.0, rate_hz)
        if motion[0][-1] > seconds:
            break
        best = motion
    if best is None:
        raise TrajectoryError(f"no stop of the pattern fits in {seconds:g} s at an amplitude of {amplitude:g} rad", "too short")
    return best
