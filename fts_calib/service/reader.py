r"""In service: wrenches from strains inside a control loop, and gravity compensation of a payload.

Frames and units: strains raw; wrenches ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m], the
load on the sensor expressed in the sensor frame S with the moment about its origin, unless
asked otherwise. The external wrench (a hand pushing the tool, a contact) is what the
sensor measures less the payload's weight at the current orientation:

.. math::

    W_{ext} = (C \Delta + D) - [m\,g_S;\; c \times m\,g_S], \qquad g_S = R_{world,sensor}^T g_{world}

expressed in S (default), in the world frame (``F_w = R F_S``, ``M_w = R M_S``, still about
the sensor origin), or about a tool point p given in S (``M_p = M - p \times F``).

The one-sample methods write into buffers the object owns and allocate nothing per call
once the inputs are float64 arrays: the returned array is that buffer, overwritten by the
next call (copy it to keep it).
"""

from __future__ import annotations

import numpy as np

from ..core.arrays import as_matrix, as_samples
from ..core.exceptions import ConfigError, ShapeError
from ..model.calibration import Calibration
from ..model.features import features
from ..robot.tool import STANDARD_GRAVITY, ToolConfiguration

#: Frames the external wrench can be expressed in.
FRAMES = ("sensor", "world")


class WrenchReader:
    """Wrench from raw strains with a calibration, for a 1 kHz loop.

    A linear calibration is ``C strain + D``; a nonlinear one (:class:`fts_calib.model.features.SensorModel`)
    is its polynomial ``Theta phi(u) + D``, evaluated into buffers the reader owns.

    Args:
        calibration: The sensor's calibration; its layout fixes the number of channels n.
    """

    def __init__(self, calibration: Calibration):
        self.C = np.ascontiguousarray(calibration.C, dtype=float)
        self.n_channels = calibration.layout.n_channels
        self.D = np.array(calibration.D, dtype=float)  # a copy: set_offsets changes it, the calibration stays
        self.model = calibration.model
        self._out = np.empty(6)
        if self.model is not None:
            self._u = np.empty((1, self.model.inputs))
            self._phi = np.empty((1, len(self.model.names)))

    def wrench(self, strain: np.ndarray) -> np.ndarray:
        """``C strain + D`` for one sample, into an internal buffer.

        Args:
            strain: Raw channels, float64, shape (n,).

        Returns:
            The wrench [N, N m], shape (6,): a buffer overwritten by the next call.
        """
        if strain.shape != (self.n_channels,):
            raise ShapeError(f"strain.shape={strain.shape} but expected ({self.n_channels},), the calibration's channels")
        if self.model is None:
            np.dot(self.C, strain, out=self._out)
        else:
            if self.model.projection is None:
                self._u[0] = strain
            else:
                np.dot(self.model.projection, strain, out=self._u[0])
            features(self._u, self.model.degree, out=self._phi)
            np.dot(self.model.coefficients, self._phi[0], out=self._out)
        np.add(self._out, self.D, out=self._out)
        return self._out

    def wrench_batch(self, strain) -> np.ndarray:
        """``C strain + D`` for many samples.

        Args:
            strain: Raw channels, shape (N, n).

        Returns:
            Shape (N, 6), [N, N m] (a new array).
        """
        S, _ = as_samples(strain, self.n_channels, "strain")
        return (S @ self.C.T if self.model is None else self.model.wrench(S)) + self.D

    def set_offsets(self, D) -> None:
        """Replace the offsets (after a re-tare), [N, N, N, N m, N m, N m], shape (6,)."""
        self.D[:] = as_matrix(D, (6,), "D")


class GravityCompensator:
    """External wrench: the measured one less the payload's weight at the current orientation.

    Args:
        calibration: The sensor's calibration.
        payload: The payload on the sensor (mass, centre of mass in S).
        g_world: Gravity in the world frame [m/s^2], shape (3,).
    """

    def __init__(self, calibration: Calibration, payload: ToolConfiguration, g_world=(0.0, 0.0, -STANDARD_GRAVITY)):
        self.reader = WrenchReader(calibration)
        self.payload = payload
        self.g_world = np.array(as_matrix(g_world, (3,), "g_world"))
        self._weight = np.ascontiguousarray(payload.wrench_matrix)  # W_payload = A g_sensor (eqs 17-18)
        self._g = np.empty(3)
        self._w = np.empty(6)
        self._rotated = np.empty(6)

    def external(self, strain: np.ndarray, R_world_sensor: np.ndarray, frame: str = "sensor", point=None) -> np.ndarray:
        """External wrench for one sample, into an internal buffer.

        Args:
            strain: Raw channels, float64, shape (n,).
            R_world_sensor: Orientation of the sensor in the world, shape (3, 3).
            frame: 'sensor' (S) or 'world' (axes of the world, moment still about the sensor origin).
            point: A tool point in S [m], shape (3,): the moment is taken about it; None for the sensor origin.

        Returns:
            ``[F, M]`` [N, N m], shape (6,): a buffer overwritten by the next call.
        """
        measured = self.reader.wrench(strain)
        np.dot(R_world_sensor.T, self.g_world, out=self._g)
        np.dot(self._weight, self._g, out=self._w)
        np.subtract(measured, self._w, out=self._w)
        if point is not None:  # M -= point x F, component by component: no temporary array
            f, m = self._w[:3], self._w[3:]
            m[0] -= point[1] * f[2] - point[2] * f[1]
            m[1] -= point[2] * f[0] - point[0] * f[2]
            m[2] -= point[0] * f[1] - point[1] * f[0]
        if frame == "sensor":
            return self._w
        if frame != "world":
            raise ConfigError("frame", frame, f"one of {FRAMES}")
        np.dot(R_world_sensor, self._w[:3], out=self._rotated[:3])
        np.dot(R_world_sensor, self._w[3:], out=self._rotated[3:])
        return self._rotated

    def external_batch(self, strain, R_world_sensor, frame: str = "sensor", point=None) -> np.ndarray:
        """External wrench for many samples.

        Args:
            strain: Raw channels, shape (N, n).
            R_world_sensor: Orientations, shape (N, 3, 3).
            frame: 'sensor' or 'world' (see :meth:`external`).
            point: Tool point in S [m], shape (3,), or None.

        Returns:
            Shape (N, 6), [N, N m].
        """
        measured = self.reader.wrench_batch(strain)
        R = np.asarray(R_world_sensor, dtype=float)
        if R.shape != (len(measured), 3, 3):
            raise ShapeError(f"R_world_sensor.shape={R.shape} but expected ({len(measured)}, 3, 3)")
        g = np.einsum("nji,j->ni", R, self.g_world)
        out = measured - g @ self._weight.T
        if point is not None:
            out[:, 3:] -= np.cross(as_matrix(point, (3,), "point"), out[:, :3])
        if frame == "world":
            out = np.concatenate([np.einsum("nij,nj->ni", R, out[:, :3]), np.einsum("nij,nj->ni", R, out[:, 3:])], axis=1)
        elif frame != "sensor":
            raise ConfigError("frame", frame, f"one of {FRAMES}")
        return out
