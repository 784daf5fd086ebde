"""Simulated service for the health monitor: a payload moving through varied orientations with pauses, and faults.

The sensor turns between random orientations (a smooth rotation about a random axis for
``move_s``, then a pause of ``pause_s``); the payload's weight ``m g_sensor`` and its
moment ``c x F`` are the wrench on the sensor (eqs 17-18); the simulated sensor turns them
into raw channels with its noise, offsets and ADC. :func:`inject_fault` then breaks one
channel from a time on, as a real bridge fails.

Units: time [s]; mass [kg]; com [m] in the sensor frame; wrenches [N, N m]; channels raw.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.exceptions import ConfigError
from .sensor import SimulatedSensor


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about a unit axis by an angle [rad] (Rodrigues)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def service_wrenches(
    duration_s: float,
    rate_hz: float,
    rng: np.random.Generator,
    mass: float = 1.0,
    p_sensor_com=(0.05, 0.03, -0.02),
    gravity: float = 9.81,
    move_s: float = 0.8,
    pause_s: float = 0.4,
) -> tuple[np.ndarray, np.ndarray]:
    """Times and wrenches of a payload turned through random orientations with pauses.

    Args:
        duration_s: Length of the service [s].
        rate_hz: Sample rate [Hz].
        rng: Random generator (the orientations).
        mass: Payload mass [kg].
        p_sensor_com: Payload centre of mass in the sensor frame [m], shape (3,).
        gravity: Magnitude of gravity [m/s^2].
        move_s: Duration of each move [s] (up to a random factor in [0.5, 1.5]).
        pause_s: Duration of each pause [s] (likewise).

    Returns:
        ``(time (N,), w_sensor (N, 6))``.
    """
    n = int(round(duration_s * rate_hz))
    time = np.arange(n) / rate_hz
    R = _rotation(_unit(rng.standard_normal(3)), float(rng.uniform(0, np.pi)))
    g_world = np.array([0.0, 0.0, -gravity])
    g_sensor = np.empty((n, 3))
    i = 0
    while i < n:
        steps = max(1, int(rng.uniform(0.5, 1.5) * move_s * rate_hz))
        axis, angle = _unit(rng.standard_normal(3)), float(rng.uniform(0.6, 1.6))
        s = np.linspace(0.0, 1.0, steps)
        smooth = s * s * (3.0 - 2.0 * s)  # rest to rest
        for j in range(min(steps, n - i)):
            g_sensor[i + j] = (R @ _rotation(axis, angle * smooth[j])).T @ g_world
        R = R @ _rotation(axis, angle)
        i += steps
        hold = min(int(rng.uniform(0.5, 1.5) * pause_s * rate_hz), max(n - i, 0))
        g_sensor[i : i + hold] = R.T @ g_world
        i += hold
    force = mass * g_sensor
    return time, np.hstack([force, np.cross(np.asarray(p_sensor_com, dtype=float), force)])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def service_channels(sensor: SimulatedSensor, time, w_sensor, rng: np.random.Generator | None) -> np.ndarray:
    """The raw channels of the simulated sensor along a service: ``sensor.channels`` with its noise and ADC. Shape (N, n)."""
    return sensor.channels(w_sensor, time, rng)


#: The faults :func:`inject_fault` simulates.
def still_weights(
    n: int,
    rng: np.random.Generator,
    mass: float = 2.0,
    coms=((0.12, 0.0, 0.0), (0.08, 0.06, 0.0), (0.08, 0.0, 0.06)),
    gravity: float = 9.81,
) -> np.ndarray:
    """Wrenches of a tool held still in n random orientations, its centre of mass one of ``coms`` at random.

    Args:
        n: Poses.
        rng: Random generator (directions uniform on the sphere).
        mass: The tool's mass [kg].
        coms: Centres of mass to choose from [m], in the sensor frame, shape (k, 3).
        gravity: [m/s²].

    Returns:
        ``[F, c x F]`` per pose [N, N, N, N m, N m, N m], shape (n, 6).
    """
    up = rng.standard_normal((n, 3))
    force = mass * gravity * up / np.linalg.norm(up, axis=1, keepdims=True)
    centres = np.asarray(coms, dtype=float)
    return np.hstack([force, np.cross(centres[rng.integers(0, len(centres), n)], force)])


def still_poses(
    sensor: SimulatedSensor, wrenches, seconds: float, rate_hz: float, rng: np.random.Generator, mid_code: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sensor held still under each wrench in turn, for ``seconds`` each (no drift).

    Args:
        sensor: The simulated sensor (its noise and ADC).
        wrenches: One wrench per pose [N, N, N, N m, N m, N m], shape (P, 6).
        seconds: How long each pose is held [s].
        rate_hz: Sample rate [Hz].
        rng: Random generator of the noise.
        mid_code: Move each channel's offset so that its noiseless reading sits in the middle
            of an ADC code at each pose (a quiet channel's longest stays in one code); the
            sensor needs ``adc_bits``.

    Returns:
        Time [s] (N,), raw channels (N, n), pose index (N,), N = P round(seconds rate_hz).
    """
    wrenches = np.atleast_2d(np.asarray(wrenches, dtype=float))
    per = int(round(seconds * rate_hz))
    parts = []
    for wrench in wrenches:
        held = sensor
        if mid_code:
            analog = dataclasses.replace(sensor, adc_bits=0).channels(wrench)
            origin = sensor.adc_codes[0] if sensor.adc_range is not None else 0.0  # the codes are origin + k lsb
            codes = origin + np.round((analog - origin) / sensor.lsb) * sensor.lsb
            held = dataclasses.replace(sensor, channel_offset=np.asarray(sensor.channel_offset, dtype=float) + codes - analog)
        parts.append(held.channels(np.repeat(wrench[None], per, axis=0), None, rng))
    pose = np.repeat(np.arange(len(wrenches)), per)
    return np.arange(len(pose)) / rate_hz, np.concatenate(parts), pose


