"""README.md and docs/: short, every link inside the repository, every YAML and printed example real.

The printed examples (``<!-- doc-output -->`` and the README's own-robot steps) are run again
by :mod:`tests.docs_outputs`; ``docs/cli.md`` is generated from the argument parser by
:mod:`fts_calib.app.cli_docs`.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import yaml

from fts_calib import load_robot, load_tool
from fts_calib.app.cli_docs import GENERATED_BY, cli_reference
from fts_calib.app.exit_codes import EXIT_CODES, ExitCode

from .docs_outputs import ROOT, commands_of, parse, run_page, workspace

README = ROOT / "README.md"
DOCS = ROOT / "docs"
MAX_README_LINES = 300
MAX_IMAGE_BYTES = 300_000
#: Pages written on other branches of this release (the API, real sensors, safety): linked
#: from here before they are merged. Once they are, this set must be emptied.
PAGES_FROM_OTHER_BRANCHES: set[str] = set()
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
FENCED = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)
#: Files beside a checkout that the repository must not cite (spelt in pieces, so that this file does not cite them).
OUTSIDE = (*(stem + ".md" for stem in ("DESIGN", "STYLE", "paper")), "../" + "shared")


def _pages() -> list[Path]:
    return [README, *sorted(DOCS.glob("*.md"))]


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = FENCED.sub("", page.read_text(encoding="utf-8"))
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.*?)\s*$", text, flags=re.M)}


def _blocks(page: Path, language: str) -> list[str]:
    return [m.group(2) for m in FENCED.finditer(page.read_text(encoding="utf-8")) if m.group(1) == language]


def test_the_readme_is_at_most_300_lines():
    lines = README.read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_README_LINES, f"README.md has {lines} lines, at most {MAX_README_LINES}: move reference material into docs/"


@pytest.mark.parametrize("page", _pages(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_link_resolves_inside_the_repository(page):
    text = FENCED.sub("", page.read_text(encoding="utf-8"))
    bad = []
    for match in LINK.finditer(text):
        target = match.group(1) or match.group(2)
        path_part, _, anchor = target.partition("#")
        if re.match(r"^[a-z][a-z0-9+.-]*:", path_part):
            bad.append(f"{target}: leaves the repository")
            continue
        resolved = (page.parent / path_part).resolve() if path_part else page
        if not resolved.is_relative_to(ROOT):
            bad.append(f"{target}: outside the repository")
        elif not resolved.exists():
            if resolved.relative_to(ROOT).as_posix() not in PAGES_FROM_OTHER_BRANCHES:
                bad.append(f"{target}: no such file")
        elif anchor and resolved.suffix == ".md" and anchor not in _anchors(resolved):
            bad.append(f"{target}: no heading '{anchor}' in {resolved.relative_to(ROOT)}")
    assert not bad, f"{page.relative_to(ROOT)}: " + "; ".join(bad)


def test_the_index_and_the_readme_link_every_docs_page():
    pages = {p.name for p in DOCS.glob("*.md") if p.name != "README.md"} | {Path(p).name for p in PAGES_FROM_OTHER_BRANCHES}
    index = {m.group(1) for m in LINK.finditer((DOCS / "README.md").read_text(encoding="utf-8")) if m.group(1)}
    readme = {m.group(1) for m in LINK.finditer(README.read_text(encoding="utf-8")) if m.group(1)}
    assert pages <= index, f"docs/README.md does not link {sorted(pages - index)}"
    assert {f"docs/{name}" for name in pages} | {"docs/README.md"} <= readme, "README.md links every docs page"


def test_no_tracked_file_cites_a_file_outside_the_repository():
    """A clone holds what git tracks and nothing beside it: no code, test, doc or comment may send a reader elsewhere."""
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True)
    if listed.returncode != 0:
        pytest.skip(f"not a git checkout: {listed.stderr.decode(errors='replace').strip()}")
    tracked = [ROOT / name for name in listed.stdout.decode().split("\0") if name]
    assert README in tracked, "git ls-files lists the repository's files"
    cited = [
        f"{path.relative_to(ROOT)}: {name}" for path in tracked if path.is_file() for name in OUTSIDE if name.encode() in path.read_bytes()
    ]
    assert not cited, "tracked files cite files outside the repository (cite docs/ or tests/data/ instead):\n" + "\n".join(cited)


def test_the_readme_picture_is_small_and_a_png():
    images = [m.group(2) for m in LINK.finditer(README.read_text(encoding="utf-8")) if m.group(2)]
    assert images, "the README shows the demo's plot"
    for image in images:
        path = README.parent / image
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", image
        assert path.stat().st_size < MAX_IMAGE_BYTES, f"{image}: {path.stat().st_size} bytes"


def test_every_yaml_block_of_the_readme_loads_with_the_projects_loaders(tmp_path):
    blocks = _blocks(README, "yaml")
    kinds = []
    for k, block in enumerate(blocks):
        path = tmp_path / f"block{k}.yaml"
        path.write_text(block, encoding="utf-8")
        if "urdf:" in block:
            robot = load_robot(path)
            assert robot.sensor.parent_frame == "tool0", robot
            kinds.append("robot")
        else:
            tool = load_tool(path)
            assert len(tool.configurations) == 3, tool
            # the three centres of mass must not lie on one line (rank 7, paper eqs 18-20)
            com = np.array([c["com"] for c in yaml.safe_load(block)["configurations"]], dtype=float)
            assert np.linalg.matrix_rank(com[1:] - com[0], tol=1e-9) == 2, com
            kinds.append("tool")
    assert sorted(kinds) == ["robot", "tool"], kinds


def test_every_command_of_the_readme_names_its_tool():
    """--tool has no silent default: every documented calibrate, live, trajectory and simulate states it."""
    for page in _pages():
        if page.name == "cli.md":
            continue
        text = page.read_text(encoding="utf-8").replace("\\\n", " ")
        for line in re.findall(
            r"fts-calib (?:calibrate|live|trajectory|simulate)(?=\s)[^\n`]*", text
        ):  # a command, not an error line "fts-calib live: ..."
            if "--help" in line or line.rstrip().endswith(("calibrate", "live", "trajectory", "simulate")):
                continue
            assert "--tool" in line, f"{page.relative_to(ROOT)}: {line}"


# --- docs/cli.md: generated, never stale ------------------------------------------------------------------------------


def test_cli_md_is_what_the_parser_generates():
    committed = (DOCS / "cli.md").read_text(encoding="utf-8")
    assert committed == cli_reference(), f"docs/cli.md is stale: write it again with `{GENERATED_BY}`"


def test_the_exit_code_table_is_complete():
    table = re.findall(r"^\| (\d+) \| `(\w+)` \|", (DOCS / "cli.md").read_text(encoding="utf-8"), flags=re.M)
    assert {int(code): name for code, name in table} == {int(code): code.name for code in ExitCode}
    assert len(table) == len(EXIT_CODES)


def test_every_command_and_option_is_in_cli_md():
    from fts_calib.app.parser import COMMANDS, build_parser

    text = (DOCS / "cli.md").read_text(encoding="utf-8")
    parser = build_parser()
    for name in COMMANDS:
        assert f"## `fts-calib {name}`" in text
        sub = parser._subparsers._group_actions[0].choices[name]  # type: ignore[union-attr]
        for action in sub._actions:
            for option in [] if isinstance(action, argparse._HelpAction) else action.option_strings:
                assert f"`{option}`" in text, f"{name} {option}"


# --- printed examples: run again ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "page",
    [p for p in _pages() if any(s.kind in ("run", "output", "show", "commands") for s in parse(p.read_text(encoding="utf-8")))],
    ids=lambda p: p.relative_to(ROOT).as_posix(),
)
@pytest.mark.slow  # the README's page runs the demo and the own-robot steps: about 8 s of CPU
def test_every_printed_example_is_the_programs_output(page, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    mismatches = run_page(page)
    assert not mismatches, "\n\n".join(str(m) for m in mismatches)


def test_the_readme_runs_the_own_robot_steps_in_order():
    steps = [s for s in parse(README.read_text(encoding="utf-8")) if s.kind == "commands"]
    assert len(steps) == 1
    commands = [c.split()[1] for c in commands_of(README.read_text(encoding="utf-8"), steps[0])]
    assert commands == ["trajectory", "simulate", "calibrate", "validate"], commands


# --- the README's Python: run with the arm and ROS 2 replaced by recorders -------------------------------------------


class _Recorder:
    """Stands in for a robot API: records every call."""

    def __init__(self, log: list, name: str):
        self._log, self._name = log, name

    def __getattr__(self, method):
        def call(*args, **kwargs):
            self._log.append((f"{self._name}.{method}", args, kwargs))
            return self if method in ("send_goal_async", "result", "get_result_async") else 0.0

        return call


def _fake_modules(log: list) -> dict[str, types.ModuleType]:
    """rtde_control, rclpy and the ROS 2 message modules the README's snippets import, as recorders."""

    def module(name, **attributes):
        mod = types.ModuleType(name)
        mod.__dict__.update(attributes)
        return mod

    class Message:
        def __init__(self, **fields):
            self.__dict__.update(fields)

    class Goal:
        def __init__(self):
            self.trajectory = types.SimpleNamespace(joint_names=[], points=[])

    def action_client(node, kind, name):
        log.append(("ActionClient", (name,), {}))
        return _Recorder(log, "client")

    rclpy = module("rclpy", init=lambda: None, shutdown=lambda: None, create_node=lambda name: _Recorder(log, "node"))
    rclpy.spin_until_future_complete = lambda node, future: None  # type: ignore[attr-defined]
    return {
        "rtde_control": module("rtde_control", RTDEControlInterface=lambda host: _Recorder(log, "rtde")),
        "rclpy": rclpy,
        "rclpy.action": module("rclpy.action", ActionClient=action_client),
        "builtin_interfaces": module("builtin_interfaces"),
        "builtin_interfaces.msg": module("builtin_interfaces.msg", Duration=Message),
        "control_msgs": module("control_msgs"),
        "control_msgs.action": module("control_msgs.action", FollowJointTrajectory=types.SimpleNamespace(Goal=Goal)),
        "trajectory_msgs": module("trajectory_msgs"),
        "trajectory_msgs.msg": module("trajectory_msgs.msg", JointTrajectoryPoint=Message),
    }


