"""Every example runs and prints its results beside the expected answer."""

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .paper import ROUNDING, TABLE_1

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))
NUMBER = r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?"


def _numbers(text: str) -> np.ndarray:
    return np.array([float(v) for v in re.findall(NUMBER, text)])


def _line(out: str, pattern: str) -> re.Match:
    match = re.search(pattern, out, flags=re.M)
    assert match, f"no line matching {pattern!r} in:\n{out}"
    return match


def _sensor_online_calibration(out: str) -> None:
    """Three configurations, 2,000 samples each, noise 1e-5 per bridge: rank 4, 6, 7, and C and D
    within their standard errors of the truth."""
    assert [int(r) for r in re.findall(r"^rank of S_XX: (\d)", out, flags=re.M)] == [4, 6, 7]
    c_fx = _numbers(_line(out, r"^C\[Fx\]\s+=(.*)N per").group(1))
    table = _numbers(_line(out, r"^Table 1 =(.*)$").group(1))
    np.testing.assert_array_equal(table, TABLE_1[0], err_msg="the example's truth is Table 1 of the paper")
    stderr = float(_line(out, rf"^stderr of C_bar\[0, 0\]: ({NUMBER})").group(1))
    # a C entry sums up to two C_bar entries (C = C_bar P), each of about this standard error:
    # 5 sigma of sqrt(2) of it, plus the table's rounding and the 4 printed decimals
    assert np.all(np.abs(c_fx - TABLE_1[0]) <= 5 * math.sqrt(2) * stderr + ROUNDING + 5e-5), c_fx - TABLE_1[0]
    D = _numbers(_line(out, r"^D\s+=(.*)\[N").group(1))
    true_D = _numbers(_line(out, r"^true D\s+=(.*)$").group(1))
    rms = _numbers(_line(out, r"^residual RMS:(.*)\[N").group(1))
    # an offset is known to about the residual RMS over sqrt(N) = sqrt(6000): 10 of that, and
    # the 5 printed decimals
    assert np.all(np.abs(D - true_D) <= 10 * rms / math.sqrt(6000) + 1e-5), D - true_D


def _wrench_loop(out: str) -> None:
    """1,000 noisy samples: the RMS error of each axis is the noise through C (its estimate scatters by
    1/sqrt(2 N) = 2.2 %; 20 % is 9 of that, and the 2 printed digits)."""
    rms = _numbers(_line(out, r"^wrench error RMS:(.*)N·m$").group(1))
    expected = _numbers(_line(out, r"^expected RMS:(.*)N·m").group(1))
    assert len(rms) == len(expected) == 6 and np.all(np.abs(rms / expected - 1) <= 0.2), (rms, expected)
    assert float(_line(out, rf"^time per call: ({NUMBER}) µs").group(1)) > 0


def _calibrate_from_arrays(out: str) -> None:
    """C and D within 5 standard errors of the truth (48 + 6 values: P(any outside) < 54 x 6e-7)."""
    assert "rank 7 of 7; fit: consistent" in out, out
    c_fx = _numbers(_line(out, r"^C\[Fx\]\s+=(.*)N per").group(1))
    table = _numbers(_line(out, r"^Table 1 =(.*)$").group(1))
    stderr_c, stderr_d = (_numbers(m) for m in re.findall(r"^stderr  =(.*)$", out, flags=re.M))
    np.testing.assert_array_equal(table, TABLE_1[0], err_msg="the example's truth is Table 1 of the paper")
    assert np.all(np.abs(c_fx - table) <= 5 * stderr_c + 1e-4), (c_fx - table) / stderr_c  # 4 printed decimals
    D, true_D = _numbers(_line(out, r"^D\s+=(.*)\[N").group(1)), _numbers(_line(out, r"^true D\s+=(.*)$").group(1))
    assert np.all(np.abs(D - true_D) <= 5 * stderr_d + 1e-4), D - true_D
    assert 0 < float(_line(out, rf"largest error ({NUMBER}) % of full scale").group(1)) < 1


