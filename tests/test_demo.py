"""The demo, headless at reduced size: every file, the paper's Fig. 7 story, the targets."""

import io

import numpy as np
import pytest

from fts_calib.app.demo import run_demo

# Left out of the seed sweep: the quick demo plans, simulates, calibrates and validates (about
# 4 s a seed). Its steps are swept one by one: test_calibrate, test_validate, test_estimator.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def demo(tmp_path_factory, seed):
    out = tmp_path_factory.mktemp("demo")
    text = io.StringIO()
    return run_demo(out, seed=seed, quick=True, stream=text), out, text.getvalue()


def test_the_demo_writes_every_file(demo):
    result, out, text = demo
    names = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert names >= {
        "trajectories/A.csv",
        "trajectories/B.csv",
        "trajectories/C.csv",
        "trajectories/plan.yaml",
        "trajectories/plan.png",
        "recordings/calibration.csv",
        "recordings/validation.csv",
        "calibration.yaml",
        "calibration_wrench.png",
        "convergence_c11.png",
        "validation_fx.png",
    }
    for png in out.rglob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    for part in ("largest relative coefficient error", "offset error", "validation over", "less than 10 %", "Table 1 against"):
        assert part in text


def test_fig_7_the_c11_error_drops_at_the_tool_changes_and_ends_at_the_noise_floor(demo):
    """Rank 4 -> 6: the missing directions' bias in C_bar_11 (about 8e-4 of it) goes, a drop of
    40 times or more. Rank 6 -> 7: what is left at rank 6 is a bias of about 7e-6 (noiseless
    data with the same three centres of mass), as large as the quick demo's noise, so whether the error
    just before C is above the final one is left to the seed (4 of 12 seeds say no) and not
    asserted; at the end the error is within the noise."""
    result, _, _ = demo
    curve, starts = result.convergence, [s for s, _ in result.changes]
    assert len(starts) == 3
    before = [curve[np.searchsorted(curve[:, 0], s) - 1, 1] for s in starts[1:]]
    end = curve[-1, 1]
    assert before[0] > 10 * before[1] and before[0] > 10 * end, (before, end)
    se = result.calibration.quality.stderr_C_bar[0, 0] / abs(result.calibration.C_bar[0, 0])
    assert end <= 5 * se, (end, se)  # within the noise (5 sigma, for any seed): the strain noise, not the method


def test_the_quick_demo_meets_the_targets(demo):
    result, _, _ = demo
    assert result.relative_error.max() <= 5e-4  # 0.05 % of each row's largest coefficient
    assert result.validation.errors[0].max_percent.max() <= 0.2  # % of full scale


def test_the_demo_report_in_a_browser(demo, tmp_path):
    # the page the demo writes, rendered by Chromium: no console message, no request out, every section, and the verdict
    # banner (green: the demo's calibration is good) within the first 300 px of a 1200 px wide window
    from .report_checks import banner_rows, check_page, render_in_browser

    _, out, text = demo
    page = out / "report.html"
    assert f"  {page}" in text
    check_page(page.read_text())
    assert page.stat().st_size < 1_000_000  # the size target of the issue
    shot, dom = render_in_browser(page, tmp_path)
    for section in ("verdict", "sphere", "residuals", "budget", "model-selection", "matrix", "offsets", "skipped", "provenance"):
        assert f'id="{section}"' in dom, f"section {section} missing after rendering"
    rows = banner_rows(shot)
    assert rows.size and rows.min() < 300, f"the verdict banner is not at the top of the page (rows {rows[:3]})"
