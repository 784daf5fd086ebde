"""Clock sanity of a recording: is its time column a clock in seconds for its joint readings?

A wrong time column does not stop a calibration by itself: the filter then keeps moving
samples too, and the calibration is a few % off with no warning. So ``calibrate`` checks
the first rows of a recording (the first chunk: ~36,000 rows, read once) before the
session sees them, and refuses, naming the likely cause, when

- every stamp is equal (no clock at all);
- most consecutive stamps are equal and the clock ticks more coarsely than the filter's
  windows (``filter.strain_window_s``, ``filter.derivative_window_s``);
- under the dynamic filter (``filter.mode: dynamic``), more than :data:`DYNAMIC_REPEATED_SHARE`
  of consecutive rows share their time stamp: that filter differentiates the joints over
  time, fits the stream latency and measures the timing jitter from the stamps, which then
  say nothing of the samples between them (two samples per stamp made its jitter term
  millions of % of full scale, and it kept 95 % of the samples where a clean stamp keeps 30 %);
- the sample period is longer than :data:`SLOWEST_PERIOD_S` (slower than 10 Hz): a time column
  in ms makes the period look 1000x longer (in µs 1e6x); the unit whose conversion gives a
  controller's period (100 Hz to 10 kHz) is suggested. From 10 Hz up the filter's windows
  hold their minimum number of samples whatever the rate
  (:meth:`fts_calib.filters.settings.FilterConfig.windows`): a 10 Hz log is a log, not a wrong clock;
- the joint speeds implied by the stamps, ``|Δjoint| / Δt`` over :data:`SPEED_LAG` samples,
  are far beyond the velocity limits of the robot (:attr:`Kinematics.limits.velocity`,
  rad/s): joint columns in degrees (57x; named when a reading is beyond a turn), or a
  time column that advances too slowly.

Joint columns in degrees are what the same rule finds when the joint unit is not given
(``joints_in_degrees=None``, ``--joint-unit auto``: :func:`degrees_found`): the chunks are then
converted to rad, and the words say why; a unit given is taken as given.

Only valid rows count (finite, in time order); a few glitches do not trigger the speed
rule, which needs :data:`SPEED_SHARE` of the intervals to be too fast.
:func:`clock_checked` holds the first chunks of a stream until the check has passed on
them, so that the file is read once.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.exceptions import RecordingError
from ..robot.kinematics import Kinematics
from ..sources.batch import SampleBatch
from .settings import DYNAMIC, FilterConfig

#: Sample periods of a robot controller or a sensor, in [s] (10 kHz to 100 Hz).
PLAUSIBLE_PERIOD_S = (1e-4, 1e-2)
#: The longest sample period read as a clock in [s] (10 Hz: a logger's, e.g. a sensor's own at its slowest).
SLOWEST_PERIOD_S = 0.1
#: Units a time column is mistakenly written in, with their value in [s].
TIME_UNITS = (("ms", 1e-3), ("µs", 1e-6), ("ns", 1e-9))
#: An implied speed this many times the velocity limit is impossible.
FAR_BEYOND = 5.0
#: Samples between the two readings of a speed estimate (smooths stamp jitter).
SPEED_LAG = 10
#: Share of the intervals that must be impossibly fast for a refusal (glitches are not).
SPEED_SHARE = 0.005
#: Share of consecutive rows with the same stamp beyond which the dynamic filter refuses a recording.
DYNAMIC_REPEATED_SHARE = 0.1
#: Rows needed for a verdict; fewer are not judged.
MIN_ROWS = 3
#: Rows the check looks at, at least (the first chunk of a recording holds ~36,000).
CHECK_ROWS = 1000


@dataclass(frozen=True)
class ClockCheck:
    """What the check found on the first rows of a recording.

    Attributes:
        rows: Valid rows looked at.
        period_s: Median interval between distinct stamps, in [s] (0 when none).
        max_speed_ratio: Largest implied joint speed over its velocity limit, at the
            :data:`SPEED_SHARE` quantile (0 without motion).
    """

    rows: int
    period_s: float
    max_speed_ratio: float


def clock_checked(
    path: str | Path,
    chunks: Iterable[SampleBatch],
    kin: Kinematics,
    filter_settings: FilterConfig | None,
    joints_in_degrees: bool | None = False,
    on_degrees: Callable[[str], None] | None = None,
) -> Iterator[SampleBatch]:
    """The chunks of a recording, their joints in rad, once :func:`check_clock` has passed on their first rows.

    The first chunks are held until they hold :data:`CHECK_ROWS` rows (the first chunk of a
    file does) or the stream ends; nothing reaches the caller before the check.

    Args:
        path: The recording, for the messages.
        chunks: Its batches, joints as read.
        kin: Kinematics of the robot.
        filter_settings: The filter's settings (its windows), or None without the filter.
        joints_in_degrees: The joint columns are in degrees (True: converted to rad) or in
            rad (False); None: decided on the first rows (:func:`degrees_found`).
        on_degrees: Called with the words of :func:`degrees_found` when None found degrees.

    Raises:
        RecordingError: From :func:`check_clock`, before the first chunk is yielded.
    """
    stream = iter(chunks)
    held: list[SampleBatch] = []
    for chunk in stream:
        held.append(chunk)
        if sum(len(c) for c in held) >= CHECK_ROWS:
            break
    degrees = bool(joints_in_degrees)
    if held:
        first = SampleBatch.concatenate(held)
        if joints_in_degrees is None:
            found = degrees_found(first.time, first.joints, kin)
            degrees = bool(found)
            if found and on_degrees is not None:
                on_degrees(found)
        joints = np.radians(first.joints) if degrees else first.joints
        check_clock(path, first.time, joints, kin, filter_settings, degrees)
    for chunk in itertools.chain(held, stream):
        yield dataclasses.replace(chunk, joints=np.radians(chunk.joints)) if degrees else chunk


def degrees_found(time: np.ndarray, joints: np.ndarray, kin: Kinematics) -> str:
    """Why the joint columns of a recording's first rows are in degrees, in words; '' when they read as rad.

    The rule of :func:`check_clock`'s refusal: the speeds the stamps imply are beyond
    :data:`FAR_BEYOND` times a joint's velocity limit, and that joint reads beyond a turn.

    Args:
        time: Times of the first rows [s], shape (N,).
        joints: Their joint readings as read, shape (N, n_joints).
        kin: Kinematics of the robot (velocity limits, continuous joints).
    """
    time, joints = _valid(time, joints)
    if len(time) < MIN_ROWS:
        return ""
    ratio, joint = _speed_ratio(time, joints.copy(), kin)
    largest = float(np.max(np.abs(joints[:, joint]))) if len(joints) else 0.0
    if ratio <= FAR_BEYOND or largest <= 2 * math.pi:
        return ""
    name, limit = kin.joint_names[joint], float(kin.limits.velocity[joint])
    speed = ratio * limit
    return (
        f"|{name}| up to {largest:.4g}, beyond a turn in rad, moving at {speed:.3g} rad/s read as rad ({ratio:.0f}x its velocity "
        f"limit of {limit:.3g} rad/s), {math.radians(speed):.3g} rad/s read as degrees"
    )


def _valid(time: np.ndarray, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows the clock check judges: finite, and not earlier than one before them (the checks' business)."""
    time = np.asarray(time, dtype=float)
    joints = np.array(joints, dtype=float)
    ok = np.isfinite(time) & np.all(np.isfinite(joints), axis=1)
    time, joints = time[ok], joints[ok]
    if len(time):
        forward = time >= np.maximum.accumulate(time)
        time, joints = time[forward], joints[forward]
    return time, joints


