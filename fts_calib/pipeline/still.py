"""Quasi-static samples: the filter's decisions, the sensor motion and the tool's load, in that order.

The one place that joins the three: :class:`QuasiStaticFilter` decides from joint rates and
strain stationarity (rules 1-3), :func:`fts_calib.robot.tool_wrench.tool_load` computes the
tool's load along the motion of the still samples (the only kinematics), and the filter's
dynamic rule (4) judges that load. The calibration session, tare and payload
identification all take their samples from :func:`quasi_static`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..feeds.batch import SampleBatch
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..robot.tool_wrench import tool_load
from .qsfilter import QuasiStaticFilter


@dataclass(frozen=True)
class StillSamples:
    """The samples the filter decided, which of them are quasi-static, and the load of those.

    Attributes:
        decided: The samples decided by this call, in time order. Length m.
        keep: The quasi-static ones (all four rules passed). Shape (m,) bool, k of them true.
        g_sensor: Gravity in the sensor frame at each kept sample, in [m/s^2]. Shape (k, 3).
        w_sensor: The tool's static wrench at each kept sample (paper eqs 17-18), in
            [N, N m], shape (k, 6); None for an unknown payload (no tool). The dynamic filter's:
            the moving wrench (:mod:`fts_calib.pipeline.dynamic`).
        weight: The estimator's weight of each kept sample, shape (k,), or None: all 1.
        static_model: Which kept samples the fit check's static model (eqs 17-18) holds for,
            shape (k,) bool, or None: all (the quasi-static filter's).
    """

    decided: SampleBatch
    keep: np.ndarray
    g_sensor: np.ndarray
    w_sensor: np.ndarray | None
    weight: np.ndarray | None = None
    static_model: np.ndarray | None = None

    @property
    def samples(self) -> SampleBatch:
        """The kept samples, in time order. Length k."""
        return self.decided.select(self.keep)


def quasi_static(filter_: QuasiStaticFilter, kin: Kinematics, tool: Tool | None, batch: SampleBatch, final: bool = False) -> StillSamples:
    """Feed ``batch`` to the filter and return the samples it can now decide, with the load of the kept ones.

    Args:
        filter_: The stream's filter (it keeps context between calls).
        kin: Kinematics of the robot.
        tool: The mounted tool, or None for an unknown payload (gravity then has the robot
            model's magnitude, and the dynamic rule is skipped).
        batch: New samples, in time order, every configuration index valid.
        final: No more samples will come.
    """
    decided = filter_.process(batch, final=final)
    still = decided.samples.select(decided.still)
    keep = decided.still.copy()
    if tool is None:
        g = kin.g_sensor(still.joints, None).reshape(-1, 3) if len(still) else np.zeros((0, 3))
        return StillSamples(decided.samples, keep, g, None)
    velocity, acceleration = decided.joint_velocity[decided.still], decided.joint_acceleration[decided.still]
    load = tool_load(kin, tool, still.joints, still.configuration, velocity, acceleration)
    ok = filter_.dynamic_rule(load, still.configuration, tool)
    keep[decided.still] = ok
    return StillSamples(decided.samples, keep, load.g_sensor[ok], load.static[ok])
