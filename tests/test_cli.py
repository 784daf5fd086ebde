"""The command line: every command has --help with an example; the demo runs."""

import pytest

from fts_calib import load_calibration
from fts_calib.cli import build_parser, main


def _commands():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sorted(sub.choices)


@pytest.mark.parametrize("command", _commands())
def test_every_command_has_help_with_an_example(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "example:" in out and f"fts-calib {command}" in out


def test_demo_runs_and_writes_a_calibration(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--samples", "300"]) == 0
    out = capsys.readouterr().out
    assert "rank of S_XX = 4" in out and "rank of S_XX = 6" in out and "rank of S_XX = 7" in out
    cal = load_calibration(tmp_path / "calibration.yaml")
    assert cal.quality.rank == 7


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out
