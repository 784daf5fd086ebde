"""Checks of an HTML report page shared by the tests: a strict HTML5 parse, self-containment, and a real browser."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fts_calib.report.html import SECTIONS

#: Chromium's executables, Debian's first.
BROWSERS = ("chromium", "chromium-browser", "google-chrome")
#: Longest a browser may take to render the page, [s] (a deadline, never a wait).
BROWSER_TIMEOUT_S = 60
#: Hosts Chromium itself calls (updates, time, accounts) whatever the page: not the page's requests.
BROWSER_OWN_HOSTS = re.compile(r"^https?://([a-z0-9-]+\.)*(google\.com|googleapis\.com|gstatic\.com|googleusercontent\.com)(:\d+)?/")
#: The banner's colour of a good calibration (report_html's CSS ``.good``), RGB.
GOOD_BANNER = (0x1E, 0x84, 0x49)


def check_page(text: str, sections=tuple(s for s, _ in SECTIONS)) -> None:
    """Every section is there, nothing leaves the file, and a strict HTML5 parser accepts it."""
    html5lib = pytest.importorskip("html5lib", reason="html5lib (the dev extra) checks the HTML")
    parser = html5lib.HTMLParser(strict=True)
    parser.parse(text)  # strict: raises on the first parse error
    assert not parser.errors, parser.errors[:3]
    for section in sections:
        assert f'<section id="{section}">' in text, f"section {section} missing"
    assert '<meta name="viewport"' in text and "@media print" in text and "@media (max-width" in text
    self_contained(text)


def self_contained(text: str) -> None:
    """No script, no stylesheet or image file, no reference to anything outside (the SVG namespace is a name, not a request)."""
    for tag in ("<script", "<link", "<img", "<iframe", "<object", "<embed", "url(", "@import"):
        assert tag not in text, f"{tag} in the page"
    references = re.findall(r"""\b(?:src|href|xlink:href|action|data|srcset|poster)\s*=\s*["']?([^"'\s>]+)""", text)
    assert references == [], references


def browser() -> str:
    """Chromium's executable, or skip the test with the reason."""
    for name in BROWSERS:
        found = shutil.which(name)
        if found:
            return found
    pytest.skip("Chromium is not installed (.ci/run installs Debian's chromium where it can): the report is not rendered")


def render_in_browser(page: Path, tmp: Path) -> tuple[Path, str]:
    """Render ``page`` in headless Chromium: its screenshot (PNG) and the DOM after rendering.

    Fails on any console message of the page (an error in it) and on a DOM that refers to
    anything outside the file.
    """
    exe = browser()
    common = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--disable-extensions",
        f"--user-data-dir={tmp / 'profile'}",
        "--enable-logging=stderr",
        "--v=0",
    ]
    shot = tmp / "report.png"
    run = subprocess.run(
        [*common, "--window-size=1200,1600", "--hide-scrollbars", f"--screenshot={shot}", page.as_uri()],
        capture_output=True,
        text=True,
        timeout=BROWSER_TIMEOUT_S,
    )
    netlog = tmp / "netlog.json"
    dom = subprocess.run(
        [*common, f"--log-net-log={netlog}", "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=BROWSER_TIMEOUT_S
    )
    for step in (run, dom):
        assert step.returncode == 0, step.stderr[-2000:]
        console = [line for line in step.stderr.splitlines() if "CONSOLE" in line or "Uncaught" in line]
        assert console == [], console
        requests = [line for line in step.stderr.splitlines() if re.search(r"net::ERR_|https?://(?!www\.w3\.org/2000/svg)", line)]
        assert requests == [], requests
    # every URL the browser's network stack saw while it rendered the page (its netlog), less the browser's own calls
    urls = set(re.findall(r'"url":"([^"]+)"', netlog.read_text(errors="replace")))
    outside = sorted(u for u in urls if not BROWSER_OWN_HOSTS.match(u) and u != page.as_uri())
    assert outside == [], f"the page requested {outside}"
    assert shot.exists() and shot.stat().st_size > 20_000, "no screenshot"
    self_contained(dom.stdout)
    return shot, dom.stdout


def banner_rows(shot: Path, colour=GOOD_BANNER) -> np.ndarray:
    """Rows of the screenshot (px from the top) that hold the verdict banner's colour."""
    from PIL import Image

    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=int)
    match = np.all(np.abs(pixels - np.array(colour)) <= 3, axis=2)
    return np.nonzero(match.sum(axis=1) > 0.5 * pixels.shape[1])[0]


#: Measures, after the page is laid out, what is wider than its box: run on a copy of the page (the page has no script).
_OVERFLOW_PROBE = """<script>
window.addEventListener('load', () => {
  const out = [];
  document.querySelectorAll('*').forEach(e => {
    const box = e.getBoundingClientRect();
    const where = e.tagName + '.' + e.className + ' in #' + ((e.closest('section') || {}).id || '');
    const scrolls = e.scrollWidth > e.clientWidth + 1 && getComputedStyle(e).overflowX !== 'visible';
    if (scrolls) out.push(where + ' scrolls ' + e.scrollWidth + ' > ' + e.clientWidth);
    if (box.right > window.innerWidth + 1) out.push(where + ' ends at ' + Math.round(box.right) + ' > ' + window.innerWidth);
  });
  const pre = document.createElement('pre'); pre.id = 'overflow-probe'; pre.textContent = out.join('\\n'); document.body.appendChild(pre);
});
</script>"""


def overflowing(page: Path, tmp: Path, width: int = 1000) -> list[str]:
    """What scrolls sideways, or ends beyond the window, when ``page`` is shown in a window ``width`` px wide (Chromium)."""
    exe = browser()
    probe = tmp / f"probe_{page.name}"
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", _OVERFLOW_PROBE + "</body>"), encoding="utf-8")
    command = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", f"--user-data-dir={tmp / 'probe_profile'}"]
    dom = subprocess.run(
        [*command, f"--window-size={width},1000", "--virtual-time-budget=2000", "--dump-dom", probe.resolve().as_uri()],
        capture_output=True,
        text=True,
        timeout=BROWSER_TIMEOUT_S,
    )
    found = re.search(r'<pre id="overflow-probe">(.*?)</pre>', dom.stdout, re.S)
    assert found is not None, dom.stderr[-2000:]
    return [line for line in found.group(1).replace("&gt;", ">").splitlines() if line]
