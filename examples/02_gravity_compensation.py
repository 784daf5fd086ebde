"""Gravity compensation: hand guiding a UR5 with the calibrated sensor.

The sensor measures the payload's weight as well as a hand pushing the tool. Shown here:
re-tare the offsets with nothing mounted (``estimate_offsets``), identify an unknown
gripper's mass and centre of mass from six still wrist orientations (``identify_payload``),
then a 1 kHz loop where ``GravityCompensator.external`` removes the gripper's weight at
the current orientation, so that an admittance law moves the tool along a push and stops
on an overload. Each result is printed beside the truth of the simulation.
"""

import math

import numpy as np

from fts_calib import GravityCompensator, Kinematics, ToolConfiguration, identify_payload, load_calibration, load_robot, load_tool
from fts_calib.model.retare import estimate_offsets
from fts_calib.sim.sensor import load_simulated_sensor

RATE = 1000.0  # [Hz] the control loop
DETECT = 4.0  # [N] an external force above this is a push: start guiding
DEADBAND = 2.0  # [N] below this the arm holds still
OVERLOAD = 40.0  # [N] above this the loop stops
ADMITTANCE = 0.004  # [m/s per N] tool velocity per newton of external force
HOME = np.array([0.0, -1.2, 1.6, -1.971, -math.pi / 2, 0.0])  # [rad] UR5, tool pointing down


def external_push(t: float) -> np.ndarray:
    """Force of the world on the tool [N], world frame: a hand pushes, later the tool hits something."""
    force = np.zeros(3)
    if 1.0 <= t < 2.0:  # a hand pushes along +x for a second, ramping up and down over 0.2 s
        force[0] = 12.0 * min(1.0, (t - 1.0) / 0.2, (2.0 - t) / 0.2)
    if t >= 3.0:  # a collision: 60 N upwards on the tool tip
        force[2] = 60.0
    return force


def main():
    """Run the loop on a simulated sensor and print what happened."""
    kin = Kinematics(load_robot("ur5"))  # a shipped robot, by name
    sensor = load_simulated_sensor("sensor")  # the "real" sensor, with unknown offsets
    gripper = load_tool("validation_tool").configurations[0]  # the payload, unknown to the loop
    rng = np.random.default_rng(0)
    g_world = kin.g_world(9.81)

    # 1. the calibration of the paper (Table 1) has no offsets: re-tare with nothing mounted, arm still
    calibration = load_calibration("paper_table1_calibration")
    tare = estimate_offsets(calibration.C_bar, sensor.channels(np.zeros((500, 6)), rng=rng))
    calibration = calibration.with_offsets(tare.D, "re-tare, nothing mounted")
    print(
        "1. re-tare, nothing mounted: D = "
        + " ".join(f"{v:+.3f}" for v in calibration.D)
        + " [N, N·m] (true "
        + " ".join(f"{v:+.3f}" for v in sensor.D)
        + ")"
    )

    # 2. the gripper goes on: identify it from six still orientations of the wrist
    W, G = [], []
    for wrist in ([0, 0], [0, 1.5], [1.0, -1.0], [-1.2, 2.5], [0.6, 2.0], [-0.8, -2.2]):
        reading = HOME.copy()
        reading[[3, 5]] += wrist
        g = kin.g_sensor(reading, 9.81)
        channels = sensor.channels(np.tile(gripper.static_wrench(g), (300, 1)), rng=rng)  # 0.3 s still
        W.append(calibration.wrench(channels))
        G.append(np.tile(g, (300, 1)))
    payload = identify_payload(np.vstack(W), np.vstack(G))
    print(
        f"2. payload: {payload.mass:.4f} ± {payload.stderr_mass:.1g} kg (true {gripper.mass}), centre of mass "
        + " ".join(f"{v:+.4f}" for v in payload.com)
        + " m (true "
        + " ".join(f"{v:+.4f}" for v in gripper.p_sensor_com)
        + ")"
    )

    # 3. the control loop: external force in the world frame, admittance on the tool position
    compensator = GravityCompensator(calibration, ToolConfiguration("gripper", payload.mass, payload.com), g_world)
    tip = np.array([0.15, 0.0, 0.0])  # [m] the tool tip in the sensor frame, where a hand or an obstacle acts
    q = HOME.copy()
    start = kin.sensor_pose(q).translation.copy()
    guiding, detected_at, peak, steps = False, None, 0.0, int(4.0 * RATE)
    for k in range(steps):
        t = k / RATE
        R = kin.R_world_sensor(q)
        f_world = external_push(t)
        f_sensor = R.T @ f_world
        truth = gripper.static_wrench(R.T @ g_world) + np.concatenate([f_sensor, np.cross(tip, f_sensor)])
        channels = sensor.channels(truth, rng=rng)  # what the sensor reads at this tick
        external = compensator.external(channels, R, frame="world")
        magnitude = float(np.linalg.norm(external[:3]))
        peak = max(peak, magnitude)
        if magnitude > OVERLOAD:
            print(
                f"3. overload: |F_ext| = {magnitude:.1f} N > {OVERLOAD:.0f} N at t = {t:.3f} s: the loop stops "
                f"(true external force {np.linalg.norm(f_world):.1f} N)"
            )
            break
        if magnitude > DETECT and not guiding:
            guiding, detected_at = True, t
            print(
                f"3. push detected at t = {t:.3f} s: F_ext = "
                + " ".join(f"{v:+.2f}" for v in external[:3])
                + " N in the world frame (true "
                + " ".join(f"{v:+.2f}" for v in f_world)
                + ")"
            )
        if magnitude > DEADBAND:  # move the tool along the force, holding the orientation
            J = kin.jacobian(q)
            velocity = np.concatenate([ADMITTANCE * external[:3], np.zeros(3)])
            q = q + np.linalg.lstsq(J, velocity, rcond=None)[0] / RATE
        elif guiding and magnitude < DEADBAND and detected_at is not None and t > detected_at + 0.3:
            moved = kin.sensor_pose(q).translation - start
            print(
                f"   push over at t = {t:.3f} s: the tool moved "
                + " ".join(f"{1000 * v:+.1f}" for v in moved)
                + " mm (expected along +x only)"
            )
            guiding = False
    print(f"   peak external force seen {peak:.1f} N; quiet ticks below {DEADBAND} N kept the arm still")


if __name__ == "__main__":
    main()