FAULTS = ("gain", "jump", "frozen", "open", "shorted")


def inject_fault(channels, time, kind: str, channel: int, start_s: float, size: float = -0.01, rail: float | None = None) -> np.ndarray:
    """A copy of ``channels`` with one channel broken from ``start_s`` on.

    Args:
        channels: Raw readings, shape (N, n).
        time: Sample times [s], shape (N,).
        kind: ``gain`` (reading times 1 + size), ``jump`` (reading plus size, raw units),
            ``frozen`` (the reading at start_s held), ``open`` (the reading at ``rail``:
            its amplifier driven to the supply), ``shorted`` (likewise at the other end, ``-rail``).
        channel: 1-based channel.
        start_s: When the fault begins [s].
        size: Relative gain change (gain) or step in raw units (jump).
        rail: Reading of an open bridge, raw units (open, shorted).

    Raises:
        ConfigError: Unknown kind or channel, or no rail for open/shorted.
    """
    out = np.array(channels, dtype=float, copy=True)
    if kind not in FAULTS:
        raise ConfigError("kind", kind, f"one of {', '.join(FAULTS)}")
    if not 1 <= channel <= out.shape[1]:
        raise ConfigError("channel", channel, f"1 to {out.shape[1]}")
    after = np.asarray(time) >= start_s
    k = channel - 1
    if kind == "gain":
        out[after, k] *= 1.0 + size
    elif kind == "jump":
        out[after, k] += size
    elif kind == "frozen":
        out[after, k] = out[int(np.argmax(after)), k]
    else:
        if rail is None:
            raise ConfigError("rail", None, "the reading of a bridge driven to its supply, raw units")
        out[after, k] = rail if kind == "open" else -rail
    return out


def contacts_and_drift(
    time, rng: np.random.Generator, drift_per_s, n_contacts: int, push: float = 15.0, duration_s: float = 2.0, ramp_s: float = 0.1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An offset drift and random pushes on the payload, to add to the wrench the sensor sees.

    Args:
        time: Sample times [s], shape (N,).
        rng: Random generator (the contacts' times and directions).
        drift_per_s: Drift of the offsets per second, [N, N, N, N m, N m, N m], shape (6,).
        n_contacts: Pushes, at random times, each of ``push`` newtons in a random direction for
            ``duration_s``, rising and falling in ``ramp_s``.
        push: Force of a push [N].
        duration_s: Length of a push [s].
        ramp_s: Rise and fall time of a push [s].

    Returns:
        ``(drift (N, 6), contact (N, 6), in_contact (N,) bool)``.
    """
    time = np.asarray(time, dtype=float)
    drift = np.outer(time - time[0], np.asarray(drift_per_s, dtype=float))
    contact = np.zeros((len(time), 6))
    in_contact = np.zeros(len(time), dtype=bool)
    for start in np.sort(rng.uniform(time[0] + 5.0, time[-1] - duration_s, n_contacts)):
        during = (time >= start) & (time < start + duration_s)
        direction = rng.standard_normal(3)
        ramp = np.clip((time[during] - start) / ramp_s, 0, 1) * np.clip((start + duration_s - time[during]) / ramp_s, 0, 1)
        contact[during, :3] += ramp[:, None] * push * direction / np.linalg.norm(direction)
        in_contact |= during
    return drift, contact, in_contact


def offset_watch_trial(seconds: float, contacts: int, rng: np.random.Generator, noise, drift_per_s, full_scale, settle_s: float = 10.0):
    """A simulated service with drifting offsets and pushes, fed window by window to an :class:`OffsetWatch`.

    Args:
        seconds: Length of the service [s] (1 kHz).
        contacts: Number of 15 N pushes of 2 s.
        rng: Random generator.
        noise: Wrench noise per sample, [N, N m], shape (6,).
        drift_per_s: Offset drift per second, shape (6,).
        full_scale: Full scale per axis, shape (6,), for the error in %.
        settle_s: Time the tracker has to learn the rate before errors count [s].

    Returns:
        ``(watch, worst (6,), updated_in_contact)``: the watch, the largest error of the predicted
        offset outside contacts in % of full scale, and the windows touched by a push that updated it.
    """
    from ..monitor.offset_watch import OffsetWatch

    t, w_payload = service_wrenches(seconds, 1000.0, rng)
    drift, contact, in_contact = contacts_and_drift(t, rng, drift_per_s, contacts)
    noise = np.asarray(noise, dtype=float)
    measured = w_payload + drift + contact + rng.standard_normal(w_payload.shape) * noise
    watch = OffsetWatch(noise)
    worst, updated_in_contact = np.zeros(6), 0
    for i in range(0, len(t) - 99, 100):
        before = watch.updates
        watch.update_batch(t[i : i + 100], measured[i : i + 100], w_payload[i : i + 100])
        touched = bool(in_contact[i : i + 100].any())
        updated_in_contact += int(touched and watch.updates > before)
        if not touched and t[i] > settle_s:
            error = watch.predicted(t[i + 99]) - drift[i + 99]
            worst = np.maximum(worst, np.abs(error) / np.asarray(full_scale, dtype=float) * 100)
    return watch, worst, updated_in_contact
