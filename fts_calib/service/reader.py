r"""In service: wrenches from raw channels inside a control loop, and gravity compensation of a payload.

Frames and units: channels raw; wrenches ``[Fx, Fy, Fz, Mx, My, Mz]`` in [N] and [N m], the
load on the sensor expressed in the sensor frame S with the moment about its origin, unless
asked otherwise. The external wrench (a hand pushing the tool, a contact) is what the
sensor measures less the payload's weight at the current orientation:

.. math::

    W_{ext} = (C \Delta + D) - [m\,g_S;\; c \times m\,g_S], \qquad g_S = R_{world,sensor}^T g_{world}

expressed in S (default), in the world frame (``F_w = R F_S``, ``M_w = R M_S``, still about
the sensor origin), or about a tool point p given in S (``M_p = M - p \times F``).

The one-sample methods write into buffers the object owns and allocate nothing per call
once the inputs are float64 arrays: the returned array is that buffer, overwritten by the
next call (copy it to keep it). Other inputs (a list, float32, a ``pin.SE3`` for the
orientation) are converted once per call; a wrong shape raises :class:`ShapeError` naming
the argument, and an orientation that is not a rotation (Frobenius norm of ``R^T R - I`` above 1e-6, or
``det R <= 0``) raises :class:`NotARotation`. This module imports numpy only.
"""

from __future__ import annotations

import reprlib

import numpy as np

from ..core.arrays import as_matrix, as_samples
from ..core.deprecation import renamed
from ..core.exceptions import ConfigError, NotARotation, ShapeError
from ..model.calibration import Calibration
from ..model.features import features
from ..robot.tool import STANDARD_GRAVITY, ToolConfiguration

#: Frames the external wrench can be expressed in.
FRAMES = ("sensor", "world")

#: Largest accepted Frobenius norm of ``R^T R - I`` for an orientation (float64 rounding of a product of rotations is ~1e-15).
ROTATION_TOLERANCE = 1e-6

_EYE = np.eye(3)  # for the batch check


def rotation(value, name: str = "R_world_sensor") -> np.ndarray:
    """``value`` as a (3, 3) rotation matrix, checked.

    Args:
        value: A (3, 3) array or nested list, or an object with a ``rotation`` attribute
            (a ``pin.SE3`` ``T_world_sensor``: its rotation is ``R_world_sensor``).
        name: The argument's name, for the messages.

    Raises:
        ShapeError: Not a (3, 3) matrix of numbers (a (4, 4) homogeneous transform included).
        NotARotation: ``|R^T R - I|_F > 1e-6`` or ``det R <= 0`` (a reflection).
    """
    if type(value) is not np.ndarray or value.dtype != np.float64 or value.shape != (3, 3):
        if hasattr(value, "rotation") and not isinstance(value, np.ndarray):
            value = value.rotation
        array = np.asarray(value) if isinstance(value, np.ndarray) else None
        if array is not None and array.shape == (4, 4):
            raise ShapeError(f"{name}.shape=(4, 4) but expected (3, 3): a rotation; pass the transform's T[:3, :3]")
        value = as_matrix(value, (3, 3), name)
    # in Python floats: one conversion beats the four numpy calls of R.T @ R - I on a 3 x 3
    a, b, c, d, e, f, g, h, i = value.ravel().tolist()
    c00, c11, c22 = a * a + d * d + g * g - 1.0, b * b + e * e + h * h - 1.0, c * c + f * f + i * i - 1.0
    c01, c02, c12 = a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i
    error = (c00 * c00 + c11 * c11 + c22 * c22 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)) ** 0.5  # Frobenius norm
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)  # NaN in any entry makes it NaN
    if not error <= ROTATION_TOLERANCE or det != det:
        raise NotARotation(f"{name} is not a rotation: |R^T R - I| = {error:.3g} but expected <= {ROTATION_TOLERANCE:g}")
    if det <= 0:
        raise NotARotation(f"{name} is a reflection (det = {det:.6g}) but expected a rotation (det = +1)")
    return value


