"""Live progress against a sized plan: the motion left and the configuration to mount next."""

import pytest
import yaml

from fts_calib import FileFormatError
from fts_calib.core.resources import resolve
from fts_calib.session.plan_progress import PlanProgress, load_plan_progress
from fts_calib.session.session import Progress

from .helpers import live_calibrate
from .test_planner import ROOT


def progress(**kept):
    return Progress(
        seen=0,
        kept=sum(kept.values()),
        kept_by_configuration=dict(kept),
        rank=0,
        condition_number=0.0,
        missing="",
        skipped={},
        last_time=None,
    )


def test_the_time_left_and_the_configuration_to_mount_follow_the_kept_samples():
    plan = PlanProgress(duration_s=10.0, expected={"A": 100.0, "B": 100.0, "C": 100.0}, target_percent=0.05)
    assert plan.remaining_s(progress(A=0, B=0, C=0)) == pytest.approx(30.0)
    assert plan.status(progress(A=0, B=0, C=0)) == "~30 s of motion left; mount A"
    assert plan.status(progress(A=40, B=0, C=0)) == "~26 s of motion left (A 40 %); mount B next"
    assert plan.status(progress(A=100, B=0, C=0)) == "~20 s of motion left; mount B"
    assert plan.status(progress(A=120, B=100, C=50)) == "~5 s of motion left (C 50 %)"  # more than planned counts as done
    assert plan.next_configuration(progress(A=120, B=100, C=50)) is None
    assert plan.status(progress(A=100, B=99, C=91)) == "plan done: the target (0.05 % of full scale) is reached when the fit is solved"


def test_a_shipped_plan_file_gives_the_expectations_at_the_channel_rate():
    plan = load_plan_progress(ROOT / "trajectories" / "ur5" / "plan.yaml", rate_hz=1000.0)
    assert set(plan.expected) == {"A", "B", "C"} and plan.target_percent == 0.05
    assert plan.duration_s == pytest.approx(13.45, abs=0.01)
    assert plan.expected["A"] == pytest.approx(130 * 10)  # 130 samples at the plan's 100 Hz
    with pytest.raises(FileFormatError, match="duration_s"):
        load_plan_progress(resolve("paper_tool", "configs"), 1000.0)


def test_the_plan_counts_follow_the_rate_the_stream_shows():
    """A 1 kHz sensor's plan replayed at 100 Hz: its counts are a tenth, so the plan is done, not stuck at 9 %."""
    plan = load_plan_progress(ROOT / "trajectories" / "ur5" / "plan.yaml", rate_hz=1000.0)
    at_100 = plan.at_rate(100.0)
    assert at_100.expected["A"] == pytest.approx(130) and at_100.rate_hz == 100.0
    done = progress(A=130, B=int(at_100.expected["B"]), C=int(at_100.expected["C"]))
    assert plan.status(done).startswith("~") and at_100.status(done).startswith("plan done")
    assert plan.at_rate(None) is plan and plan.at_rate(0.0) is plan


@pytest.mark.parametrize(("field", "value"), [("rate_hz", 0), ("duration_s", -1.0)])
def test_a_plan_file_with_a_rate_or_duration_not_above_zero_is_refused_by_name(tmp_path, field, value):
    text = (ROOT / "trajectories" / "ur5" / "plan.yaml").read_text()
    data = yaml.safe_load(text)
    data[field] = value
    path = tmp_path / "plan.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(FileFormatError, match=f"{field}.*{value}"):
        load_plan_progress(path, 1000.0)


def test_the_live_status_line_shows_the_plan(ur5, paper_tool):
    from fts_calib.session.calibration_run import LiveRunner
    from fts_calib.session.session import CalibrationSession
    from fts_calib.sources.live_feed import LiveFeed
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import UdpReceiver

    plan = load_plan_progress(ROOT / "trajectories" / "ur5" / "plan.yaml", rate_hz=1000.0)
    receiver = UdpReceiver("127.0.0.1", 0)
    try:
        sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
        runner = LiveRunner(CalibrationSession(ur5, paper_tool, source="test"), LiveFeed(receiver, sync), plan=plan)
        assert "| ~40 s of motion left; mount A" in runner.status_line()
    finally:
        receiver.close()


def test_live_refuses_the_plan_of_another_robot_and_a_file_that_is_not_a_plan(tmp_path, capsys):
    """Before: the Kinova's plan was taken for the UR5's (the status line then counted the wrong motion)."""
    from fts_calib.app.cli import main
    from fts_calib.app.exit_codes import ExitCode

    out = tmp_path / "cal.yaml"
    run = live_calibrate(out, "--idle-timeout", "0.1", "--quiet", "--plan")
    assert main([*run, str(ROOT / "trajectories" / "kinova" / "plan.yaml")]) == ExitCode.CONFIG
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is a plan of the robot 'kinova' but --robot is 'ur5': give the plan of this robot" in err[0], err
    assert main([*run, str(resolve("paper_table1_calibration", "configs"))]) == ExitCode.FILE
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1 and "paper_table1_calibration.yaml: not a plan: expected the plan.yaml that 'fts-calib trajectory' writes" in err[0]
    )
    assert not list(tmp_path.iterdir())  # neither the calibration nor a checkpoint


def test_the_live_runner_measures_the_stream_rate_on_the_stream_clock(ur5, paper_tool):
    from fts_calib.session.calibration_run import LiveRunner
    from fts_calib.session.session import CalibrationSession
    from fts_calib.sources.live_feed import LiveFeed
    from fts_calib.sources.synchronizer import Synchronizer
    from fts_calib.sources.udp import UdpReceiver

    receiver = UdpReceiver("127.0.0.1", 0)
    try:
        sync = Synchronizer(ur5.joint_names, ur5.continuous, 0.05, 0.0, configurations=paper_tool.names)
        feed = LiveFeed(receiver, sync)
        runner = LiveRunner(CalibrationSession(ur5, paper_tool, source="test"), feed)
        sync.add_tool(0.0, "A")
        for k in range(301):  # 3 s at 100 Hz, joints and strains on one clock
            t = 0.01 * k
            sync.add_joints(t, dict.fromkeys(ur5.joint_names, 0.1))
            sync.add_strain(t, [0.0] * 8)
            if k == 50:
                runner.session.add_samples(feed.place())
                assert runner.stream_rate_hz() is None  # under 1 s of stream
        runner.session.add_samples(feed.place(final=True))
        assert runner.stream_rate_hz() == pytest.approx(100.0, rel=0.02)
    finally:
        receiver.close()