def check_clock(
    path: str | Path,
    time: np.ndarray,
    joints: np.ndarray,
    kin: Kinematics,
    filter_settings: FilterConfig | None,
    joints_in_degrees: bool = False,
) -> ClockCheck:
    """Check the time column of a recording's first rows (see the module docstring).

    Args:
        path: The recording, for the message.
        time: Times of the first rows, as read, in [s]. Shape (N,).
        joints: Joint readings of those rows, in [rad] (converted when given in degrees).
            Shape (N, n_joints).
        kin: Kinematics of the robot (velocity limits, continuous joints).
        filter_settings: The filter's settings (its windows), or None without the filter.
        joints_in_degrees: The joint columns were converted from degrees (no degree hint then).

    Raises:
        RecordingError: The clock cannot be the recording's (column 'time', or the joint
            column that looks like degrees); the message names the likely cause.
    """
    time, joints = _valid(time, joints)
    n = len(time)
    if n < MIN_ROWS:
        return ClockCheck(n, 0.0, 0.0)
    if time[-1] == time[0]:
        raise RecordingError(path, None, "time", _no_clock(n, float(time[0])))
    steps = np.diff(time)
    period = float(np.median(steps[steps > 0]))
    if filter_settings is not None:
        _check_period(path, period, float(np.mean(steps == 0)), filter_settings)
        _check_repeated(path, time, steps, filter_settings)
    ratio, joint = _speed_ratio(time, joints.copy(), kin)  # unwraps continuous joints
    if ratio > FAR_BEYOND:
        raise _too_fast(path, ratio, joint, kin, joints, joints_in_degrees)
    return ClockCheck(n, period, ratio)


