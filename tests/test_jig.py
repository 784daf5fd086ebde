"""The tool file's check for a sensor model and the jig ``fts-calib trajectory --model`` names instead."""

from __future__ import annotations

import numpy as np
import yaml

from fts_calib.app.cli import main
from fts_calib.planning.jig import check_jig, sphere_directions, suggest_jig
from fts_calib.robot.tool import load_tool

FULL_SCALE = np.array([50.0] * 3 + [5.0] * 3)


def test_suggest_jig_extends_the_paper_tool_to_one_that_determines_the_model_within_the_full_scale(paper_tool):
    for family in ("quadratic", "cubic"):
        assert not check_jig(paper_tool, family).determined
        jig = suggest_jig(paper_tool, family, FULL_SCALE)
        assert check_jig(jig, family).determined, family
        assert jig.configurations[:3] == paper_tool.configurations  # the tool's own first
        masses = sorted({c.mass for c in jig.configurations})
        assert len(masses) == 2 and masses[0] == 2.0
        heaviest = max(c.mass * np.linalg.norm(c.p_sensor_com) for c in jig.configurations) * paper_tool.gravity
        assert heaviest <= 0.86 * FULL_SCALE[3] and masses[1] * paper_tool.gravity <= 0.86 * FULL_SCALE[0]
    # the plan's stops must give each configuration enough orientations: 4 do not, 6 do
    jig = suggest_jig(paper_tool, "quadratic", FULL_SCALE)
    assert not check_jig(jig, "quadratic", directions=sphere_directions(4)).determined
    assert check_jig(jig, "quadratic", directions=sphere_directions(12)).determined


def test_trajectory_model_quadratic_on_the_paper_tool_names_and_writes_the_jig_and_plans_nothing(tmp_path, capsys):
    out = tmp_path / "plan"
    assert main(["trajectory", "--robot", "ur5", "--tool", "paper_tool", "-o", str(out), "--model", "quadratic"]) == 9
    printed = capsys.readouterr().out
    assert "NOT PLANNED: the configurations of 'RIM calibration tool' cannot determine a quadratic model" in printed
    assert "fix 20 of its 26 directions" in printed and "--model quadratic" in printed
    assert sorted(p.name for p in out.iterdir()) == ["suggested_tool.yaml"]
    jig = load_tool(out / "suggested_tool.yaml")
    assert len(jig.configurations) == 10 and check_jig(jig, "quadratic").determined
    assert yaml.safe_load((out / "suggested_tool.yaml").read_text())["configurations"][0]["name"] == "A"