def _plan_execute_calibrate(out: str) -> None:
    """The plan is safe, the calibration within 5 standard errors, and the measured budget near the predicted one."""
    assert "problems: none" in out and "rank 7 of 7, fit consistent" in out, out
    assert float(_line(out, rf"largest error ({NUMBER}) standard errors").group(1)) <= 5
    D, true_D = _numbers(_line(out, r"^D\s+=(.*)\[N").group(1)), _numbers(_line(out, r"^true D\s+=(.*)$").group(1))
    # 1,100 samples at 2e-3 N of noise: the offsets to about 1e-4 N, printed to 1e-4
    np.testing.assert_allclose(D, true_D, rtol=0, atol=1e-3)
    predicted = float(_line(out, rf"^predicted accuracy: largest error ({NUMBER}) %").group(1))
    measured = float(_line(out, rf"^measured accuracy: largest error ({NUMBER}) %").group(1))
    # the same terms, from the plan's samples and the sensor file's noise, then from the kept samples and their noise
    assert 0.5 <= measured / predicted <= 2, (measured, predicted)


def _export_firmware_ros2(out: str) -> None:
    """The header's loop gives the reader's wrench; the ROS 2 payload is the tool's configuration."""
    header = _numbers(_line(out, r"^header loop:(.*)\[N").group(1))
    reader = _numbers(_line(out, r"^WrenchReader:(.*)\[N").group(1))
    applied = _numbers(_line(out, r"^applied load:(.*)\[N").group(1))
    np.testing.assert_array_equal(header, reader)
    # noiseless channels through a 24-bit ADC and Table 1's 4 decimals: within 1e-3 N and N·m
    np.testing.assert_allclose(reader, applied, rtol=0, atol=1e-3)
    ros2 = _line(out, r"^ROS 2 gravity compensation: mass (.*) kg, CoG \[(.*)\] m in ft_sensor, gravity \[(.*)\] m/s²$")
    expected = _line(out, r"^expected: mass (.*) kg, CoG \[(.*)\] m")
    assert float(ros2.group(1)) == float(expected.group(1))
    np.testing.assert_array_equal(_numbers(ros2.group(2)), _numbers(expected.group(2)))
    np.testing.assert_array_equal(_numbers(ros2.group(3)), [0.0, 0.0, -9.81])


def _ur5_hand_guiding(out: str) -> None:
    """Re-tare, payload, push and overload against their truths and a hand computation."""
    tare = _line(out, r"^1\. re-tare.*D = (.*) \[N, N·m\] \(true (.*)\)$")
    # 500 samples: the offsets to 1e-4 N (noise 2e-3 N over sqrt(500)), printed to 1e-3
    np.testing.assert_allclose(_numbers(tare.group(1)), _numbers(tare.group(2)), rtol=0, atol=1.5e-3)
    payload = _line(out, rf"^2\. payload: ({NUMBER}) ± ({NUMBER}) kg \(true ({NUMBER})\), centre of mass (.*) m \(true (.*)\)$")
    mass, stderr, true_mass = (float(payload.group(k)) for k in (1, 2, 3))
    assert abs(mass - true_mass) <= 5 * stderr + 5e-5, (mass, true_mass)
    np.testing.assert_allclose(_numbers(payload.group(4)), _numbers(payload.group(5)), rtol=0, atol=2e-4)  # [m], 4 decimals
    push = _line(out, rf"^3\. push detected at t = ({NUMBER}) s: F_ext = (.*) N in the world frame \(true (.*)\)$")
    # the push ramps to 12 N in 0.2 s and the loop detects 4 N: at t = 1 + 0.2 * 4 / 12 s, the next 1 ms tick
    assert abs(float(push.group(1)) - (1.0 + 0.2 * 4.0 / 12.0)) <= 1.5e-3, push.group(1)
    # one sample, gravity compensated: the noise (2e-3 N) and the payload's error, printed to 0.01 N
    np.testing.assert_allclose(_numbers(push.group(2)), _numbers(push.group(3)), rtol=0, atol=0.03)
    moved = _numbers(_line(out, r"^\s+push over at .*the tool moved (.*) mm \(expected").group(1))
    # admittance 0.004 m/(N s) times the push's impulse above the 2 N deadband:
    # 12 N x 0.8 s of plateau and ramps, less the two 1/30 s corners below 2 N = 9.533 N s
    impulse = 12.0 * 0.8 - 2 * 0.5 * 2.0 * (0.2 * 2.0 / 12.0)  # [N s]
    assert abs(moved[0] - 1000 * 0.004 * impulse) <= 0.5 and np.all(np.abs(moved[1:]) <= 0.1), moved
    overload = _line(out, rf"^3\. overload: \|F_ext\| = ({NUMBER}) N > 40 N at t = ({NUMBER}) s.*\(true external force ({NUMBER}) N\)")
    seen, t, true_force = (float(overload.group(k)) for k in (1, 2, 3))
    assert t == 3.0 and true_force == 60.0 and abs(seen - true_force) <= 0.1, overload.group(0)


