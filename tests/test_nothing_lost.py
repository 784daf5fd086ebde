"""Nothing lost: checkpoints never overwritten unasked, outputs checked first, SIGHUP saves, datagram loss counted."""

import hashlib
import io
import json
import os
import shutil
import signal
import socket
import threading

import numpy as np
import pytest

from fts_calib import FileFormatError, FtsCalibWarning, load_calibration
from fts_calib.app.cli import main
from fts_calib.app.exit_codes import ExitCode
from fts_calib.core.resources import data_dir
from fts_calib.session.calibration_run import LiveRunner, format_stats
from fts_calib.session.checkpoint import HASHED_BYTES, live_source, recording_source
from fts_calib.session.session import CalibrationSession
from fts_calib.sources import source as source_module
from fts_calib.sources.live_feed import LiveFeed, StreamEnd
from fts_calib.sources.sender import ReplayOptions, messages, replay
from fts_calib.sources.synchronizer import Synchronizer
from fts_calib.sources.udp import End, LiveStats, SeqGaps, Strain, ToolChange, UdpReceiver, encode, feed_datagram

from .helpers import DEADLINE_S, live_calibrate, wait_for


def _calibrate(recording, output, *extra):
    return main(
        [
            "calibrate",
            "--robot",
            "ur5",
            "--tool",
            "paper_tool",
            str(recording),
            "-o",
            str(output),
            "--quiet",
            *extra,
        ]
    )


def _one_error_line(capsys, command):
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"fts-calib {command}: error: "), captured.err
    return lines[0], captured.out


@pytest.fixture(scope="module")
def checkpointed(tmp_path_factory, ur5_recording):
    """A finished calibrate run with a checkpoint: (folder, checkpoint, calibration)."""
    folder = tmp_path_factory.mktemp("checkpointed")
    assert _calibrate(ur5_recording, folder / "cal.yaml", "--checkpoint", str(folder / "cp.json")) == 0
    return folder, folder / "cp.json", folder / "cal.yaml"


# --- an existing checkpoint is never overwritten unasked -----------------------------------------------------


def test_calibrate_refuses_an_existing_checkpoint_without_resume_or_restart(tmp_path, ur5_recording, capsys):
    checkpoint = tmp_path / "cp.json"
    checkpoint.write_text("a crashed run's samples")
    assert _calibrate(ur5_recording, tmp_path / "cal.yaml", "--checkpoint", str(checkpoint)) == ExitCode.CONFIG
    line, out = _one_error_line(capsys, "calibrate")
    assert str(checkpoint) in line and "--resume" in line and "--restart" in line, line
    assert checkpoint.read_text() == "a crashed run's samples"
    assert not (tmp_path / "cal.yaml").exists() and out == ""


def test_live_refuses_its_default_checkpoint_without_resume_or_restart(tmp_path, capsys):
    output = tmp_path / "cal.yaml"
    checkpoint = tmp_path / "cal.yaml.checkpoint.json"  # live's default: OUTPUT.checkpoint.json
    checkpoint.write_text("a crashed run's samples")
    assert main(live_calibrate(output, "--quiet")) == ExitCode.CONFIG
    line, out = _one_error_line(capsys, "calibrate")
    assert str(checkpoint) in line and "--resume" in line and "--restart" in line, line
    assert checkpoint.read_text() == "a crashed run's samples" and "listening" not in out


@pytest.mark.parametrize(
    ("flags", "match"),
    [(["--resume", "--restart"], "--resume and --restart exclude each other"), (["--resume"], "give it with --checkpoint FILE")],
)
def test_contradictory_or_incomplete_checkpoint_flags_are_refused(tmp_path, ur5_recording, capsys, flags, match):
    extra = flags + (["--checkpoint", str(tmp_path / "cp.json")] if "--restart" in flags else [])
    assert _calibrate(ur5_recording, tmp_path / "cal.yaml", *extra) == ExitCode.CONFIG
    assert match in _one_error_line(capsys, "calibrate")[0]


