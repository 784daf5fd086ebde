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