def _own_robot_from_urdf(out: str) -> None:
    """Eqs 17-18 by hand from the printed gravity, mass and centre of mass; |F| = m |g| at every pose."""
    poses = re.split(r"^(?=\S.*: sensor at)", out, flags=re.M)[1:]
    poses[-1] = poses[-1].split("\nexpected")[0]
    assert len(poses) == 2, out
    printed = []
    for pose in poses:
        g = _numbers(_line(pose, r"g_sensor = \[(.*?)\] m/s²").group(1))
        assert abs(np.linalg.norm(g) - 9.81) <= 1e-3, g
        tools = re.findall(r"tool (\w) \(m = (.*?) kg, c = \[(.*?)\] m\): F = \[(.*?)\] N, M = \[(.*?)\] N·m", pose)
        assert [name for name, *_ in tools] == ["A", "B", "C"], pose
        for name, m, c, F, M in tools:
            F_hand = float(m) * g  # eq 17
            M_hand = np.cross(_numbers(c), F_hand)  # eq 18
            # g printed to 1e-3 m/s² (2e-3 N on F), F and M to 1e-3
            np.testing.assert_allclose(_numbers(F), F_hand, rtol=0, atol=3e-3, err_msg=f"F of {name}")
            np.testing.assert_allclose(_numbers(M), M_hand, rtol=0, atol=2e-3, err_msg=f"M of {name}")
        printed.append({name: (_numbers(F), _numbers(M)) for name, _, _, F, M in tools})
    magnitude = float(_line(out, rf"^expected: \|F\| = m \|g\| = ({NUMBER}) N at every pose").group(1))
    for pose in printed:
        for name, (F, _) in pose.items():
            assert abs(np.linalg.norm(F) - magnitude) <= 3e-3, (name, F)  # 3 printed decimals


#: What each example must print, beside its expected answer.
CHECKS = {
    "01_wrench_loop": _wrench_loop,
    "02_gravity_compensation": _ur5_hand_guiding,
    "03_calibrate_from_arrays": _calibrate_from_arrays,
    "04_own_robot_from_urdf": _own_robot_from_urdf,
    "05_plan_execute_calibrate": _plan_execute_calibrate,
    "06_export_firmware_ros2": _export_firmware_ros2,
    "07_online_estimator": _sensor_online_calibration,
}


def test_every_example_has_a_check_a_number_a_docstring_and_a_main_guard():
    assert sorted(CHECKS) == [p.stem for p in EXAMPLES] and len(EXAMPLES) >= 6
    for k, path in enumerate(EXAMPLES, 1):
        text = path.read_text(encoding="utf-8")
        assert path.stem.startswith(f"{k:02d}_"), path.name
        assert text.startswith('"""') and 'if __name__ == "__main__":' in text, path.name


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_prints_results_that_match_the_expected_answer(path, tmp_path):
    # run from another folder: an example finds its data by shipped names, never relative to the working folder
    result = subprocess.run(
        [sys.executable, str(path)], capture_output=True, text=True, timeout=300, env={"MPLBACKEND": "Agg", "PATH": ""}, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    CHECKS[path.stem](result.stdout)