def test_the_checkpoint_records_its_recording_and_restart_overwrites_it(tmp_path, checkpointed, ur5_recording, capsys):
    folder, checkpoint, _ = checkpointed
    source = json.loads(checkpoint.read_text())["source"]
    head = ur5_recording.read_bytes()[:HASHED_BYTES]
    assert source == {
        "kind": "recording",
        "path": str(ur5_recording.resolve()),
        "size": ur5_recording.stat().st_size,
        "hashed_bytes": len(head),
        "sha256": hashlib.sha256(head).hexdigest(),
    }
    copy = tmp_path / "cp.json"
    copy.write_text('{"format": "fts-calib-checkpoint/1"}')  # not even a usable checkpoint: --restart does not read it
    assert _calibrate(ur5_recording, tmp_path / "cal.yaml", "--checkpoint", str(copy), "--restart") == 0
    assert json.loads(copy.read_text())["source"] == source


def test_resume_continues_the_same_recording_even_moved(tmp_path, checkpointed, ur5_recording, capsys):
    folder, checkpoint, calibration = checkpointed
    moved = tmp_path / "moved.csv"
    shutil.copyfile(ur5_recording, moved)  # the same bytes under another name: the same recording
    shutil.copyfile(checkpoint, tmp_path / "cp.json")
    assert _calibrate(moved, tmp_path / "cal.yaml", "--checkpoint", str(tmp_path / "cp.json"), "--resume") == 0
    capsys.readouterr()
    got, expected = load_calibration(tmp_path / "cal.yaml"), load_calibration(calibration)
    # every sample is already in the checkpoint: the resumed run adds none and solves the same sums
    assert got.quality.samples_used == expected.quality.samples_used
    assert np.allclose(got.C, expected.C, rtol=0, atol=1e-9 * np.abs(expected.C).max())


def _another_recording(path, ur5_recording):
    lines = ur5_recording.read_text().splitlines(keepends=True)
    fields = lines[1].split(",")
    fields[1] = f"{float(fields[1]) + 1e-3:.6f}"  # one joint reading of the first row differs
    path.write_text(lines[0] + ",".join(fields) + "".join(lines[2:]))
    return path


