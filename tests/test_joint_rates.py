"""The one joint-rate estimator, in each of its uses: the quadratic of the quasi-static filter, validation,
the stream-latency estimate and payload from motion; the quintic (or cubic) of the dynamic filter."""

import numpy as np
import pytest

from fts_calib.filters.joint_rates import joint_rates, smoothed_like_acceleration, whole_windows
from fts_calib.filters.quasi_static import QuasiStaticFilter
from fts_calib.filters.settings import FilterConfig

DT = 1e-3  # [s] 1 kHz
RTOL_RATES = 1e-9  # of the largest rate: the FFT's rounding is ~1e-16 of the readings, times the kernels' gains


BINARY_DT = 2.0**-10  # [s] about 1 kHz, sample times exact in binary: no sample on the edge of a 25 ms half-window


def _fit_at(t: np.ndarray, q: np.ndarray, i: int, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration at sample i of a direct least-squares quadratic through the samples ``near`` (indices or mask)."""
    c = np.polynomial.polynomial.polyfit(t[near] - t[i], q[near], 2)  # (3, joints)
    return c[1], 2.0 * c[2]


@pytest.fixture
def readings(rng):
    """Two seconds of three joints moving smoothly, with 1e-5 rad of reading noise, a 100-sample gap in the middle."""
    t = np.arange(2048) * BINARY_DT
    q = np.column_stack([np.sin(1.3 * t), 0.5 * np.cos(0.7 * t + 0.2), 1.0 + 0.2 * t * t]) + 1e-5 * rng.standard_normal((len(t), 3))
    keep = np.ones(len(t), dtype=bool)
    keep[1000:1100] = False  # the windows beside the gap are cut
    return t[keep], q[keep]


def test_the_quadratic_window_is_a_direct_least_squares_fit(readings):
    """The quasi-static filter's rates (50 ms window): at whole windows, at the stream's edges and beside a gap."""
    t, q = readings
    out = joint_rates(t, q, 0.05, BINARY_DT)
    half = 26  # samples each side: round(25 ms / BINARY_DT)
    assert out.check is None and out.full.sum() == len(t) - 4 * half
    scale_v, scale_a = np.abs(out.velocity).max(), np.abs(out.acceleration).max()
    whole = [26, 400, 973]
    # a cut window's fit takes every other sample within 25 ms of it: the widest cut window holds 51,
    # and a quadratic through 32 at most is as good (the other cut windows' samples are taken alike)
    cut = [0, 3, 25, len(t) - 1, 974, 999, 1000, 1003]
    for i in whole + cut:
        assert out.full[i] == (i in whole), i
        if i in whole:
            near = np.abs(np.arange(len(t)) - i) <= half
        else:
            within = np.flatnonzero(np.abs(t - t[i]) <= 0.025)
            near = within[::2]
        velocity, acceleration = _fit_at(t, q, i, near)
        assert np.max(np.abs(out.velocity[i] - velocity)) <= RTOL_RATES * scale_v, (i, out.velocity[i], velocity)
        assert np.max(np.abs(out.acceleration[i] - acceleration)) <= RTOL_RATES * scale_a, (i, out.acceleration[i], acceleration)
    np.testing.assert_array_equal(out.joints[~out.full], q[~out.full])  # at the sample: the cut fit keeps the reading


def test_the_quasi_static_filter_takes_the_quadratic(readings):
    t, q = readings
    filter_ = QuasiStaticFilter(FilterConfig(), np.zeros(3, dtype=bool))
    velocity, acceleration = filter_._joint_rates(t, q)  # its period from the first 100 intervals: BINARY_DT
    out = joint_rates(t, q, FilterConfig().derivative_window_s, BINARY_DT, order=2)
    np.testing.assert_array_equal(velocity, out.velocity)
    np.testing.assert_array_equal(acceleration, out.acceleration)


@pytest.mark.parametrize("order", [3, 5])
def test_the_dynamic_window_is_exact_on_a_polynomial_motion_and_shifts_by_the_latency(order):
    """The dynamic filter's use: 0.3 s, evaluated 8 ms later, the narrower window's check exact too."""
    t = np.arange(0.0, 2.0, DT)
    coefficients = np.array([0.3, -0.2, 0.5, 0.1, -0.05, 0.02])[: order + 1]
    q = np.polynomial.polynomial.polyval(t, coefficients)[:, None]
    out = joint_rates(t, q, 0.3, DT, None, order=order, shift_s=0.008, cut=False, check=True)
    later = t[out.full] + 0.008
    assert out.full.sum() == len(t) - 300
    for name, derivative in (("joints", 0), ("velocity", 1), ("acceleration", 2), ("check", 2)):
        expected = np.polynomial.polynomial.polyval(later, np.polynomial.polynomial.polyder(coefficients, derivative))
        got = getattr(out, name)[out.full, 0]
        assert np.max(np.abs(got - expected)) <= 1e-9 * np.abs(expected).max(), (name, np.max(np.abs(got - expected)))
    assert not out.velocity[~out.full].any() and not out.check[~out.full].any()  # cut windows dropped, not fitted


def test_a_window_holds_a_sample_more_than_the_degree():
    """A quintic through five samples is not determined: those windows count as cut."""
    t = np.arange(0.0, 0.1, DT)
    q = t[:, None] ** 2
    assert not joint_rates(t, q, 0.004, DT, order=5, cut=False).full.any()  # 2 samples each side: 5 in all
    assert joint_rates(t, q, 0.006, DT, order=5, cut=False).full.sum() == len(t) - 6  # 3 each side: 7


def test_the_payload_smoothing_is_the_biweight_kernel_and_leaves_out_windows_with_a_sample_missing(rng):
    t = np.arange(0.0, 1.0, DT)
    t = np.delete(t, 500)  # a sample missing at 0.5 s
    line = np.column_stack([2.0 * t - 1.0, np.full(len(t), 3.0)])
    smoothed, whole = smoothed_like_acceleration(t, line, 0.05, DT)
    near = np.abs(t - 0.5) <= 0.025 + 1e-9
    np.testing.assert_array_equal(whole, whole_windows(t, 25, DT, complete=True))
    assert not whole[near].any() and whole[~near][25:-25].all() and not whole[:25].any() and not whole[-25:].any()
    # a symmetric kernel of unit sum leaves a straight line where the window is evenly spaced
    assert np.max(np.abs(smoothed[whole] - line[whole])) <= 1e-12 * np.abs(line).max()
    values = rng.standard_normal((len(t), 2))
    kernel = (1.0 - (np.arange(-25, 26) / 26) ** 2) ** 2
    i = 100
    expected = kernel @ values[i - 25 : i + 26] / kernel.sum()
    np.testing.assert_allclose(smoothed_like_acceleration(t, values, 0.05, DT)[0][i], expected, rtol=0, atol=1e-12)


def test_the_predicted_budget_propagates_the_noise_through_the_estimators_kernels(rng):
    """The budget's joint-noise term takes the dynamic filter's kernels: the rates of white noise are those kernels applied."""
    from fts_calib.budget.sensitivities import MotionUncertainty

    uncertainty = MotionUncertainty(joint_rate_hz=1000.0, window_s=0.3, order=5)
    kernels = uncertainty.kernels()
    noise = rng.standard_normal((2000, 1))
    out = joint_rates(np.arange(2000) * DT, noise, 0.3, DT, order=5, cut=False)
    i = 1000
    for row, name in enumerate(("joints", "velocity", "acceleration")):
        expected = kernels[row] @ noise[i - 150 : i + 151, 0]
        scale = np.abs(kernels[row]).sum()  # the largest a kernel can make of unit readings
        assert abs(getattr(out, name)[i, 0] - expected) <= 1e-12 * scale, name