def test_the_readme_python_plays_the_plan_and_reads_wrenches(monkeypatch):
    """The UR snippets stream every row at the file's period (ur_rtde) or write one servoj per 20 ms
    (URScript, within a·Δt²/8 of the plan), the ROS 2 one sends every row but the first with its time,
    and the in-controller code gives C channels + D."""
    blocks = _blocks(README, "python")
    assert len(blocks) == 4, "the UR (ur_rtde and URScript), ROS 2 and in-controller snippets"
    log: list = []
    for name, mod in _fake_modules(log).items():
        monkeypatch.setitem(sys.modules, name, mod)
    plan = ROOT / "trajectories" / "ur5"
    with workspace() as folder:
        import gzip
        import shutil

        (folder / "plan").mkdir()
        with gzip.open(plan / "A.csv.gz", "rb") as source, open(folder / "plan" / "A.csv", "wb") as target:
            shutil.copyfileobj(source, target)
        with open(folder / "plan" / "A.csv") as file:
            header = file.readline().strip().split(",")
        table = np.loadtxt(folder / "plan" / "A.csv", delimiter=",", skiprows=1, usecols=range(len(header) - 1))
        joint_names = [name for name in header[1:-1] if not name.endswith(("_vel", "_acc"))]
        time = table[:, 0]
        positions = table[:, [header.index(j) for j in joint_names]]
        velocities = table[:, [header.index(j + "_vel") for j in joint_names]]
        n = len(time)

        exec(compile(blocks[0], "README.md (UR)", "exec"), {})
        servo = [args for call, args, _ in log if call == "rtde.servoJ"]
        assert len(servo) == n
        np.testing.assert_allclose(np.array([a[0] for a in servo]), positions, rtol=0, atol=1e-9)
        assert {a[3] for a in servo} == {1.0 / 500.0}  # one row per 2 ms: the default rate of trajectory

        exec(compile(blocks[1], "README.md (URScript)", "exec"), {})
        script = (folder / "plan" / "A.script").read_text().splitlines()
        assert script[0] == "def fts_calib_play():" and script[-2:] == ["  stopj(2.0)", "end"], script[:2] + script[-2:]
        servoj = [line for line in script if line.startswith("  servoj([")]
        # one servoj per 20 ms, the last row too (this plan is at 100 Hz: every 2nd row), not one per row
        period = time[1] - time[0]
        every = round(0.02 / period)
        kept = [*range(0, n, every), n - 1]
        assert len(servoj) == len(kept) and all(f"t={every * period:.4g}," in line for line in servoj), servoj[:2]
        played = np.array([[float(v) for v in line.split("[")[1].split("]")[0].split(",")] for line in servoj])
        np.testing.assert_allclose(played, positions[kept], rtol=0, atol=1e-9)
        # the controller's straight line between two servoj targets stays within a·Δt²/8 of the planned joint path
        accelerations = table[:, [header.index(j + "_acc") for j in joint_names]]
        between = np.column_stack([np.interp(time, time[kept], played[:, k]) for k in range(played.shape[1])])
        bound = np.abs(accelerations).max() * (every * period) ** 2 / 8 + 1e-8  # + the CSV's 9 decimals
        assert np.abs(between - positions).max() <= bound, (np.abs(between - positions).max(), bound)
        assert len("\n".join(script)) < 0.6 * n * 130, "about half the rows of this 100 Hz plan, of ~130 characters each"

        log.clear()
        exec(compile(blocks[2], "README.md (ROS 2)", "exec"), {})
        goal = next(args[0] for call, args, _ in log if call == "client.send_goal_async")
        assert goal.trajectory.joint_names == joint_names
        points = goal.trajectory.points
        assert len(points) == n - 1
        times = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in points])
        np.testing.assert_allclose(times, time[1:], rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.array([p.positions for p in points]), positions[1:], rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.array([p.velocities for p in points]), velocities[1:], rtol=0, atol=1e-9)

        calibration = ROOT / "configs" / "paper_table1_calibration.yaml"
        shutil.copy(calibration, folder / "calibration.yaml")
        scope: dict = {}
        exec(compile(blocks[3], "README.md (controller)", "exec"), scope)
        from fts_calib import load_calibration

        expected = load_calibration(calibration).D  # channels all zero: the wrench is D
        np.testing.assert_allclose(scope["w_sensor"], expected, rtol=0, atol=1e-12)


