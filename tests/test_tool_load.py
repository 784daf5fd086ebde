"""A tool mass in grams: the data fit it exactly, so the sensor's range must refuse it before any sample is read."""

import dataclasses

import numpy as np
import pytest

from fts_calib import ConfigError
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import data_dir
from fts_calib.model.sensor_config import DEFAULT_FULL_SCALE
from fts_calib.robot.tool import MAX_LOAD_RATIO, STANDARD_GRAVITY, check_tool_load
from fts_calib.session.session import CalibrationSession


def _scaled(tool, factor):
    """The tool with every mass multiplied by ``factor`` (a file written in g: factor 1000)."""
    return dataclasses.replace(tool, configurations=tuple(dataclasses.replace(c, mass=c.mass * factor) for c in tool.configurations))


def test_the_heaviest_tool_the_sensor_can_carry_passes_and_just_beyond_is_refused(paper_tool):
    full_scale = np.array(DEFAULT_FULL_SCALE)  # [N, N, N, N m, N m, N m]: 50 N
    limit = MAX_LOAD_RATIO * 50.0 / STANDARD_GRAVITY / 2.0  # [kg] over the paper tool's 2 kg: the factor at the limit
    check_tool_load(_scaled(paper_tool, 0.999 * limit), full_scale)
    with pytest.raises(ConfigError, match=r"configuration A: mass .* kg weighs about 510 N, 10 times the sensor's full scale of 50 N"):
        check_tool_load(_scaled(paper_tool, 1.02 * limit), full_scale)
    check_tool_load(_scaled(paper_tool, 1.02 * limit), full_scale * 2)  # a sensor twice as strong carries it


def test_a_tool_file_in_grams_is_refused_by_python_and_the_command_before_any_work(tmp_path, ur5, paper_tool, ur5_recording, capsys):
    grams = _scaled(paper_tool, 1000.0)  # 2000 kg: 19,620 N on a 50 N sensor
    with pytest.raises(ConfigError, match=r"mass 2000 kg weighs about 19,620 N, 392 times .* \(grams\?\)"):
        CalibrationSession(ur5, grams)
    text = (data_dir("configs") / "paper_tool.yaml").read_text().replace("mass: 2.0 ", "mass: 2000 ")
    assert text.count("mass: 2000 ") == 1  # configuration A
    tool_file = tmp_path / "tool_in_grams.yaml"
    tool_file.write_text(text)
    output = tmp_path / "cal.yaml"
    assert main(["calibrate", "--robot", "ur5", "--tool", str(tool_file), str(ur5_recording), "-o", str(output)]) == ExitCode.CONFIG
    captured = capsys.readouterr()
    assert captured.err.startswith("fts-calib calibrate: error: tool 'RIM calibration tool', configuration A: mass 2000 kg")
    assert captured.out == "" and not output.exists()
