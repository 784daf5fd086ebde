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


def _ur5_static_wrench(out: str) -> None:
    """Eqs 17-18 by hand from the printed gravity, mass and centre of mass; the expected line."""
    poses = re.split(r"^(?=\S.*: sensor at)", out, flags=re.M)[1:]
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
    expected = _line(out, r"^expected, tool down: F = \[(.*?)\] N for every.*M = c × F = (.*) N·m for A, B, C$")
    for name, M in zip("ABC", re.findall(r"\[(.*?)\]", expected.group(2)), strict=True):
        F_down, M_down = printed[0][name]
        np.testing.assert_array_equal(F_down, _numbers(expected.group(1)), err_msg=f"F of {name}, tool down")
        np.testing.assert_array_equal(M_down, _numbers(M), err_msg=f"M of {name}, tool down")


#: What each example must print, beside its expected answer.
CHECKS = {
    "sensor_online_calibration": _sensor_online_calibration,
    "ur5_hand_guiding": _ur5_hand_guiding,
    "ur5_static_wrench": _ur5_static_wrench,
}


def test_every_example_has_a_check():
    assert sorted(CHECKS) == [p.stem for p in EXAMPLES]


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_prints_results_that_match_the_expected_answer(path):
    result = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=300, env={"MPLBACKEND": "Agg", "PATH": ""})
    assert result.returncode == 0, result.stderr
    CHECKS[path.stem](result.stdout)