# --- exit codes: what the pages and --help say is what the code does ----------------------------------------------

#: Words that name a family of errors in prose, beside its exception classes' names (:data:`EXIT_CODES`).
EXIT_WORDS: dict[ExitCode, tuple[str, ...]] = {
    ExitCode.EXCITATION: ("cannot determine C", "insufficient excitation", "too little excitation", "rank below"),
    ExitCode.POOR_FIT: ("poor fit", "does not fit its data"),
    ExitCode.OUTPUT_IN_USE: ("lock is held", "another run is writing"),
    ExitCode.INTERRUPTED: ("Ctrl-C ends",),
}
EXIT_CLAIM = re.compile(r"\bexit(?:s|ing)?(?: with)?(?: status| code)? (\d+)\b", re.I)


def _clauses(text: str) -> list[str]:
    """The prose of a page (fenced blocks dropped), one clause at a time: lines joined, cut at '. ', '; ' and paragraph ends."""
    prose = FENCED.sub("", text)
    return [c for paragraph in re.split(r"\n\s*\n", prose) for c in re.split(r"(?<=[.;])\s+", " ".join(paragraph.split()))]


def _exit_claims() -> list[tuple[str, str]]:
    """(where, clause) of every clause of README.md, docs/ and the commands' --help that names an exit status."""
    from fts_calib.app.parser import COMMANDS, build_parser

    sources = [(page.relative_to(ROOT).as_posix(), page.read_text(encoding="utf-8")) for page in _pages()]
    choices = build_parser()._subparsers._group_actions[0].choices  # type: ignore[union-attr]
    sources += [(f"fts-calib {name} --help", choices[name].format_help()) for name in COMMANDS]
    return [(where, clause) for where, text in sources for clause in _clauses(text) if EXIT_CLAIM.search(clause)]


