"""Recordings: streaming in chunks, and every kind of bad input named by line and column."""

import numpy as np
import pytest

from fts_calib import FtsCalibWarning, RecordingError
from fts_calib.core.exceptions import ShapeError
from fts_calib.sources.recording import MALFORMED, UNKNOWN_TOOL, RecordingReader, RecordingWriter

JOINTS = ["j1", "j2"]
HEADER = "time,j1,j2,strain_1,strain_2,strain_3,strain_4,strain_5,strain_6,strain_7,strain_8,tool\n"


def _row(t, tool="A", j=(0.1, 0.2), s=None):
    s = s if s is not None else [0.01 * k for k in range(8)]
    return ",".join(str(v) for v in [t, *j, *s]) + f",{tool}\n"


def _read(path, block_bytes=1 << 20, tools=("A", "B")):
    with RecordingReader(path, JOINTS, list(tools), block_bytes=block_bytes) as reader:
        chunks = list(reader)
    return reader, chunks


@pytest.mark.parametrize("name", ["rec.csv", "rec.csv.gz"])
def test_write_then_read_in_small_chunks(tmp_path, rng, name):
    t = np.arange(1000) / 100
    q = rng.standard_normal((1000, 2))
    s = rng.standard_normal((1000, 8)) * 0.1
    tools = ["A"] * 600 + ["B"] * 400
    with RecordingWriter(tmp_path / name, JOINTS) as writer:
        writer.write(t[:600], q[:600], s[:600], "A")
        writer.write(t[600:], q[600:], s[600:], tools[600:])
    reader, chunks = _read(tmp_path / name, block_bytes=16384)
    assert len(chunks) > 5 and chunks[1].first_line == 2 + len(chunks[0].time)
    np.testing.assert_allclose(np.concatenate([c.time for c in chunks]), t, atol=5e-7)
    np.testing.assert_allclose(np.concatenate([c.joints for c in chunks]), q, atol=5e-10)
    # strains are written as %.9e, a relative rounding of 5e-10 however small the value: here,
    # and only here, a tolerance relative to each entry is the model of the error
    np.testing.assert_allclose(np.concatenate([c.channels for c in chunks]), s, rtol=1e-9)
    assert np.concatenate([c.configuration for c in chunks]).tolist() == [0] * 600 + [1] * 400
    assert reader.skipped == {} and reader.rows_read == 1000


def test_a_failed_write_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), RecordingWriter(tmp_path / "r.csv", JOINTS) as writer:
        writer.write([0.0], [[0, 0]], [[0] * 8], "A")
        raise RuntimeError("robot stopped")
    assert list(tmp_path.iterdir()) == []


def test_missing_column_is_an_error_naming_it(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER.replace("strain_5,", "") + _row(0.0).replace("0.04,", "", 1))
    with pytest.raises(RecordingError, match=r"r.csv, line 1, column 'strain_5': missing column\(s\) \['strain_5'\]"):
        RecordingReader(path, JOINTS, ["A"])
    path.write_text(HEADER.replace("j2,", "") + "0,0.1,0,0,0,0,0,0,0,0,A\n")
    with pytest.raises(RecordingError, match=r"column 'j2': missing column"):
        RecordingReader(path, JOINTS, ["A"])


@pytest.mark.parametrize("n", [6, 7, 12])
def test_any_number_of_channels_round_trips(tmp_path, rng, n):
    s = rng.standard_normal((50, n))
    with RecordingWriter(tmp_path / "r.csv", JOINTS, n) as writer:
        writer.write(np.arange(50) / 100, np.zeros((50, 2)), s, "A")
    assert (tmp_path / "r.csv").read_text().startswith("time,j1,j2," + ",".join(f"strain_{k}" for k in range(1, n + 1)) + ",tool\n")
    reader, chunks = _read(tmp_path / "r.csv")
    assert reader.n_channels == n and chunks[0].channels.shape == (50, n)
    np.testing.assert_allclose(chunks[0].channels, s, rtol=1e-9)
    with (
        pytest.raises(ShapeError, match=rf"channels.shape=\(1, 8\) but expected \(n, {n}\)"),
        RecordingWriter(tmp_path / "w.csv", JOINTS, n) as w,
    ):
        w.write([0.0], [[0, 0]], [[0] * 8], "A")