def test_resume_with_the_checkpoint_of_another_recording_is_refused(tmp_path, checkpointed, ur5_recording, capsys):
    folder, checkpoint, _ = checkpointed
    shutil.copyfile(checkpoint, tmp_path / "cp.json")
    before = (tmp_path / "cp.json").read_bytes()
    truncated = tmp_path / "truncated.csv"
    truncated.write_bytes(ur5_recording.read_bytes()[: ur5_recording.stat().st_size // 2])
    for other in (_another_recording(tmp_path / "other.csv", ur5_recording), truncated):
        assert _calibrate(other, tmp_path / "cal.yaml", "--checkpoint", str(tmp_path / "cp.json"), "--resume") == ExitCode.FILE
        line, _ = _one_error_line(capsys, "calibrate")
        assert f"checkpoint of recording {ur5_recording.resolve()}" in line and f"not of recording {other.resolve()}" in line, line
        assert (tmp_path / "cp.json").read_bytes() == before and not (tmp_path / "cal.yaml").exists()


def test_a_checkpoint_is_resumed_only_with_its_kind_of_source(tmp_path, ur5, paper_tool, ur5_recording):
    live = CalibrationSession(ur5, paper_tool, checkpoint=tmp_path / "live.json", source_record=live_source("127.0.0.1", 5005))
    live.checkpoint()
    with pytest.raises(FileFormatError, match=r"checkpoint of live udp://127.0.0.1:5005, not of recording .*ur5.csv"):
        CalibrationSession.resume(tmp_path / "live.json", ur5, paper_tool, source_record=recording_source(ur5_recording))
    # a live feed may come back on another address
    CalibrationSession.resume(tmp_path / "live.json", ur5, paper_tool, source_record=live_source("127.0.0.1", 6006))
    recorded = CalibrationSession(ur5, paper_tool, checkpoint=tmp_path / "rec.json", source_record=recording_source(ur5_recording))
    recorded.checkpoint()
    with pytest.raises(FileFormatError, match=r"checkpoint of recording .*ur5.csv \([\d,]+ bytes, sha256 \w{12}\), not of live"):
        CalibrationSession.resume(tmp_path / "rec.json", ur5, paper_tool, source_record=live_source("127.0.0.1", 5005))
    state = json.loads((tmp_path / "rec.json").read_text())
    del state["source"]  # a checkpoint of an older version records none: resumed, with a warning
    (tmp_path / "old.json").write_text(json.dumps(state))
    with pytest.warns(FtsCalibWarning, match="records no source"):
        CalibrationSession.resume(tmp_path / "old.json", ur5, paper_tool, source_record=recording_source(ur5_recording))


def test_a_recording_that_grew_is_the_same_one_continued(tmp_path, ur5, paper_tool):
    path = tmp_path / "growing.csv"
    path.write_text("time,j\n0.0,1.0\n")  # shorter than the MiB hashed: the checkpoint hashes it whole
    CalibrationSession(ur5, paper_tool, checkpoint=tmp_path / "cp.json", source_record=recording_source(path)).checkpoint()
    with path.open("a") as handle:
        handle.write("0.1,1.0\n")
    resumed = CalibrationSession.resume(tmp_path / "cp.json", ur5, paper_tool, source_record=recording_source(path))
    assert resumed.source_record == recording_source(path), "the checkpoint goes on with the grown recording"
    path.write_text("time,j\n0.0,2.0\n0.1,1.0\n")
    with pytest.raises(FileFormatError, match="not of recording"):
        CalibrationSession.resume(tmp_path / "cp.json", ur5, paper_tool, source_record=recording_source(path))


# --- -o never one of the inputs, and writable before any work ----------------------------------------------------


def test_output_equal_to_an_input_is_refused_before_any_work(tmp_path, ur5_recording, capsys):
    recording = tmp_path / "rec.csv"
    shutil.copyfile(ur5_recording, recording)
    before = recording.read_bytes()
    cases = [
        (tmp_path / "sub" / ".." / "rec.csv", [], "-o", "the recording"),  # the same file by another spelling
        (tmp_path / "cal.yaml", ["--checkpoint", str(recording)], "--checkpoint", "the recording"),
        (tmp_path / "cal.yaml", ["--checkpoint", str(tmp_path / "cal.yaml")], "--checkpoint", "the file of -o"),
    ]
    for output, extra, flag, what in cases:
        assert _calibrate(recording, output, *extra) == ExitCode.CONFIG
        line, out = _one_error_line(capsys, "calibrate")
        assert f"{flag} " in line and f"is {what}" in line and "choose another file" in line, line
        assert out == "" and recording.read_bytes() == before and not (tmp_path / "cal.yaml").exists()


def test_simulate_refuses_to_write_over_a_trajectory(tmp_path, capsys):
    trajectory = tmp_path / "A.csv.gz"
    shutil.copyfile(data_dir("trajectories") / "ur5" / "A.csv.gz", trajectory)
    before = trajectory.read_bytes()
    for given in (tmp_path, trajectory):  # the folder of trajectories, or the one file
        assert (
            main(["simulate", "--robot", "ur5", "--tool", "paper_tool", "--trajectory", str(given), "-o", str(trajectory)])
            == ExitCode.CONFIG
        )
        line, out = _one_error_line(capsys, "simulate")
        assert f"-o {trajectory} is the trajectory file A.csv.gz" in line, line
        assert trajectory.read_bytes() == before and out == ""


def test_an_output_that_cannot_be_written_is_refused_before_any_work(tmp_path, ur5_recording, capsys):
    (tmp_path / "a_file").write_text("")
    checkpoint = tmp_path / "cp.json"
    for output, reason in [(tmp_path, "it is a folder"), (tmp_path / "a_file" / "cal.yaml", "a_file is a file, not a folder")]:
        assert _calibrate(ur5_recording, output, "--checkpoint", str(checkpoint)) == ExitCode.FILE_ACCESS
        line, out = _one_error_line(capsys, "calibrate")
        assert f"cannot write {output}: " in line and reason in line, line
        assert out == "" and not checkpoint.exists(), "work was done before the output was checked"
    assert _calibrate(ur5_recording, tmp_path / "cal.yaml", "--checkpoint", str(tmp_path)) == ExitCode.FILE_ACCESS
    assert f"cannot write {tmp_path}: it is a folder" in _one_error_line(capsys, "calibrate")[0]
    assert (
        main(
            [
                "simulate",
                "--robot",
                "ur5",
                "--tool",
                "paper_tool",
                "--trajectory",
                str(data_dir("trajectories") / "ur5"),
                "-o",
                str(tmp_path),
            ]
        )
        == 14
    )
    assert "it is a folder" in _one_error_line(capsys, "simulate")[0]
    assert main(live_calibrate(tmp_path, "--quiet")) == ExitCode.FILE_ACCESS
    line, out = _one_error_line(capsys, "calibrate")
    assert "it is a folder" in line and "listening" not in out


def test_export_payload_and_tare_refuse_an_input_or_a_folder_as_output_before_any_work(tmp_path, ur5_recording, capsys):
    """Before: ``export -o calibration.yaml`` replaced the calibration with a C header and exited 0."""
    calibration = tmp_path / "calibration.yaml"
    shutil.copy(data_dir("configs") / "paper_table1_calibration.yaml", calibration)
    kept = {path: path.read_bytes() for path in (calibration, ur5_recording)}
    cases = [
        (["export", "--format", "c-header", "--calibration", str(calibration), "-o", str(calibration)], "is the calibration"),
        (
            ["payload", "--calibration", str(calibration), "--robot", "ur5", str(ur5_recording), "-o", str(ur5_recording)],
            "is the recording",
        ),
        (["tare", "--calibration", str(calibration), str(ur5_recording), "-o", str(ur5_recording)], "is the recording"),
    ]
    for argv, what in cases:
        assert main(argv) == ExitCode.CONFIG, argv
        line, out = _one_error_line(capsys, argv[0])
        assert f"{what}: writing it would destroy it; choose another file" in line and out == "", line
    for argv in (
        ["export", "--format", "json", "--calibration", str(calibration), "-o", str(tmp_path)],
        ["payload", "--calibration", str(calibration), "--robot", "ur5", str(ur5_recording), "-o", str(tmp_path)],
    ):
        assert main(argv) == ExitCode.FILE_ACCESS, argv
        line, out = _one_error_line(capsys, argv[0])
        assert f"cannot write {tmp_path}: it is a folder" in line and out == "", line
    assert all(path.read_bytes() == before for path, before in kept.items()), "an input was changed"


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_folder_is_refused_before_any_work(tmp_path, ur5_recording, capsys):
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        assert _calibrate(ur5_recording, folder / "cal.yaml", "--checkpoint", str(tmp_path / "cp.json")) == ExitCode.FILE_ACCESS
        line, out = _one_error_line(capsys, "calibrate")
        assert f"cannot write {folder / 'cal.yaml'}: Permission denied" in line and out == "", line
        assert not (tmp_path / "cp.json").exists()
    finally:
        folder.chmod(0o755)


# --- SIGHUP saves like Ctrl-C --------------------------------------------------------------------------------


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="no SIGHUP on this system")
def test_sighup_ends_live_with_its_checkpoint_and_calibration_written(tmp_path, monkeypatch, ur5_recording, capsys):
    """`fts-calib live` in this process; the feed on a thread, held back until the receiver has
    everything it sent (no loss on loopback), then SIGHUP instead of an 'end' message."""
    receivers, problems = [], []

    class Receiver(UdpReceiver):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            receivers.append(self)

    def feed():
        try:
            wait_for(lambda: receivers, "the receiver")
            wait_for(lambda: isinstance(getattr(signal.getsignal(signal.SIGHUP), "__self__", None), LiveFeed), "the SIGHUP handler")
            receiver, sent = receivers[0], 0

            def caught_up(count):
                wait_for(lambda: receiver.received >= count, f"{count} datagrams received")

            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
                for _, message in messages(ur5_recording, ReplayOptions()):
                    if isinstance(message, End):
                        break
                    sock.sendto(encode(message), receiver.address)
                    sent += 1
                    if sent % 200 == 0:  # what the socket buffer holds for sure
                        caught_up(sent)
            caught_up(sent)
        except BaseException as exc:  # reported by the test; the live run ends on its idle timeout
            problems.append(exc)
            return
        os.kill(os.getpid(), signal.SIGHUP)

    monkeypatch.setattr(source_module, "UdpReceiver", Receiver)
    output = tmp_path / "cal.yaml"
    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    code = main(live_calibrate(output, "--quiet", "--idle-timeout", "20"))
    thread.join(timeout=DEADLINE_S)
    assert not problems, problems
    out = capsys.readouterr().out
    assert code == 0, out
    assert "stopped after" in out and "0 lost on the way (gaps in seq)" in out, out
    calibration = load_calibration(output)
    state = json.loads((tmp_path / "cal.yaml.checkpoint.json").read_text())
    assert calibration.quality.rank == 7 and sum(state["kept"]) == calibration.quality.samples_used > 0
    assert state["source"] == {"kind": "live", "listen": "udp://127.0.0.1:0"}


# --- datagram loss is visible --------------------------------------------------------------------------------


def test_seq_gaps_count_the_numbers_missing_per_sender():
    gaps = SeqGaps(window=100)
    for seq in [0, 1, 2, 5, 6, 4, 7]:  # 3 lost; 4 late (reordered) fills its place
        gaps.observe("a", seq)
    for seq in [10, 11, 13]:  # another sender, its own numbers: 12 lost
        gaps.observe("b", seq)
    assert gaps.missing == 2 and gaps.sequenced == 10
    for seq in [7, 6, 0, 1]:  # "a" again: duplicates change nothing; 0 far back would be a restart, 0 here is a duplicate
        gaps.observe("a", seq)
    assert gaps.missing == 2
    for seq in [500, 0, 1, 2]:  # 8..499 lost (492), then "a" starts again from 0: a new sequence, no loss
        gaps.observe("a", seq)
    assert gaps.missing == 2 + 492


def test_replay_numbers_its_datagrams_and_the_receiver_counts_what_was_dropped(tmp_path, ur5):
    rows = 300
    header = ["time", *ur5.joint_names, *[f"strain_{k + 1}" for k in range(8)], "tool"]
    lines = [",".join(header)] + [",".join([f"{0.01 * i:.2f}", *["0.1"] * 6, *["0.5"] * 8, "A"]) for i in range(rows)]
    (tmp_path / "rec.csv").write_text("\n".join(lines) + "\n")
    sent = [m.seq for _, m in messages(tmp_path / "rec.csv", ReplayOptions())]
    assert sent == list(range(len(sent))), "replay numbers every message 0, 1, 2, ..."
    receiver, stats = UdpReceiver("127.0.0.1", 0), LiveStats()
    try:
        replayed = replay(tmp_path / "rec.csv", *receiver.address, ReplayOptions(speed=0.0, loss=0.1, reorder=0.1, seed=3))
        wait_for(lambda: receiver.received >= replayed.sent, "every datagram sent")
        for data, sender in receiver.drain_from():
            feed_datagram(data, None, stats, sender)
    finally:
        receiver.close()
    assert replayed.dropped > 0 and replayed.reordered > 0
    assert stats.gaps == replayed.dropped, "each datagram dropped on purpose is one gap; the reordered ones are not"


def _live_run(ur5, paper_tool, datagrams):
    """A LiveRunner over ``datagrams`` (sent before it starts; the last one is 'end'): (stats, status text, sync)."""
    receiver = UdpReceiver("127.0.0.1", 0)
    sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
    status = io.StringIO()
    feed = LiveFeed(receiver, sync, end=StreamEnd(idle_timeout_s=DEADLINE_S), status_interval_s=0.0)
    runner = LiveRunner(CalibrationSession(ur5, paper_tool), feed, status=status)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for data in datagrams:
                sock.sendto(data, receiver.address)
        stats = runner.run()  # ends on the 'end' message
    finally:
        receiver.close()
    return stats, status.getvalue(), sync


def test_lost_datagrams_show_in_the_status_line_and_the_summary(ur5, paper_tool):
    strain = tuple([0.5] * 8)
    with_seq = [ToolChange(0.0, "A", 0), Strain(0.0, strain, 1), Strain(0.01, strain, 4), Strain(0.02, strain, 3), End(6)]
    stats, status, sync = _live_run(ur5, paper_tool, [encode(m) for m in with_seq])
    assert stats.ended and stats.strain == 3 and stats.gaps == 2, "2 and 5 lost; 3 arrived late"
    assert "| lost datagrams 2" in status.splitlines()[-1], status
    assert "2 lost on the way (gaps in seq)" in format_stats(stats, sync)
    without = [ToolChange(0.0, "A"), Strain(0.0, strain), Strain(0.01, strain), End()]
    stats, status, sync = _live_run(ur5, paper_tool, [encode(m) for m in without])
    assert stats.ended and stats.strain == 2 and stats.gaps == 0 and stats.malformed == 0, "seq is optional"
    assert "lost datagrams" not in status and "losses not counted (no datagram with a seq number)" in format_stats(stats, sync)
