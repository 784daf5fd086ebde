"""Wrench from raw channels in a 1 kHz control loop, with `WrenchReader`.

A controller holds a calibration file and reads the sensor's raw channels every
millisecond; ``WrenchReader.wrench`` turns them into ``[Fx, Fy, Fz, Mx, My, Mz]`` in the
sensor frame without allocating (it returns a buffer it reuses: copy it to keep it). The
sensor here is the simulated one of the paper (true C = Table 1, noise 1e-5 mV/V per
bridge, 24-bit ADC) under a known load that changes every 250 ms.
"""

import time

import numpy as np

from fts_calib import WrenchReader, load_calibration
from fts_calib.budget.propagation import wrench_noise
from fts_calib.sim.sensor import load_simulated_sensor

RATE_HZ = 1000.0  # [Hz] the control loop
DURATION_S = 1.0  # [s]


def main():
    """Run the loop for one second and print the wrench error and the time per call."""
    sensor = load_simulated_sensor("sensor")  # the "real" sensor: true C = Table 1, offsets D
    calibration = load_calibration("paper_table1_calibration")  # Table 1, offsets not yet known
    calibration = calibration.with_offsets(sensor.D, "offsets of the simulated sensor (a re-tare gives them)")
    reader = WrenchReader(calibration)
    rng = np.random.default_rng(0)
    loads = rng.uniform(-1, 1, (4, 6)) * [20, 20, 20, 2, 2, 2]  # [N, N, N, N·m, N·m, N·m], one per 250 ms
    ticks = int(RATE_HZ * DURATION_S)
    channels = sensor.channels(np.repeat(loads, ticks // 4, axis=0), rng=rng)  # (1000, 8) [mV/V], read tick by tick
    errors = np.empty((ticks, 6))
    spent = 0.0
    for k in range(ticks):
        t0 = time.perf_counter()
        w_sensor = reader.wrench(channels[k])  # (8,) raw -> (6,) [N, N·m]
        spent += time.perf_counter() - t0
        errors[k] = w_sensor - loads[k * 4 // ticks]
    rms = np.sqrt(np.mean(errors**2, axis=0))
    print(f"{ticks} ticks at {RATE_HZ:g} Hz, 4 loads of up to 20 N and 2 N·m")
    print("wrench error RMS:", " ".join(f"{v:.1e}" for v in rms[:3]), "N,", " ".join(f"{v:.1e}" for v in rms[3:]), "N·m")
    expected = wrench_noise(calibration.C, sensor.noise_std)  # sqrt(sum_k C_jk² sigma_k²) per axis
    print("expected RMS:    ", " ".join(f"{v:.1e}" for v in expected[:3]), "N,", " ".join(f"{v:.1e}" for v in expected[3:]), "N·m", end=" ")
    print(f"(the noise of {sensor.noise_std.max():g} mV/V per bridge through C)")
    print(f"time per call: {1e6 * spent / ticks:.1f} µs (expected a few µs: small against the 1000 µs of a tick)")


if __name__ == "__main__":
    main()
