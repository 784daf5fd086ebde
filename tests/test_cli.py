"""The command line: every command has --help with an example; the demo runs."""

import json
import re
import subprocess
import sys

import pytest

from fts_calib import load_calibration
from fts_calib.app.cli import build_parser, main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import resolve


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


@pytest.mark.slow  # the whole quick demo, about 5 s a seed: left out of the seed sweep (test_demo.py tells why)
def test_demo_command_runs_quick(tmp_path, capsys, seed):
    assert main(["demo", "-o", str(tmp_path), "--quick", "--seed", str(seed)]) == 0
    out = capsys.readouterr().out
    assert "[5/5] validating" in out and "largest validation error" in out
    cal = load_calibration(tmp_path / "calibration.yaml")
    assert cal.quality.rank == 7


def test_the_script_starts_light_and_its_parser_loads_no_pandas():
    """The script's module loads no numpy; its parser no pandas (a usage error or --help answers at once)."""
    code = (
        "import json, sys; import fts_calib.app.cli as cli; light = sorted(sys.modules); cli.build_parser(); "
        "print(json.dumps([light, sorted(sys.modules)]))"
    )
    light, parsed = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert "numpy" not in light, "the fts-calib script imports numpy before main() runs (a Ctrl-C there is a traceback)"
    heavy = {"pandas", "pinocchio", "ruckig", "matplotlib", "rosbags"} & set(parsed)
    assert not heavy, f"building the parser loads {sorted(heavy)}"


def test_ctrl_c_while_the_command_line_is_read_is_one_line_and_exit_130(monkeypatch, capsys):
    import fts_calib.app.parser as arguments

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(arguments, "build_parser", interrupted)
    assert main(["calibrate", "--robot", "ur5", "--tool", "paper_tool", "run.csv"]) == ExitCode.INTERRUPTED == 130
    assert capsys.readouterr().err == "fts-calib: interrupted\n"


def test_the_exit_codes_of_the_help_go_by_number(capsys):
    assert main([]) == 2
    codes = [int(code) for code in re.findall(r"^ +(\d+)  ", capsys.readouterr().out.split("exit codes:")[1], flags=re.M)]
    assert codes == sorted(codes) and {0, 2, 15, 130} <= set(codes), codes


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


def test_trajectory_command_writes_checked_files(tmp_path, capsys, monkeypatch):
    out = tmp_path / "traj"
    monkeypatch.chdir(tmp_path)  # a robot file of the user's own, whose name is not its file's
    robot = resolve("ur5", "robots").read_text(encoding="utf-8").replace("name: ur5", "name: my_ur5")
    (tmp_path / "my_robot.yaml").write_text(robot, encoding="utf-8")
    assert main(["trajectory", "--robot", "my_robot.yaml", "--tool", "paper_tool", "-o", str(out), "--rate", "50"]) == 0
    text = capsys.readouterr().out
    assert "predicted rank 7 of 7" in text and "duration:" in text and "clearance:" in text
    # the robot named as its file names it, a shipped file as such (the same on every machine)
    assert text.startswith("planning my_ur5 sweeps for 'RIM calibration tool' (3 configurations)..."), text[:200]
    assert "robot my_ur5 (my_robot.yaml), tool 'RIM calibration tool' (shipped configs/paper_tool.yaml)" in text
    assert sorted(p.name for p in out.iterdir()) == ["A.csv", "B.csv", "C.csv", "plan.png", "plan.yaml"]


def test_trajectory_command_fails_a_check_and_writes_no_trajectory(tmp_path, capsys):
    out = tmp_path / "traj"
    # 40 cm of clearance cannot be met: the plan is refused, the report says why
    assert main(
        ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out), "--rate", "50", "--min-clearance", "0.4", "--no-plot"]
    ) in (
        ExitCode.CHECK_FAILED,
        ExitCode.TRAJECTORY,
    )
    captured = capsys.readouterr()
    assert "0.4 m" in captured.out + captured.err
    assert not out.exists() or not list(out.glob("*.csv"))