def rotations(value, n: int, name: str = "R_world_sensor") -> np.ndarray:
    """``value`` as (n, 3, 3) rotation matrices, each checked as :func:`rotation` does.

    Raises:
        ShapeError: Another shape.
        NotARotation: One of them is not a rotation; the message gives its index.
    """
    R = as_matrix(value, (n, 3, 3), name)
    error = np.sqrt(((np.einsum("nji,njk->nik", R, R) - _EYE) ** 2).sum(axis=(1, 2))) if n else np.zeros(0)  # Frobenius
    bad = np.flatnonzero(~(error <= ROTATION_TOLERANCE))
    if bad.size:
        k = int(bad[0])
        raise NotARotation(f"{name}[{k}] is not a rotation: |R^T R - I| = {error[k]:.3g} but expected <= {ROTATION_TOLERANCE:g}")
    det = np.linalg.det(R) if n else np.ones(0)
    bad = np.flatnonzero(det <= 0)
    if bad.size:
        k = int(bad[0])
        raise NotARotation(f"{name}[{k}] is a reflection (det = {det[k]:.6g}) but expected a rotation (det = +1)")
    return R


class WrenchReader:
    """Wrench from raw channels with a calibration, for a 1 kHz loop.

    A linear calibration is ``C strain + D``; a nonlinear one (:class:`fts_calib.model.features.SensorModel`)
    is its polynomial ``Theta phi(u) + D``, evaluated into buffers the reader owns.

    Args:
        calibration: The sensor's calibration; its layout fixes the number of channels n.

    Raises:
        ConfigError: ``calibration`` is not a :class:`Calibration` (a path: load it first).

    The reader never checks the calibration's load region itself (a test per sample has no
    place in a 1 kHz loop); :meth:`outside_region` is a cheap check a caller may make, e.g. to
    count or to log the loads a nonlinear model was not fitted on.

    Example::

        reader = WrenchReader(load_calibration("calibration.yaml"))
        w_sensor = reader.wrench(channels)  # (n,) raw -> (6,) [N, N m], a buffer reused by the next call
        if reader.outside_region(w_sensor):  # optional: beyond the loads the calibration was fitted on
            ...
    """

    def __init__(self, calibration: Calibration):
        if not isinstance(calibration, Calibration):  # a path, None: say what to pass (not an AttributeError)
            expected = "a Calibration (load_calibration(path) reads a file)"
            raise ConfigError(
                "calibration", calibration, expected, message=f"calibration={reprlib.repr(calibration)} but expected {expected}"
            )
        self.C = np.ascontiguousarray(calibration.C, dtype=float)
        self.n_channels = calibration.layout.n_channels
        self.D = np.array(calibration.D, dtype=float)  # a copy: set_offsets changes it, the calibration stays
        self.model = calibration.model
        self._out = np.empty(6)
        self._shape = (self.n_channels,)
        if self.model is not None:
            self._u = np.empty((1, self.model.inputs))
            self._phi = np.empty((1, len(self.model.names)))
        region = calibration.region
        # the region's limits as Python floats: a one-sample check without numpy temporaries
        self._lower = () if region is None else tuple(region.lower.tolist())
        self._upper = () if region is None else tuple(region.upper.tolist())
        self._force_limit2 = 0.0 if region is None else region.force_limit**2
        self._moment_limit2 = 0.0 if region is None else region.moment_limit**2

    @renamed(strain="channels")
    def wrench(self, channels) -> np.ndarray:
        """``C channels + D`` for one sample, into an internal buffer.

        Args:
            channels: Raw channels, shape (n,): a float64 array (no copy), or anything that
                converts to one (a list, float32).

        Returns:
            The wrench [N, N m], shape (6,): a buffer overwritten by the next call.

        Raises:
            ShapeError: ``channels`` is not n numbers.
        """
        if not (type(channels) is np.ndarray and channels.dtype == np.float64 and channels.shape == self._shape):
            channels = as_matrix(channels, self._shape, "channels")  # a list, float32: converted; else ShapeError
        if self.model is None:
            np.dot(self.C, channels, out=self._out)
        else:
            if self.model.projection is None:
                self._u[0] = channels
            else:
                np.dot(self.model.projection, channels, out=self._u[0])
            features(self._u, self.model.degree, out=self._phi)
            np.dot(self.model.coefficients, self._phi[0], out=self._out)
        np.add(self._out, self.D, out=self._out)
        return self._out

    @renamed(strain="channels")
    def wrench_batch(self, channels) -> np.ndarray:
        """``C channels + D`` for many samples.

        Args:
            channels: Raw channels, shape (N, n).

        Returns:
            Shape (N, 6), [N, N m] (a new array).
        """
        S, _ = as_samples(channels, self.n_channels, "channels")
        return (S @ self.C.T if self.model is None else self.model.wrench(S)) + self.D

    def outside_region(self, w_sensor) -> bool:
        """Whether one wrench lies outside the calibration's load region (:meth:`fts_calib.model.region.LoadRegion.contains`).

        Not called by :meth:`wrench`: a caller decides whether the check is worth its cost in
        its loop (about half that of :meth:`wrench`: 0.8 µs against 1.4 µs, measured in
        CPython). A calibration without a region (typed in by hand, or a file written before
        regions were recorded) has nothing to check: always False.

        Args:
            w_sensor: The wrench [N, N, N, N m, N m, N m], shape (6,), e.g. what :meth:`wrench` returned.

        Returns:
            True when an axis leaves its range (with the margin), or |F| or |M| exceeds its
            limit; NaN is outside.

        Raises:
            ShapeError: ``w_sensor`` is not 6 numbers.
        """
        if not self._lower:
            return False
        if not (type(w_sensor) is np.ndarray and w_sensor.shape == (6,)):
            w_sensor = as_matrix(w_sensor, (6,), "w_sensor")  # a list: converted; another shape: ShapeError
        fx, fy, fz, mx, my, mz = values = w_sensor.tolist()
        for value, lower, upper in zip(values, self._lower, self._upper, strict=True):
            if not lower <= value <= upper:
                return True
        return not (fx * fx + fy * fy + fz * fz <= self._force_limit2 and mx * mx + my * my + mz * mz <= self._moment_limit2)

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

    @renamed(strain="channels")
    def external(self, channels, R_world_sensor, frame: str = "sensor", point=None) -> np.ndarray:
        """External wrench for one sample, into an internal buffer.

        Args:
            channels: Raw channels, shape (n,) (float64 avoids a copy).
            R_world_sensor: Orientation of the sensor in the world, shape (3, 3); a
                ``pin.SE3`` ``T_world_sensor`` is taken as its ``rotation``.
            frame: 'sensor' (S) or 'world' (axes of the world, moment still about the sensor origin).
            point: A tool point in S [m], shape (3,): the moment is taken about it; None for the sensor origin.

        Returns:
            ``[F, M]`` [N, N m], shape (6,): a buffer overwritten by the next call.

        Raises:
            ShapeError: A wrong shape or type; the message names the argument.
            NotARotation: ``R_world_sensor`` is not a rotation.
        """
        measured = self.reader.wrench(channels)
        R = rotation(R_world_sensor)
        np.dot(R.T, self.g_world, out=self._g)
        np.dot(self._weight, self._g, out=self._w)
        np.subtract(measured, self._w, out=self._w)
        if point is not None:  # M -= point x F, component by component: no temporary array
            p = point if type(point) is np.ndarray and point.shape == (3,) else as_matrix(point, (3,), "point")
            f, m = self._w[:3], self._w[3:]
            m[0] -= p[1] * f[2] - p[2] * f[1]
            m[1] -= p[2] * f[0] - p[0] * f[2]
            m[2] -= p[0] * f[1] - p[1] * f[0]
        if frame == "sensor":
            return self._w
        if frame != "world":
            raise ConfigError("frame", frame, f"one of {FRAMES}")
        np.dot(R, self._w[:3], out=self._rotated[:3])
        np.dot(R, self._w[3:], out=self._rotated[3:])
        return self._rotated

    @renamed(strain="channels")
    def external_batch(self, channels, R_world_sensor, frame: str = "sensor", point=None) -> np.ndarray:
        """External wrench for many samples.

        Args:
            channels: Raw channels, shape (N, n).
            R_world_sensor: Orientations, shape (N, 3, 3), each a rotation.
            frame: 'sensor' or 'world' (see :meth:`external`).
            point: Tool point in S [m], shape (3,), or None.

        Returns:
            Shape (N, 6), [N, N m].
        """
        measured = self.reader.wrench_batch(channels)
        R = rotations(R_world_sensor, len(measured))
        g = np.einsum("nji,j->ni", R, self.g_world)
        out = measured - g @ self._weight.T
        if point is not None:
            out[:, 3:] -= np.cross(as_matrix(point, (3,), "point"), out[:, :3])
        if frame == "world":
            out = np.concatenate([np.einsum("nij,nj->ni", R, out[:, :3]), np.einsum("nij,nj->ni", R, out[:, 3:])], axis=1)
        elif frame != "sensor":
            raise ConfigError("frame", frame, f"one of {FRAMES}")
        return out
