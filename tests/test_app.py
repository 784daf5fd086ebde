"""The app stage: each command runs from Python with the CLI's defaults; errors exit with their family's code."""

import argparse
import inspect
import json
import shutil

import pytest
import yaml

from fts_calib import load_calibration
from fts_calib.app import cli, export, robots, setup, tare, trajectory
from fts_calib.app import parser as arguments
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import EXIT_CODES, ExitCode, error_line, exit_code
from fts_calib.app.setup import Setup, SourceOptions
from fts_calib.core import exceptions
from fts_calib.core.exceptions import FtsCalibError, PayloadError
from fts_calib.core.resources import resolve

from .helpers import live_calibrate

CALIBRATION = resolve("paper_table1_calibration", "configs")
GRAVITY_ELSEWHERE = 9.7803  # [m/s²] at the equator: not the default, so the export must read it from the tool file


def _subparsers():
    parser = arguments.build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices


def _recording(path, joint_names, rows=300, strain="0.1", strain_columns=8):
    """A recording of the arm held still: ``rows`` samples at 100 Hz, every strain equal to ``strain``."""
    header = ["time", *joint_names, *[f"strain_{k + 1}" for k in range(strain_columns)], "tool"]
    joints = ["0.0", "-1.5", "1.5", "0.0", "0.3", "0.0"][: len(joint_names)]
    lines = [",".join(header)] + [",".join([f"{0.01 * i:.2f}", *joints, *[strain] * strain_columns, "A"]) for i in range(rows)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def ur5_joints():
    return setup.load_setup("ur5").kinematics.joint_names


# --- the Python entry points, with the defaults of the command line ---------------------------------------------


def _run_of(command):
    import importlib

    return importlib.import_module(f"fts_calib.app.{cli.RUNS.get(command, command)}").run


@pytest.mark.parametrize("command", sorted(arguments.COMMANDS))
def test_every_option_reaches_the_run_function_with_the_same_default(command):
    """Each option is a keyword parameter of ``run`` or a field of a dataclass ``run`` takes (its Setup, SourceOptions, ...):
    the command line and Python take the same arguments, by name, with the same defaults."""
    import dataclasses

    run = _run_of(command)
    parameters = inspect.signature(run).parameters
    parts = cli.parts(run)
    fields = {f.name: (name, f) for name, kind in parts.items() for f in dataclasses.fields(kind)}
    actions = [a for a in _subparsers()[command]._actions if a.dest != "help" and a.help != argparse.SUPPRESS]  # old spellings apart
    reached = set()
    for action in actions:
        required = action.required or (not action.option_strings and action.nargs is None)
        if action.dest in fields:
            part, field = fields[action.dest]
            reached.add(part)
            # a field's None is the command's own default (calibrate's output: calibration.yaml), said in its help
            assert action.default == field.default or field.default is None, (
                f"{command}: {action.dest}: {action.default!r} != {field.default!r}"
            )
            continue
        assert action.dest in parameters, (
            f"{command}: the option {action.dest} is neither a parameter of run() nor a field of {sorted(parts)}"
        )
        parameter = parameters[action.dest]
        reached.add(action.dest)
        if required:
            assert parameter.default is inspect.Parameter.empty, f"{command}: {action.dest} is required on the command line only"
        else:
            assert parameter.default == action.default, f"{command}: default of {action.dest} differs: {parameter.default!r}"
        assert parameter.kind is inspect.Parameter.KEYWORD_ONLY, f"{command}: {action.dest} is not keyword-only"
    assert reached == set(parameters), f"{command}: parameters of run() no option reaches: {set(parameters) - reached}"


@pytest.mark.parametrize("command", sorted(arguments.COMMANDS))
def test_each_help_shows_at_most_six_options_before_the_advanced_groups(command):
    from fts_calib.app.options import ADVANCED, MAIN_OPTIONS

    parser = _subparsers()[command]
    shown = 0
    for group in parser._action_groups:
        if (group.title or "").startswith(ADVANCED):
            break
        shown += sum(1 for a in group._group_actions if a.option_strings and a.dest != "help" and a.help != argparse.SUPPRESS)
    assert shown <= MAIN_OPTIONS, f"{command} shows {shown} options before its advanced groups"
    titles = [group.title or "" for group in parser._action_groups]
    advanced = [k for k, title in enumerate(titles) if title.startswith(ADVANCED)]
    assert advanced == list(range(advanced[0], len(titles))) if advanced else True, (
        f"{command}: a main group after an advanced one: {titles}"
    )


def test_one_meaning_per_flag():
    """A flag is declared once (options.OPTIONS), whichever commands take it."""
    from fts_calib.app.options import OPTIONS
    from fts_calib.app.parser import COMMAND_OPTIONS

    flags = [flag for option in OPTIONS.values() for flag in option.flags]
    assert len(flags) == len(set(flags)), sorted(f for f in flags if flags.count(f) > 1)
    for command, groups in COMMAND_OPTIONS.items():
        for _, uses in groups:
            for item in uses:
                assert item.option is OPTIONS[item.option.name], f"{command}: {item.option.name} is not the declared option"
                assert set(item.changes) <= {"required", "default", "choices", "nargs", "help", "metavar", "dest", "action", "flags"}


def test_robots_from_python(capsys):
    assert robots.run() == 0
    assert "ur5" in capsys.readouterr().out
    assert robots.run(name="ur5") == 0
    assert "sweep joints: wrist_2_joint, wrist_3_joint" in capsys.readouterr().out


def test_trajectory_from_python_with_the_defaults(tmp_path, capsys):
    out = tmp_path / "traj"
    setup = Setup(robot_file="ur5", tool_file="paper_tool")
    assert trajectory.run(setup, trajectory.Sweeps(rate_hz=50.0), output=out, plot=False) == ExitCode.OK
    text = capsys.readouterr().out
    assert "predicted rank 7 of 7" in text and "predicted accuracy budget" in text and "sized to the target 0.05 %" in text
    assert "largest error: " in text and "largest from strain noise alone" in text
    assert sorted(p.name for p in out.iterdir()) == ["A.csv", "B.csv", "C.csv", "plan.yaml"]


def test_export_from_python_takes_gravity_from_the_payload_file(tmp_path, capsys):
    assert export.run(Setup(), calibration=CALIBRATION, output=tmp_path / "c.json") == 0  # json: the suffix says
    assert json.loads((tmp_path / "c.json").read_text())["D"] == load_calibration(CALIBRATION).D.tolist()
    tool = yaml.safe_load(resolve("paper_tool", "configs").read_text())
    tool["gravity"] = GRAVITY_ELSEWHERE
    (tmp_path / "tool.yaml").write_text(yaml.safe_dump(tool))
    assert export.run(Setup(), fmt="ros2", calibration=CALIBRATION, output=tmp_path / "r.yaml", payload=tmp_path / "tool.yaml") == 0
    params = yaml.safe_load((tmp_path / "r.yaml").read_text())
    filter_tool = params["force_torque_sensor_broadcaster"]["ros__parameters"]["sensor_filter_chain"]["filter1"]["params"]["tool"]
    assert filter_tool["mass"] == tool["configurations"][0]["mass"]
    assert filter_tool["gravity_field"] == [0.0, 0.0, -GRAVITY_ELSEWHERE]
    assert "wrote" in capsys.readouterr().out


def test_load_setup_gives_kinematics_tool_and_settings():
    kin, tool, settings = setup.load_setup("ur5")
    assert kin.robot.name == "ur5" and tool.names == ["A", "B", "C"] and settings.filter is not None


def test_tare_from_python_updates_the_file_in_place(tmp_path, ur5_joints, capsys):
    path = shutil.copy(CALIBRATION, tmp_path / "cal.yaml")
    assert tare.run(Setup(), SourceOptions(_recording(tmp_path / "still.csv", ur5_joints)), calibration=path) == 0
    assert len(load_calibration(path).offset_history) == 1
    assert "re-tare from 300 samples" in capsys.readouterr().out


def test_a_run_function_raises_the_error_the_command_line_maps(tmp_path, ur5_joints):
    from fts_calib.app import payload

    one_pose = _recording(tmp_path / "one.csv", ur5_joints)
    with pytest.raises(PayloadError, match="see it along one direction"):
        payload.run(Setup(robot_file="ur5"), SourceOptions(one_pose), calibration=CALIBRATION, output=tmp_path / "p.yaml")


# --- the exit-code table --------------------------------------------------------------------------------------------


def test_the_documented_exit_codes_keep_their_numbers():
    # the README lists these numbers: scripts depend on them
    assert {entry.code.name: int(entry.code) for entry in EXIT_CODES} == {
        "OK": 0,
        "CHECK_FAILED": 1,
        "USAGE": 2,
        "CONFIG": 3,
        "FILE": 4,
        "RECORDING": 5,
        "ROBOT": 6,
        "TOOL_CONFIGURATION": 7,
        "EXCITATION": 8,
        "TRAJECTORY": 9,
        "PAYLOAD": 10,
        "PROTOCOL": 11,
        "ARRAY": 12,
        "OTHER": 13,
        "FILE_ACCESS": 14,
        "POOR_FIT": 15,
        "OUTPUT_IN_USE": 16,
        "RESULT_REFUSED": 17,
        "TIMEOUT": 18,
        "INTERRUPTED": 130,
    }


def test_the_exit_codes_are_distinct_and_cover_every_error_class():
    codes = [entry.code for entry in EXIT_CODES]
    assert len(codes) == len(set(codes)), f"an exit code appears twice: {codes}"
    assert {ExitCode.OK, ExitCode.CHECK_FAILED, ExitCode.USAGE, ExitCode.INTERRUPTED} <= set(codes)
    classes = [c for c in vars(exceptions).values() if isinstance(c, type) and issubclass(c, FtsCalibError) and c is not FtsCalibError]
    for cls in classes:
        code = exit_code(cls.__new__(cls))
        assert code >= 3 and code != ExitCode.OTHER, f"{cls.__name__} has no family of its own in EXIT_CODES"
    assert exit_code(FtsCalibError("x")) == ExitCode.OTHER
    assert exit_code(PermissionError(13, "Permission denied", "out/cal.yaml")) == ExitCode.FILE_ACCESS
    # ResourceNotFound and RobotDataNotFound are FileNotFoundErrors too: their fts-calib family wins
    assert exit_code(exceptions.ResourceNotFound("x", "robot", [])) == ExitCode.FILE
    assert exit_code(exceptions.RobotDataNotFound("install it")) == ExitCode.ROBOT


def test_error_lines_are_one_line():
    assert error_line(PermissionError(13, "Permission denied", "out/cal.yaml")) == "cannot access out/cal.yaml: Permission denied"
    assert error_line(FtsCalibError("first\n  second\n")) == "first second"


def _errors(tmp_path, ur5_joints):
    """(argv, expected code, text in the message) for a representative error of each family."""
    tool = yaml.safe_load(resolve("paper_tool", "configs").read_text())
    tool["configurations"][0]["mass"] = -1.0
    (tmp_path / "bad_tool.yaml").write_text(yaml.safe_dump(tool))
    robot = resolve("ur5", "robots").read_text().replace("parent_frame: tool0", "parent_frame: no_such_frame")
    (tmp_path / "robot.yaml").write_text(robot)
    (tmp_path / "a_file").write_text("")
    no_strain_8 = _recording(tmp_path / "no_strain_8.csv", ur5_joints, rows=3, strain_columns=7)
    still = _recording(tmp_path / "still.csv", ur5_joints)
    not_finite = _recording(tmp_path / "nan.csv", ur5_joints, rows=30, strain="nan")
    cal, out = str(CALIBRATION), str(tmp_path / "out.yaml")
    ros2 = ["export", "--format", "ros2", "--calibration", cal, "-o", out]
    unwritable = str(tmp_path / "a_file" / "c.json")  # its folder is a file
    return [
        (["robots", str(tmp_path / "missing.yaml")], ExitCode.FILE, "missing.yaml: file not found"),
        ([*ros2, "--payload", str(tmp_path / "bad_tool.yaml")], ExitCode.FILE, "mass"),
        ([*ros2, "--payload", "paper_tool", "--configuration", "Z"], ExitCode.TOOL_CONFIGURATION, "'Z'"),
        (ros2, ExitCode.CONFIG, "--payload"),
        (
            ["calibrate", "--robot", "ur5", "--tool", "paper_tool", str(no_strain_8), "--quiet", "-o", out],
            ExitCode.ARRAY,
            "7 channels but the sensor's layout maltese-cross-8 has 8",
        ),
        (["robots", str(tmp_path / "robot.yaml")], ExitCode.ROBOT, "no_such_frame"),
        (["tare", "--calibration", cal, str(not_finite), "-o", out], ExitCode.EXCITATION, "no still sample"),
        (
            ["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(tmp_path / "t"), "--rate", "0"],
            ExitCode.TRAJECTORY,
            "rate=0.0 Hz",
        ),
        (["payload", "--calibration", cal, "--robot", "ur5", str(still), "-o", out], ExitCode.PAYLOAD, "one direction"),
        (["export", "--format", "json", "--calibration", cal, "-o", unwritable], ExitCode.FILE_ACCESS, "cannot write"),
    ]


def test_each_error_family_exits_with_its_code_and_one_line(tmp_path, ur5_joints, capsys):
    for argv, code, text in _errors(tmp_path, ur5_joints):
        assert cli.main(argv) == code, f"fts-calib {' '.join(argv)}"
        captured = capsys.readouterr()
        lines = captured.err.splitlines()
        assert len(lines) == 1, f"fts-calib {argv[0]}: expected one line on stderr, got {lines}"
        assert lines[0].startswith(f"fts-calib {argv[0]}: error: ") and text in lines[0], lines[0]
        assert "Traceback" not in captured.out + captured.err


def test_usage_errors_exit_2_and_ctrl_c_130(monkeypatch, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["replay", "recording.csv", "--to", "no-port"])
    assert info.value.code == ExitCode.USAGE
    assert "expected HOST:PORT" in capsys.readouterr().err

    def interrupted(**options):
        raise KeyboardInterrupt

    monkeypatch.setattr(robots, "run", interrupted)
    assert cli.main(["robots"]) == ExitCode.INTERRUPTED
    assert capsys.readouterr().err.splitlines() == ["fts-calib robots: interrupted"]


# --- help ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", sorted(arguments.COMMANDS))
def test_every_command_help_has_an_example(command, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "example:" in out and f"fts-calib {command}" in out


def test_network_mistakes_are_one_line_with_their_code(tmp_path, capsys):
    """A port in use, an unknown host, a port out of range: no traceback."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        live = live_calibrate(tmp_path / "l.yaml", "--idle-timeout", "1", address=f"127.0.0.1:{port}")
        assert cli.main(live) == ExitCode.FILE_ACCESS
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"cannot use udp://127.0.0.1:{port}: Address already in use" in err, err
    recording = tmp_path / "r.csv"
    strains = ",".join(f"strain_{k}" for k in range(1, 9))
    recording.write_text(f"time,joint,{strains},tool\n0.0,0.1,{','.join(['0.0'] * 8)},A\n")
    assert cli.main(["replay", str(recording), "--to", "no-such-host.invalid:5005"]) == ExitCode.FILE_ACCESS
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "cannot use udp://no-such-host.invalid:5005" in err, err
    with pytest.raises(SystemExit) as usage:
        cli.main(["replay", str(recording), "--to", "127.0.0.1:99999"])
    assert usage.value.code == ExitCode.USAGE and "port 99999" in capsys.readouterr().err


def test_trajectory_target_error_and_a_fixed_raster(tmp_path, capsys):
    out = tmp_path / "traj"
    unreachable = [
        "trajectory",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "-o",
        str(out),
        "--rate",
        "50",
        "--no-plot",
        "--target-error",
        "0.01",
    ]
    assert main(unreachable) == ExitCode.TRAJECTORY
    assert "no plan meets the target of 0.01 % of full scale: sensor mount alone gives" in capsys.readouterr().err
    fixed = [
        "trajectory",
        "--robot",
        "ur5",
        "--tool",
        "paper_tool",
        "-o",
        str(out),
        "--rate",
        "50",
        "--no-plot",
        "--levels",
        "2",
        "--stops",
        "3",
        "--span",
        "0.5",
    ]
    assert main(fixed) == ExitCode.OK
    text = capsys.readouterr().out
    assert "2 levels" in text and "this fixed raster meets the target of 0.05 %" in text
    summary = yaml.safe_load((out / "plan.yaml").read_text())
    assert summary["pattern"]["span"] == 0.5 and summary["accuracy_budget"]["dominant"]["term"] == "sensor mount"
