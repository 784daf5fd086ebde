"""A calibration remembers its robot file and tool file: the later commands use them, name a moved or changed one."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.app.setup import Setup
from fts_calib.core.exceptions import ConfigError, FtsCalibWarning
from fts_calib.core.files import file_sha256
from fts_calib.core.resources import resolve
from fts_calib.model.calibration import load_calibration, save_calibration
from fts_calib.planning.trajectory_files import TrajectoryFile
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool
from fts_calib.session.provenance import file_provenance
from fts_calib.sim.runs import simulate_recording
from fts_calib.sim.sensor import load_simulated_sensor

#: A user's tool, lighter than the paper's (1.2 kg against 2 kg): validated against the paper's
#: tool, a good calibration shows errors of several % of full scale.
USER_TOOL = """name: user jig
gravity: 9.81
shape: {radius: 0.08, length: 0.17}
configurations:
  - {name: A, mass: 1.2, com: [0.10, 0.0, 0.0]}
  - {name: B, mass: 1.2, com: [0.06, 0.05, 0.0]}
  - {name: C, mass: 1.2, com: [0.06, 0.0, 0.05]}
"""


def _largest_error(out: str) -> float:
    """The largest 'max, % FS' printed by validate."""
    return max(float(x) for x in re.findall(r"([0-9.]+) %\s+\S+ N(?:·m)?\s+[0-9.]+ %", out))


@pytest.fixture(scope="module")
def user_files(tmp_path_factory, short_plan):
    """A user robot file (the UR5 under another name), a user tool file, a recording made with them and its calibration."""
    folder = tmp_path_factory.mktemp("provenance")
    robot_file = folder / "my_arm.yaml"
    robot_file.write_text(resolve("ur5", "robots").read_text().replace("name: ur5", "name: my_arm", 1))
    tool_file = folder / "my_tool.yaml"
    tool_file.write_text(USER_TOOL)
    kin, tool = Kinematics(load_robot(robot_file)), load_tool(tool_file)
    sensor = load_simulated_sensor(resolve("sensor", "configs"))
    p = short_plan
    runs = [TrajectoryFile(p.joint_names, p.time, p.q, p.qd, p.qdd, c.name) for c in tool.configurations]
    recordings = [
        simulate_recording(folder / f"{n}.csv", kin, tool, runs, sensor, np.random.default_rng(s)) for n, s in (("fit", 1), ("held", 2))
    ]
    cal = folder / "cal.yaml"
    args = ["calibrate", "--robot", str(robot_file), "--tool", str(tool_file), str(recordings[0]), "-o", str(cal), "--quiet"]
    assert main(args) == ExitCode.OK
    return robot_file, tool_file, recordings[1], cal


def test_the_calibration_records_its_files_by_path_and_hash(user_files):
    robot_file, tool_file, _, cal = user_files
    prov = load_calibration(cal).provenance
    assert prov["robot"]["file"] == str(robot_file.absolute()) and prov["robot"]["sha256"] == file_sha256(robot_file)
    assert prov["tools"]["file"] == str(tool_file.absolute()) and prov["tools"]["sha256"] == file_sha256(tool_file)
    shipped = file_provenance(resolve("paper_tool", "configs"), "configs")  # a shipped file: by name, its path differs by installation
    assert shipped == {"shipped": "paper_tool", "sha256": file_sha256(resolve("paper_tool", "configs"))}
    assert file_provenance(None, "robots") == {"file": None}


def test_validate_and_report_use_the_recorded_files(user_files, tmp_path, capsys):
    robot_file, tool_file, held, cal = user_files
    assert main(["validate", "--calibration", str(cal), str(held)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "with 'user jig'" in out and "overrides" not in out
    recorded = _largest_error(out)
    # the paper's tool named: an override, said; the errors are then those of the wrong tool's weight
    assert main(["validate", "--calibration", str(cal), "--tool", "paper_tool", str(held)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert f"--tool paper_tool overrides the tool file {cal} was made with ({tool_file.absolute()}" in out
    assert recorded < 0.1 < _largest_error(out)  # % FS: within the noise, against the 0.8 kg the tools differ by
    assert main(["report", str(cal), str(held), "-o", str(tmp_path / "r.html")]) == ExitCode.OK  # a user robot file: no shipped name needed
    assert main(["tare", "--calibration", str(cal), str(held), "--configuration", "A", "-o", str(tmp_path / "t.yaml")]) != ExitCode.CONFIG


def test_a_changed_or_moved_file_is_named(user_files, tmp_path, capsys):
    robot_file, tool_file, held, cal = user_files
    folder = tmp_path / "copy"
    folder.mkdir()
    robot_copy, tool_copy = folder / "arm.yaml", folder / "tool.yaml"
    shutil.copy(robot_file, robot_copy)
    shutil.copy(tool_file, tool_copy)
    calibration = load_calibration(cal)
    prov = dict(calibration.provenance)
    prov["robot"] = {**prov["robot"], "file": str(robot_copy)}
    prov["tools"] = {**prov["tools"], "file": str(tool_copy)}
    mine = save_calibration(dataclasses.replace(calibration, provenance=prov), tmp_path / "mine.yaml")
    tool_copy.write_text(USER_TOOL.replace("mass: 1.2", "mass: 1.3", 1))  # changed since the calibration
    assert main(["validate", "--calibration", str(mine), str(held)]) == ExitCode.CONFIG
    err = capsys.readouterr().err
    assert f"the tool file {tool_copy}, whose content has changed since" in err and f"--tool {tool_copy}" in err
    assert main(["validate", "--calibration", str(mine), "--tool", str(tool_file), str(held)]) == ExitCode.OK  # an override
    robot_copy.rename(folder / "moved.yaml")
    assert main(["validate", "--calibration", str(mine), "--tool", str(tool_file), str(held)]) == ExitCode.CONFIG
    err = capsys.readouterr().err
    assert f"the robot file {robot_copy}, which is not there any more (moved or deleted): give --robot FILE" in err


def test_an_older_calibration_without_files_asks_for_the_tool(user_files, tmp_path, capsys):
    robot_file, tool_file, held, cal = user_files
    calibration = load_calibration(cal)
    prov = dict(calibration.provenance)
    prov["robot"] = {"name": "my_arm", "urdf": prov["robot"]["urdf"]}
    prov["tools"] = {k: v for k, v in prov["tools"].items() if k not in ("file", "sha256")}
    old = save_calibration(dataclasses.replace(calibration, provenance=prov), tmp_path / "old.yaml")
    assert main(["validate", "--calibration", str(old), "--robot", str(robot_file), str(held)]) == ExitCode.CONFIG
    assert f"{old} does not record the tool file it was made with" in capsys.readouterr().err  # never the paper's tool
    assert main(["validate", "--calibration", str(old), "--robot", str(robot_file), "--tool", str(tool_file), str(held)]) == ExitCode.OK
    assert _largest_error(capsys.readouterr().out) < 0.1


def test_monitor_with_the_robot_takes_the_recorded_tool_as_its_payload(user_files, tmp_path):
    """The offset error of the payload's windows is the noise with the recorded 1.2 kg tool, not the paper's 2 kg one's weight."""
    robot_file, _, held, cal = user_files
    out = tmp_path / "health.json"
    assert main(["monitor", "--calibration", str(cal), "--robot", str(robot_file), str(held), "--json", str(out)]) == ExitCode.OK
    error = np.array(json.loads(out.read_text())["offset"]["error"])
    assert np.all(np.abs(error[:3]) < 0.05), error  # [N]; the 0.8 kg the tools differ by weighs 7.8 N


def test_shipped_files_are_recorded_by_name_and_a_changed_one_is_used_with_a_warning():
    tool_digest = file_sha256(resolve("paper_tool", "configs"))
    provenance = {"robot": {"name": "ur5", "shipped": "ur5", "sha256": "0" * 64}, "tools": {"shipped": "paper_tool", "sha256": tool_digest}}
    with pytest.warns(FtsCalibWarning, match="the shipped robot 'ur5' has changed since cal.yaml was made"):
        setup = Setup().recorded(provenance, "cal.yaml")
    assert (setup.robot_file, setup.tool_file) == ("ur5", "paper_tool")
    gone = {**provenance, "robot": {"shipped": "ur3", "sha256": "0" * 64}}
    with pytest.raises(ConfigError, match="the shipped robot 'ur3', which this fts-calib does not ship: give --robot FILE"):
        Setup().recorded(gone, "cal.yaml")
    orientation = {"robot": {"name": "gimbal", "file": None}, "tools": provenance["tools"]}  # made from orientations: no robot
    assert Setup().recorded(orientation, "cal.yaml").robot_file is None
