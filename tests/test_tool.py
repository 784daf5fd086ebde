"""Tool files and the tool wrench (paper eqs 17-18)."""

import numpy as np
import pytest
import yaml

from fts_calib import ConfigError, FileFormatError, FtsCalibError, FtsCalibWarning, Tool, ToolConfiguration
from fts_calib.core.exceptions import UnknownToolConfiguration
from fts_calib.core.resources import resolve
from fts_calib.robot.tool import ToolShape, ToolTolerance, load_tool, save_tool

from .helpers import random_gravity, tool_wrench

# F = m g and M = c x F: a product and a difference of two, a few eps of the largest entry in
# any order of evaluation; an entry by entry tolerance would fail on moments near zero.
TOL_ROUND_OFF = 1e-14  # of the largest entry


def test_shipped_paper_tool_has_three_non_collinear_configurations():
    tool = load_tool(resolve("paper_tool", "configs"))
    assert tool.names == ["A", "B", "C"] and tool.com_rank() == 2
    assert all(c.inertia_com is not None for c in tool.configurations)


def test_static_wrench_is_eqs_17_18_written_out(rng):
    tool = load_tool(resolve("paper_tool", "configs"))
    g = random_gravity(20, rng)
    for config in tool.configurations:
        expected = tool_wrench(config.mass, config.p_sensor_com, g)
        atol = TOL_ROUND_OFF * np.abs(expected).max()
        np.testing.assert_allclose(config.static_wrench(g), expected, rtol=0, atol=atol, err_msg=f"configuration {config.name}")
        np.testing.assert_allclose(config.static_wrench(g[0]), expected[0], rtol=0, atol=atol, err_msg=f"configuration {config.name}")


def test_unknown_configuration_lists_the_names():
    tool = load_tool(resolve("paper_tool", "configs"))
    with pytest.raises(UnknownToolConfiguration, match="'Z' is not in the tool file; configurations: A, B, C"):
        tool.configuration("Z")


def _tool(tmp_path, configurations, **extra):
    path = tmp_path / "tool.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "configurations": configurations, **extra}))
    return path


@pytest.mark.parametrize(
    ("configs", "match"),
    [
        ([{"name": "A", "mass": -1.0, "com": [0, 0, 0.1]}], r"configurations\[0\].mass': is -1.0 kg but expected a finite value > 0"),
        ([{"name": "A", "com": [0, 0, 0.1]}], r"configurations\[0\].mass': missing"),
        ([{"name": "A", "mass": 1.0}], r"configurations\[0\].com': missing"),
        ([{"name": "A", "mass": 1.0, "com": [0, 0]}], r"configurations\[0\].com': shape \(2,\) but expected \(3,\)"),
        ([{"name": "A", "mass": "heavy", "com": [0, 0, 0]}], r"mass': expected a number in kg, got 'heavy'"),
        ([{"name": "A", "mass": 1, "com": [0, 0, 0]}, {"name": "A", "mass": 1, "com": [0, 0, 1]}], r"duplicate names \['A'\]"),
        ([{"name": "A", "mass": 1, "com": [0, 0, 0], "inertia": [[1, 0, 0], [0, 1, 0], [0, 0, 3]]}], "not physical"),
        ([], "expected a non-empty list"),
    ],
)
def test_bad_tool_files_name_the_field(tmp_path, configs, match):
    with pytest.raises(FileFormatError, match=match):
        load_tool(_tool(tmp_path, configs))


def test_collinear_centres_of_mass_warn(tmp_path):
    configs = [{"name": n, "mass": 1.0, "com": [0.1 * k, 0, 0]} for k, n in enumerate("ABC", 1)]
    with pytest.warns(FtsCalibWarning, match="collinear; the calibration can reach rank 6 at most"):
        tool = load_tool(_tool(tmp_path, configs))
    assert tool.com_rank() == 1


def test_gravity_must_be_positive(tmp_path):
    with pytest.raises(FileFormatError, match="'gravity': is 0.0 m/s² but expected a finite value > 0"):
        load_tool(_tool(tmp_path, [{"name": "A", "mass": 1.0, "com": [0, 0, 0]}], gravity=0.0))


def _config(name="A", mass=1.0, com=(0.0, 0.0, 0.1), inertia=None):
    return ToolConfiguration(name, mass, np.array(com), inertia)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Tool("t", -9.81, (_config(),)), r"tool 't': gravity=-9.81 m/s² but expected a finite value > 0"),
        (lambda: Tool("t", float("nan"), (_config(),)), r"tool 't': gravity=nan m/s² but expected a finite value > 0"),
        (lambda: Tool("t", 9.81, ()), r"tool 't': configurations=\[\] but expected at least one configuration"),
        (lambda: Tool("t", 9.81, (_config("A"), _config("A"))), r"tool 't': configurations has duplicate names \['A'\]"),
        (lambda: _config(mass=0.0), r"configuration 'A': mass=0.0 kg but expected a finite value > 0"),
        (lambda: _config(com=(0.0, float("inf"), 0.0)), r"configuration 'A': p_sensor_com=\[0.0, inf, 0.0\] but expected finite values"),
        (lambda: _config(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), r"configuration 'A': inertia_com is not symmetric"),
        (lambda: _config(inertia=np.diag([1.0, 1.0, 3.0])), r"configuration 'A': inertia_com has principal moments .* not physical"),
        (lambda: ToolShape(radius=-0.05, length=0.1), r"tool shape: radius=-0.05 m but expected a finite value > 0"),
        (lambda: ToolShape(radius=0.05, length=0.0), r"tool shape: length=0.0 m but expected a finite value > 0"),
    ],
)
def test_the_python_api_refuses_what_the_tool_file_refuses(make, match):
    with pytest.raises(ConfigError, match=match) as info:
        make()
    assert isinstance(info.value, FtsCalibError) and isinstance(info.value, ValueError)  # the CLI catches it; ValueError still works