def _check_period(path: str | Path, period: float, repeated: float, settings: FilterConfig) -> None:
    window = min(settings.strain_window_s, settings.derivative_window_s)
    coarse = repeated > 0.5 and period > window
    if not coarse and period <= SLOWEST_PERIOD_S * (1 + 1e-9):
        return
    strain, derivative = settings.strain_window_s, settings.derivative_window_s
    windows = f"the filter's windows (strain_window_s {strain:g} s, derivative_window_s {derivative:g} s)"
    if coarse:
        message = (
            f"the clock ticks every {period:g} s ({100 * repeated:.0f} % of consecutive rows have the same time stamp), more "
            f"coarsely than {windows}: the filter cannot tell still samples from moving ones; record the time in s with a "
            "finer resolution (e.g. the controller's clock, to the µs)"
        )
        raise RecordingError(path, None, "time", message)
    advice = f"{settings.windows(period).text()}; record at {1 / SLOWEST_PERIOD_S:g} Hz or more (the time in s)"
    raise RecordingError(path, None, "time", _slow_clock(period, f"slower than {1 / SLOWEST_PERIOD_S:g} Hz", advice))


def check_sample_clock(path: str | Path, time: np.ndarray, why: str) -> None:
    """Check the time stamps a sample rate is measured from (``monitor``'s first samples): a clock, in s.

    Args:
        path: The recording, for the message.
        time: The first samples' times as read, in [s]. Shape (N,).
        why: What the rate is for, in words (the message's end).

    Raises:
        RecordingError: Every stamp is equal, or the period (the median step between distinct
            stamps) is longer than a sensor's (:data:`PLAUSIBLE_PERIOD_S`, 100 Hz at the slowest);
            the message names a time unit that would make it one (ms, µs, ns).
    """
    time = np.asarray(time, dtype=float)
    time = time[np.isfinite(time)]
    if len(time) < MIN_ROWS:
        return
    if np.all(time == time[0]):
        raise RecordingError(path, None, "time", _no_clock(len(time), float(time[0])))
    steps = np.diff(time)
    period = float(np.median(steps[steps > 0]))
    slowest = PLAUSIBLE_PERIOD_S[1]
    if period > slowest * (1 + 1e-9):
        beyond = f"longer than a sensor's sample period (at most {slowest:g} s, {1 / slowest:g} Hz; {why})"
        raise RecordingError(path, None, "time", _slow_clock(period, beyond, f"record at {1 / slowest:g} Hz or more (the time in s)"))


def _no_clock(n: int, value: float) -> str:
    return f"all {n:,} time stamps of the first rows are equal ({value:g}): the column holds no clock; write the time in s"