def test_empty_and_missing_files(tmp_path):
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(RecordingError, match=r"e.csv, line 1: empty file: expected a header line 'time,j1,j2,strain_1"):
        RecordingReader(tmp_path / "e.csv", JOINTS, ["A"])
    with pytest.raises(RecordingError, match="file not found"):
        RecordingReader(tmp_path / "none.csv", JOINTS, ["A"])


def test_extra_columns_are_ignored_with_a_notice(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER.replace(",tool", ",humidity,tool") + _row(0.0).replace(",A", ",41.5,A"))
    with pytest.warns(FtsCalibWarning, match=r"ignoring extra columns \['humidity'\]"):
        reader, chunks = _read(path)
    assert chunks[0].channels.shape == (1, 8) and chunks[0].configuration.tolist() == [0]
    assert chunks[0].temperature is None


def test_the_temperature_column_is_read_and_written(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER.replace(",tool", ",temperature,tool") + _row(0.0).replace(",A", ",21.5,A") + _row(0.1).replace(",A", ",21.75,A"))
    reader, chunks = _read(path)
    assert reader.has_temperature and chunks[0].temperature.tolist() == [21.5, 21.75]
    assert chunks[0].channels.shape == (2, 8) and not reader.extra_columns
    written = tmp_path / "w.csv"
    with RecordingWriter(written, reader.joint_names, 8, temperature=True) as writer:
        writer.write(chunks[0].time, chunks[0].joints, chunks[0].channels, "A", chunks[0].temperature)
    again = _read(written)[1][0]
    np.testing.assert_allclose(again.temperature, [21.5, 21.75])
    np.testing.assert_allclose(again.channels, chunks[0].channels, rtol=1e-9)
    with pytest.raises(ShapeError, match="temperature missing: the file has a temperature column"):
        RecordingWriter(tmp_path / "x.csv", reader.joint_names, 8, temperature=True).write(
            [0.0], chunks[0].joints[:1], chunks[0].channels[:1], "A"
        )


def test_unknown_tool_rows_are_skipped_counted_and_named(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER + _row(0.0) + _row(0.1, "D") + _row(0.2, "D") + _row(0.3, "B"))
    reader, chunks = _read(path)
    assert reader.skipped == {UNKNOWN_TOOL: 2} and reader.unknown_tools == {"D": 2}
    assert "line 3: column 'tool': unknown tool configuration 'D' (known: A, B)" in reader.problems[0]
    assert chunks[0].time.tolist() == [0.0, 0.3]


def test_truncated_last_line_and_bad_numbers_are_skipped_with_line_and_column(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER + _row(0.0) + _row(0.1).replace("0.03", "0.0x") + _row(0.2) + "0.3,0.1,0.2,0.0,0.01")
    reader, chunks = _read(path)
    assert reader.skipped == {MALFORMED: 2}
    assert any("line 3: column 'strain_4': '0.0x' is not a number" in p for p in reader.problems)
    assert any("line 5: truncated (no line end): 5 values but the header has 12 columns" in p for p in reader.problems)
    assert np.concatenate([c.time for c in chunks]).tolist() == [0.0, 0.2]


def test_nan_values_pass_the_reader_for_the_session_to_count(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER + _row(0.0) + _row(0.1, s=[float("nan")] + [0.0] * 7))
    reader, chunks = _read(path)
    assert np.isnan(chunks[0].channels[1, 0]) and reader.skipped == {}


def test_open_reader_takes_joints_from_the_header_and_any_tool(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(HEADER + _row(0.0, "X") + _row(0.1, "Y") + _row(0.2, "X"))
    with RecordingReader(path, None, None) as reader:
        chunk = next(iter(reader))
    assert reader.joint_names == JOINTS and reader.tool_names == ["X", "Y"] and chunk.configuration.tolist() == [0, 1, 0]
