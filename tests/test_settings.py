"""Pipeline settings: the dataclasses refuse what the file loader refuses, the loader names the field."""

import pytest
import yaml

from fts_calib import ConfigError, FileFormatError
from fts_calib.core.resources import resolve
from fts_calib.filters.settings import FilterConfig, LiveConfig, PipelineConfig, load_pipeline_config


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: FilterConfig(strain_window_s=float("inf")), r"filter.strain_window_s=inf but expected a finite value > 0"),
        (lambda: FilterConfig(max_strain_std=0.0), r"filter.max_strain_std=0.0 but expected a value > 0 or 'auto'"),
        (lambda: LiveConfig(max_gap_s=0.0), r"live.max_gap_s=0.0 s but expected a finite value > 0"),
        (lambda: LiveConfig(latency_s=float("nan")), r"live.latency_s=nan s but expected a finite value"),
        (lambda: LiveConfig(checkpoint_interval_s=-5.0), r"live.checkpoint_interval_s=-5.0 s but expected a finite value > 0"),
        (lambda: PipelineConfig(noise_std=0.0), r"design.noise_std=0.0 but expected a finite value > 0"),
    ],
)
def test_the_settings_refuse_bad_values_in_python(make, match):
    with pytest.raises(ConfigError, match=match):
        make()


def test_the_shipped_settings_load():
    config = load_pipeline_config(resolve("pipeline", "configs"))
    assert config.filter.max_joint_speed > 0 and config.live.max_gap_s > 0


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"filter": {"max_joint_speed": 0}}, r"p.yaml: field 'filter.max_joint_speed': is 0.0 but expected a finite value > 0"),
        ({"filter": {"max_strain_std": -1}}, r"field 'filter.max_strain_std': is -1.0 but expected a value > 0 or 'auto'"),
        ({"live": {"max_gap_s": -0.1}}, r"field 'live.max_gap_s': is -0.1 s but expected a finite value > 0"),
        ({"live": {"latency_s": "soon"}}, r"field 'live.latency_s': expected a number in s, got 'soon'"),
        ({"design": {"noise_std": 0}}, r"field 'design.noise_std': is 0.0 but expected a finite value > 0"),
    ],
)
def test_the_loader_names_the_file_and_field_of_a_refused_value(tmp_path, data, match):
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(FileFormatError, match=match) as info:
        load_pipeline_config(path)
    assert info.value.path == path
