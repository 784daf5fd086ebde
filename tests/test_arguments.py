"""The command line's help: each command starts with its purpose in one line and an example; no silent default tool."""

import pytest

from fts_calib.app.cli import main
from fts_calib.app.parser import COMMANDS


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_help_starts_with_its_purpose_and_an_example(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith(".") and not lines[0].startswith("usage"), lines[0]
    assert lines[1].startswith(f"example: fts-calib {command}"), lines[:3]


@pytest.mark.parametrize("command", ["calibrate", "live", "trajectory", "simulate"])
def test_a_missing_tool_is_an_error_naming_the_shipped_tools(command, capsys):
    extra = {"calibrate": ["recording.csv"], "simulate": ["--trajectory", "t", "-o", "r.csv"], "trajectory": [], "live": []}[command]
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--robot", "ur5", *extra])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "required: --tool" in err and "--tool paper_tool" in err and "--tool validation_tool" in err, err


# --- old spellings: read for one release, each warned about naming the new one ----------------------------------------

OLD_AND_NEW = [
    (["demo", "--out", "d"], ["demo", "-o", "d"], "--out d is now -o/--output d"),
    (
        ["trajectory", "--robot", "ur5", "--tool", "t", "--out", "p"],
        ["trajectory", "--robot", "ur5", "--tool", "t", "-o", "p"],
        "-o/--output p",
    ),
    (
        ["report", "c.yaml", "-o", "r.html", "--target", "0.1"],
        ["report", "c.yaml", "-o", "r.html", "--target-error", "0.1"],
        "--target-error 0.1",
    ),
    (["calibrate", "r.csv", "--tool", "t", "--no-filter"], ["calibrate", "r.csv", "--tool", "t", "--filter", "none"], "--filter none"),
    (
        ["calibrate", "r.csv", "--tool", "t", "--joints-in-degrees"],
        ["calibrate", "r.csv", "--tool", "t", "--joint-unit", "deg"],
        "--joint-unit deg",
    ),
    (
        ["simulate", "--robot", "ur5", "--tool", "t", "--trajectory", "p", "-o", "r.csv", "--drift", "2e-6"],
        ["simulate", "--robot", "ur5", "--tool", "t", "--trajectory", "p", "-o", "r.csv", "--drift-rate", "2e-6"],
        "--drift-rate 2e-06",
    ),
    (
        ["tare", "--calibration", "c.yaml", "--listen", "127.0.0.1:5005"],
        ["tare", "--calibration", "c.yaml", "udp://127.0.0.1:5005"],
        "udp://",
    ),
    (
        ["monitor", "--calibration", "c.yaml", "--listen"],
        ["monitor", "--calibration", "c.yaml", "udp://127.0.0.1:5005"],
        "udp://127.0.0.1:5005",
    ),
    (
        ["monitor", "--calibration", "c.yaml", "--listen", "127.0.0.1:0", "--quiet"],
        ["monitor", "--calibration", "c.yaml", "udp://127.0.0.1:0", "--quiet"],
        "the source udp://127.0.0.1:0",
    ),
]


def _parsed(argv):
    import warnings

    from fts_calib.app.parser import build_parser

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        namespace = build_parser().parse_args(argv)
    return {k: v for k, v in vars(namespace).items() if k not in ("command", "old_given")}, [str(w.message) for w in caught]


@pytest.mark.parametrize(("old", "new", "named"), OLD_AND_NEW, ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_an_old_spelling_reads_as_the_new_one_and_warns_naming_it(old, new, named):
    """One mechanism (core/deprecation.py: OldFlag, the argparse action OldSpelling) for every old flag, whatever it stood for."""
    from fts_calib.core.deprecation import REMOVED_IN

    (read_old, warned), (read_new, quiet) = _parsed(old), _parsed(new)
    assert read_old == read_new, f"{old} reads otherwise than {new}"
    assert len(warned) == 1 and named in warned[0] and f"goes in fts-calib {REMOVED_IN}" in warned[0], warned
    assert not quiet, f"the new spelling warned: {quiet}"


def test_live_is_calibrate_with_its_sources_and_one_warning_names_the_new_line():
    read_old, warned = _parsed(["live", "--tool", "t", "--ur", "10.0.0.2", "--listen", "127.0.0.1:6000", "--no-filter"])
    read_new, _ = _parsed(["calibrate", "ur://10.0.0.2", "udp://127.0.0.1:6000", "--tool", "t", "--filter", "none"])
    assert read_old == read_new
    assert warned == ["--no-filter is now --filter none; --no-filter goes in fts-calib 0.2"], warned  # live's own: when it runs
    read_default, _ = _parsed(["live", "--tool", "t"])
    assert read_default["names"] == ["udp://127.0.0.1:5005"]  # live's old default address


def test_the_old_live_command_runs_calibrate_and_says_the_new_line(tmp_path, capsys):
    from fts_calib.app.exit_codes import ExitCode

    argv = ["live", "--robot", "ur5", "--tool", "paper_tool", "--listen", "127.0.0.1:0", "-o", str(tmp_path / "c.yaml")]
    assert main([*argv, "--idle-timeout", "0.1", "--quiet"]) == ExitCode.CHECK_FAILED  # nothing came: no calibration, as before
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        "fts-calib: warning: 'fts-calib live --listen 127.0.0.1:0' is now 'fts-calib calibrate udp://127.0.0.1:0' "
        "(the sources as SOURCE arguments); 'live' goes in fts-calib 0.2"
    ]
    assert "listening on udp://127.0.0.1:" in captured.out and "no checkpoint kept" in captured.out


def test_an_old_flag_on_the_command_line_warns_in_one_line_and_the_command_runs(tmp_path, capsys):
    from fts_calib.core.resources import resolve

    out = tmp_path / "c.json"
    assert main(["export", "--calibration", str(resolve("paper_table1_calibration", "configs")), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == f"fts-calib: warning: --out {out} is now -o/--output {out}; --out goes in fts-calib 0.2\n"
    assert out.exists() and "(json, from the suffix .json)" in captured.out


# --- every command line the documentation shows is read by the parser -------------------------------------------------


def documented_command_lines() -> list[tuple[str, str]]:
    """Every ``fts-calib ...`` command line of README.md, docs/ and examples/, with where it is.

    From fenced ``sh``/``text``/``console`` blocks (``$ `` prompts and ``\\`` continuations joined,
    ``#`` comments dropped), the ``<!-- doc-run/doc-output -->`` markers (tests/docs_outputs.py) and
    the examples' text; not the error lines a block shows (``fts-calib NAME: error: ...``) nor
    the synopses of docs/cli.md (``[options]``).
    """
    import re

    from .docs_outputs import MARKER, ROOT

    found = []
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        lines = page.read_text(encoding="utf-8").splitlines()
        fence, current = None, ""
        for number, raw in enumerate(lines, 1):
            marker = MARKER.match(raw.strip())
            if marker and marker.group(1) in ("run", "output") and marker.group(3).startswith("fts-calib "):
                found.append((f"{page.name}:{number}", marker.group(3)))
                continue
            stripped = raw.strip()
            if stripped.startswith(("```", "~~~")):
                fence = None if fence is not None else (stripped.lstrip("`~") or "text")
                continue
            if fence not in ("sh", "text", "console", "bash", "shell"):
                continue
            line = current + stripped.removeprefix("$ ").removesuffix("\\")
            if stripped.endswith("\\"):
                current = line + " "
                continue
            current = ""
            if line.startswith("fts-calib ") and not re.match(r"fts-calib [\w-]+:", line) and "[options]" not in line:
                found.append((f"{page.name}:{number}", line))
    for example in sorted((ROOT / "examples").glob("*.py")):
        for number, raw in enumerate(example.read_text(encoding="utf-8").splitlines(), 1):
            for line in re.findall(r"(fts-calib [a-z]+ [^`\"'\n]*)", raw):
                found.append((f"{example.name}:{number}", line))
    return found


def test_every_documented_command_line_parses():
    """README, docs/ and examples/ show command lines a user copies: each is read by the parser (old spellings with a warning)."""
    import shlex

    lines = documented_command_lines()
    assert len(lines) > 100, f"only {len(lines)} command lines found: the collector lost its way"
    failures = []
    for where, line in lines:
        argv = shlex.split(line, comments=True)[1:]
        try:
            _parsed(argv)
        except SystemExit as exc:
            failures.append(f"{where}: exit {exc.code}: {line}")
    assert not failures, "\n".join(failures)