def test_a_bad_value_in_the_file_names_the_file_field_and_value(tmp_path):
    path = _tool(tmp_path, [{"name": "A", "mass": 1.0, "com": [0, 0, 0]}], shape={"radius": -0.05, "length": 0.1})
    with pytest.raises(FileFormatError, match=r"tool.yaml: field 'shape.radius': is -0.05 m but expected a finite value > 0") as info:
        load_tool(path)
    assert info.value.field == "shape.radius" and info.value.path == path
    inertia = [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]
    path = _tool(tmp_path, [{"name": "A", "mass": 1.0, "com": [0, 0, 0]}, {"name": "B", "mass": 1.0, "com": [0, 0, 1], "inertia": inertia}])
    with pytest.raises(FileFormatError, match=r"field 'configurations\[1\].inertia': is not symmetric"):
        load_tool(path)


def test_the_tolerance_is_read_and_a_bad_one_names_the_field(tmp_path):
    configs = [{"name": "A", "mass": 1.0, "com": [0, 0, 0]}]
    tool = load_tool(_tool(tmp_path, configs, tolerance={"mass": 2e-4, "com": 2e-5}))
    assert tool.tolerance == ToolTolerance(mass=2e-4, com=2e-5)
    assert load_tool(_tool(tmp_path, configs)).tolerance is None  # the budget then has no tool terms
    with pytest.raises(FileFormatError, match=r"field 'tolerance.mass': is -0.001 kg but expected a finite value >= 0"):
        load_tool(_tool(tmp_path, configs, tolerance={"mass": -1e-3}))
    with pytest.raises(FileFormatError, match=r"'tolerance'.*'cog'"):
        load_tool(_tool(tmp_path, configs, tolerance={"cog": 1e-3}))


def test_a_tolerance_per_configuration_is_read_and_the_old_form_is_the_conservative_one(tmp_path):
    """``per_configuration`` states each configuration's own part; without it that part is bounded like the common one."""
    configs = [{"name": "A", "mass": 1.2, "com": [0.08, 0, 0]}, {"name": "B", "mass": 1.2, "com": [0.05, 0.06, 0]}]
    old = load_tool(_tool(tmp_path, configs, tolerance={"mass": 1e-5, "com": 5e-4})).tolerance
    assert (old.configuration_mass, old.configuration_com) == (1e-5, 5e-4)  # either way the errors are drawn
    assert (old.total_mass, old.total_com) == pytest.approx((2e-5, 1e-3))
    stated = {"mass": 1e-5, "com": 1e-4, "per_configuration": {"com": 5e-4}}
    tool = load_tool(_tool(tmp_path, configs, tolerance=stated))
    assert tool.tolerance == ToolTolerance(mass=1e-5, com=1e-4, own_mass=0.0, own_com=5e-4)  # a part left out is 0
    assert load_tool(save_tool(tool, tmp_path / "saved.yaml")).tolerance == tool.tolerance
    assert load_tool(
        save_tool(load_tool(_tool(tmp_path, configs, tolerance={"mass": 1e-5})), tmp_path / "o.yaml")
    ).tolerance == ToolTolerance(1e-5)
    bad = {"mass": 1e-5, "per_configuration": {"com": -1e-4}}
    with pytest.raises(FileFormatError, match=r"field 'tolerance.per_configuration.com': is -0.0001 m but expected a finite value >= 0"):
        load_tool(_tool(tmp_path, configs, tolerance=bad))
    with pytest.raises(FileFormatError, match=r"field 'tolerance.per_configuration': unknown keys \['mas'\]"):
        load_tool(_tool(tmp_path, configs, tolerance={"per_configuration": {"mas": 1e-5}}))
    with pytest.raises(FileFormatError, match=r"field 'tolerance.per_configuration.com': is 0.5 m, not below the farthest"):
        load_tool(_tool(tmp_path, configs, tolerance={"per_configuration": {"com": 0.5}}))


def test_a_tolerance_of_the_size_of_the_mass_or_of_the_centre_of_mass_is_a_unit_slip(tmp_path):
    """Before: accepted, and trajectory then said 'tool mass alone gives 1666 %' without naming the file's field."""
    configs = [{"name": "A", "mass": 2.0, "com": [0.0, 0.0, 0.1]}, {"name": "B", "mass": 0.5, "com": [0.05, 0.0, 0.0]}]
    with pytest.raises(FileFormatError, match=r"field 'tolerance.mass': is 0.5 kg, not below the mass of configuration B \(0.5 kg\)"):
        load_tool(_tool(tmp_path, configs, tolerance={"mass": 0.5, "com": 2e-5}))
    with pytest.raises(FileFormatError, match=r"field 'tolerance.com': is 20 m, not below the farthest centre of mass \(0.1 m"):
        load_tool(_tool(tmp_path, configs, tolerance={"mass": 2e-4, "com": 20.0}))
    assert load_tool(_tool(tmp_path, configs, tolerance={"mass": 0.1, "com": 0.01})).tolerance == ToolTolerance(mass=0.1, com=0.01)