def test_every_exit_status_the_docs_and_help_claim_is_the_codes():
    """A clause that names a family of errors (its class, or words of :data:`EXIT_WORDS`) and an exit status names its code.

    ``calibrate --help`` once said it "exits 1 when the data cannot determine C" while it exits 8
    (EXCITATION); this reads every such claim of README.md, docs/ and every command's --help.
    """
    codes = {int(code) for code in ExitCode}
    claims = _exit_claims()
    assert len(claims) > 30, f"the pages name exit statuses: {len(claims)} clauses found"
    wrong = []
    for where, clause in claims:
        said = {int(n) for n in EXIT_CLAIM.findall(clause)}
        wrong += [f"{where}: exit {n} is no exit code of fts-calib: {clause}" for n in sorted(said - codes)]
        for entry in EXIT_CODES:
            words = (*(cls.__name__ for cls in entry.errors if cls.__module__.startswith("fts_calib")), *EXIT_WORDS.get(entry.code, ()))
            named = [w for w in words if w.lower() in clause.lower() and w not in ("FtsCalibError",)]
            if named and int(entry.code) not in said:
                wrong.append(f"{where}: names {named[0]!r} (exit {int(entry.code)}) but says exit {sorted(said)}: {clause}")
    assert not wrong, "\n".join(wrong)


def test_what_the_index_says_of_outputs_is_what_a_command_does(tmp_path, capsys):
    """The docs index once promised outputs are "never overwritten" while ``-o`` replaces an existing file: it says so now."""
    from fts_calib.app.cli import main

    for page in (README, DOCS / "README.md"):
        line = next(line for line in page.read_text(encoding="utf-8").splitlines() if "safety.md" in line and "half-written" in line)
        assert "overwritten" not in line and "an existing file is replaced whole" in line, line
    out = tmp_path / "cal.json"
    out.write_text("an earlier export\n", encoding="utf-8")
    assert main(["export", "--format", "json", "--calibration", "paper_table1_calibration", "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").lstrip().startswith("{") and [p.name for p in tmp_path.iterdir()] == ["cal.json"]
    capsys.readouterr()