def test_trajectory_command_rejects_a_rate_of_zero(tmp_path, capsys):
    assert main(["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path), "--rate", "0"]) == ExitCode.TRAJECTORY
    assert "rate=0.0 Hz but expected a finite rate > 0" in capsys.readouterr().err


def test_a_plot_that_is_not_an_image_is_refused_before_the_job(capsys):
    """Before: 'validate --plot errors.csv' ran the validation, then died in matplotlib with a traceback."""
    import matplotlib.pyplot as plt

    from fts_calib.app.parser import PLOT_SUFFIXES

    figure = plt.figure()
    supported = figure.canvas.get_supported_filetypes()
    plt.close(figure)
    assert {suffix.lstrip(".") for suffix in PLOT_SUFFIXES} <= set(supported), "a suffix the plots cannot be written in"
    with pytest.raises(SystemExit) as info:
        main(["validate", "--calibration", "c.yaml", "--robot", "ur5", "--tool", "paper_tool", "r.csv", "--plot", "errors.csv"])
    assert info.value.code == ExitCode.USAGE
    assert "argument --plot: 'errors.csv' is not an image file: expected a name ending in .png, .pdf" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["payload", "tare", "calibrate"])
def test_a_bare_mount_says_what_it_takes_and_names_estimate_mount(command, capsys):
    argv = [command, "run.csv", "--mount"]
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "roll, pitch, yaw in rad" in err and "--estimate-mount" in err


def test_the_raster_options_say_the_plan_is_sized_unless_one_fixes_it():
    """``--levels`` once said "default: 4" while an unfixed plan is sized to --target-error: each says when its value applies."""
    from fts_calib.planning.sweeps import SweepPattern

    sub = build_parser()._subparsers._group_actions[0].choices["trajectory"]  # type: ignore[union-attr]
    helps = {a.option_strings[0]: a.help for a in sub._actions if a.option_strings}
    default = SweepPattern()
    for option, value in (("--levels", default.levels), ("--stops", default.stops), ("--dwell", default.dwell), ("--span", default.span)):
        text = helps[option]
        assert "default:" not in text and "sized" in text and text.endswith(f"when another option fixes it: {value:g}"), (option, text)


def test_a_validation_motion_is_planned_for_a_tool_of_one_configuration(tmp_path, capsys):
    """``--tool validation_tool`` (one configuration) once ended "no raster ... meets the target": --validation plans its
    raster, checked for limits and clearance, with no rank or accuracy requirement, and plan.yaml says so."""
    import numpy as np
    import yaml

    out = tmp_path / "val"
    common = ["trajectory", "--robot", "ur5", "--tool", "validation_tool", "-o", str(out), "--rate", "20", "--no-plot"]
    assert main(common) == ExitCode.TRAJECTORY  # a calibration of one centre of mass: refused at once, naming the way out
    err = capsys.readouterr().err
    assert "has 1 configuration (V)" in err and "rank 4 of 7" in err and "--validation" in err, err
    assert main([*common, "--validation", "--levels", "2", "--stops", "3"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("planning ur5 validation sweeps for 'validation payload' (1 configuration)...")
    assert "validation motion (quasi-static samples V: " in printed and "CHECK FAILED" not in printed, printed
    assert "fts-calib validate RECORDING --calibration CALIBRATION --tool validation_tool" in printed
    plan = yaml.safe_load((out / "plan.yaml").read_text())
    assert plan["purpose"] == "validation" and plan["configurations"] == ["V"]
    header = (out / "V.csv").read_text().splitlines()[0].split(",")
    table = np.loadtxt(out / "V.csv", delimiter=",", skiprows=1, usecols=range(len(header) - 1))
    for joint, limits in plan["limits"].items():  # the sweep joints within their velocity limits, from rest
        velocity = table[:, header.index(joint + "_vel")]
        assert np.abs(velocity).max() <= limits["velocity"] * (1 + 1e-9) and velocity[0] == 0.0, joint
    assert main([*common, "--validation", "--motion", "smooth"]) == ExitCode.CONFIG