def _slow_clock(period: float, beyond: str, advice: str) -> str:
    """The message of a period [s] ``beyond`` what the job takes: the time unit that would fit, or ``advice``.

    A unit is suggested only for a period slower than :data:`SLOWEST_PERIOD_S`: a log at 10 Hz
    or faster is a clock in s (monitor needs 100 Hz: a 10 Hz log is told that, not "ms").
    """
    rate = f"{period:g} s between samples ({1 / period:.3g} Hz)"
    low, high = PLAUSIBLE_PERIOD_S
    units = TIME_UNITS if period > SLOWEST_PERIOD_S * (1 + 1e-9) else ()
    unit = next(((name, factor) for name, factor in units if low <= period * factor <= high * (1 + 1e-9)), None)
    if unit is None:
        return f"{rate}, {beyond}: {advice}"
    name, factor = unit
    return (
        f"{rate}, {beyond}: the time column looks like {name} ({period * factor:g} s, "
        f"{1 / (period * factor):.3g} Hz when read as {name}); write the time in s (divide it by {1 / factor:g})"
    )


def _check_repeated(path: str | Path, time: np.ndarray, steps: np.ndarray, settings: FilterConfig) -> None:
    """Refuse a stream whose stamps repeat (beyond :data:`DYNAMIC_REPEATED_SHARE`) for the dynamic filter."""
    repeated = steps == 0
    if settings.mode != DYNAMIC or float(np.mean(repeated)) <= DYNAMIC_REPEATED_SHARE:
        return
    first = float(time[int(np.argmax(repeated))])
    message = (
        f"{int(repeated.sum()):,} of {len(steps):,} consecutive rows of the first {len(time):,} have the same time stamp as the row "
        f"before (the first at {first:g} s): the dynamic filter differentiates the joints over time and fits the stream latency, "
        "so it needs one time stamp per sample; record the time at the sample rate, or calibrate the still samples "
        "(--filter quasi-static)"
    )
    raise RecordingError(path, None, "time", message)


def _speed_ratio(time: np.ndarray, joints: np.ndarray, kin: Kinematics) -> tuple[float, int]:
    """The implied joint speed over its limit at the :data:`SPEED_SHARE` top quantile, and its joint."""
    limits = np.asarray(kin.limits.velocity, dtype=float)
    checked = np.isfinite(limits) & (limits > 0)
    if kin.continuous.any():
        joints[:, kin.continuous] = np.unwrap(joints[:, kin.continuous], axis=0)
    lag = min(SPEED_LAG, len(time) - 1)
    span = time[lag:] - time[:-lag]
    moved = np.abs(joints[lag:] - joints[:-lag])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where((span > 0)[:, None] & checked, moved / span[:, None] / np.where(checked, limits, 1.0), 0.0)
    if not ratio.size:
        return 0.0, 0
    per_joint = np.quantile(ratio, 1.0 - SPEED_SHARE, axis=0)
    joint = int(np.argmax(per_joint))
    return float(per_joint[joint]), joint


def _too_fast(path: str | Path, ratio: float, joint: int, kin: Kinematics, joints: np.ndarray, joints_in_degrees: bool) -> RecordingError:
    name, limit = kin.joint_names[joint], float(kin.limits.velocity[joint])
    speed = f"{ratio * limit:.3g} rad/s on {name}, {ratio:.0f}x its velocity limit ({limit:.3g} rad/s)"
    implied = f"the time stamps imply joint speeds of {speed}"
    largest = float(np.max(np.abs(joints[:, joint])))
    # readings beyond a turn are degrees (a joint sweeping 180° reads 180); below, the clock is suspect first
    if not joints_in_degrees and largest > 2 * math.pi:
        message = (
            f"{implied}: the joint columns look like degrees (|{name}| up to {largest:.4g}; in rad the speeds would be "
            f"{math.radians(ratio * limit):.3g} rad/s); write the joints in rad, or give --joint-unit deg (or auto, the default)"
        )
        return RecordingError(path, None, name, message)
    message = (
        f"{implied}: the time column advances too slowly for the motion (a unit larger than s, or another clock than "
        "the joints'), or the joint columns are not in rad (degrees of a small motion?); write the time in s and the joints in rad"
    )
    return RecordingError(path, None, "time", message)
