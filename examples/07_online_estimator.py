"""The estimator alone: online least squares from known wrenches and raw channels (paper eqs 12-18, 21-22).

Below the pipeline (no robot, no filter): ``OnlineEstimator.update_batch(w_sensor,
channels)`` accumulates the sums of one tool configuration at a time; the rank of S_XX
grows 4, 6, 7 as the second and third centres of mass arrive (one centre of mass cannot
separate the offsets from the moments), and ``solve()`` gives C, D and their standard
errors, printed beside the truth (Table 1 of the paper).
"""

import numpy as np

from fts_calib import OnlineEstimator
from fts_calib.robot.tool import static_wrench
from fts_calib.sim.sensor import load_simulated_sensor


def main():
    """Simulate, calibrate and print the result beside the truth."""
    # The shipped simulated sensor: true C = Table 1 of the paper, offsets D, noise 1e-5 mV/V, 24-bit ADC.
    sensor = load_simulated_sensor("sensor")
    rng = np.random.default_rng(0)
    est = OnlineEstimator()
    for p_sensor_com in ([0.12, 0, 0], [0.08, 0.06, 0], [0.08, 0, 0.06]):  # [m], three tool configurations
        g_sensor = rng.standard_normal((2000, 3))
        g_sensor *= 9.81 / np.linalg.norm(g_sensor, axis=1, keepdims=True)  # [m/s²], gravity seen by the sensor
        w_sensor = static_wrench(2.0, p_sensor_com, g_sensor)  # [N, N·m], paper eqs 17-18 with a 2 kg tool
        est.update_batch(w_sensor, sensor.channels(w_sensor, rng=rng))
        print("rank of S_XX:", est.rank()[0], "(expected 4, then 6, then 7)")
    cal = est.solve()
    print("C[Fx]   =", " ".join(f"{v:9.4f}" for v in cal.C[0]), "N per mV/V")
    print("Table 1 =", " ".join(f"{v:9.4f}" for v in sensor.C[0]))
    print("D       =", " ".join(f"{v:+.5f}" for v in cal.D), "[N, N·m]")
    print("true D  =", " ".join(f"{v:+.5f}" for v in sensor.D))
    print("stderr of C_bar[0, 0]:", f"{cal.quality.stderr_C_bar[0, 0]:.1e}", "N per mV/V")
    print("residual RMS:", " ".join(f"{v:.1e}" for v in cal.quality.residual_rms), "[N, N·m]")


if __name__ == "__main__":
    main()
