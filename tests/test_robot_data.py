"""Every URDF of example-robot-data: a drafted robot file is described, or refused naming what is wrong.

For each URDF (``tests/robot_sweep.py`` drafts the robot file: the sensor on the last link of
the longest chain, every other joint locked, the links beyond the sensor ignored),
``fts-calib robots FILE`` either describes it, the sensor on the link the draft names, or
refuses it with one fts-calib error line that names a joint, frame or link of the URDF (or the
URDF when it has no joint to name). A URDF Pinocchio cannot read at all is skipped, named in
the skip reason. A few are planned as well, the Z1 among them; ``python -m tests.robot_sweep``
plans every one (docs/robots.md has the table).
"""

import pinocchio as pin
import pytest

from fts_calib.app.exit_codes import ExitCode
from fts_calib.robot.definition import link_frame_id, load_robot
from fts_calib.robot.kinematics import Kinematics

from .robot_sweep import describe, draft_robot, load_urdf, plan, urdf_specs, write_draft

#: Planned here too (the rest: tests/robot_sweep.py): arms whose URDF names a link and a joint alike (Z1, B1 with a Z1,
#: ANYmal C, SO-100), and a UR5.
PLANNED = (
    "z1_description/urdf/z1.urdf",
    "b1_description/urdf/b1-z1.urdf",
    "anymal_c_simple_description/urdf/anymal.urdf",
    "so_arm_description/urdf/so100.urdf",
    "ur_description/urdf/ur5_robot.urdf",
)


def _names(model: pin.Model) -> set[str]:
    """Every name of the URDF's model: its joints and frames (links, fixed joints)."""
    return {f.name for f in model.frames} | set(model.names[1:])


def _names_something(message: str, model: pin.Model, spec: str) -> bool:
    """The message quotes a name of the model, or a collision body of a link ('link04_0'), or names the URDF."""
    quoted = {part.split("'")[0] for part in message.split("'")[1::2]} | set(message.replace(",", " ").replace("[", " ").split())
    bodies = {q.rsplit("_", 1)[0] for q in quoted if q.rsplit("_", 1)[-1].isdigit()}
    return bool((quoted | bodies) & _names(model)) or spec in message


def _model(spec: str) -> pin.Model:
    model = load_urdf(spec)
    if model is None:
        pytest.skip(f"Pinocchio cannot read {spec} at all")
    return model


def test_the_sweep_covers_the_package():
    specs = urdf_specs()
    assert len(specs) >= 60 and "z1_description/urdf/z1.urdf" in specs and set(PLANNED) <= set(specs)


@pytest.mark.parametrize("spec", urdf_specs())
def test_a_drafted_robot_file_is_described_or_refused_by_name(tmp_path, spec):
    model = _model(spec)
    draft = draft_robot(spec, model, meshes=False)
    path = write_draft(draft, tmp_path)
    outcome = describe(path)  # a traceback fails the test: never an outcome
    if outcome.code != ExitCode.OK:
        assert outcome.code in (ExitCode.FILE, ExitCode.ROBOT, ExitCode.CONFIG), outcome.output
        assert _names_something(outcome.message, model, spec), outcome.message
        return
    assert f"sensor frame 'ft_sensor' on '{draft.parent_frame}'" in outcome.output
    kin = Kinematics(load_robot(path))
    parent = kin.model.frames[kin.model.frames[kin.sensor_frame_id].parentFrame]
    assert (parent.name, parent.type) == (draft.parent_frame, pin.FrameType.BODY)  # the link, whatever else shares its name
    assert kin.joint_names == draft.chain
    for link in draft.ignored:  # what collision.ignore_links looks up: the link's own frame
        frame = kin.model.frames[link_frame_id(kin.model, link)]
        assert (frame.name, frame.type) == (link, pin.FrameType.BODY)


@pytest.mark.parametrize("spec", PLANNED)
def test_a_drafted_robot_file_is_planned_or_refused_by_name(tmp_path, spec):
    model = _model(spec)
    path = write_draft(draft_robot(spec, model), tmp_path)
    outcome = plan(path, tmp_path / "plan")
    assert outcome.code in (ExitCode.OK, ExitCode.CHECK_FAILED, ExitCode.TRAJECTORY, ExitCode.ROBOT), outcome.output
    if outcome.code != ExitCode.OK:
        assert _names_something(outcome.message, model, spec), outcome.message
    if spec.startswith("ur_description"):
        assert outcome.code == ExitCode.OK, outcome.output  # the arm fts-calib ships: planned from a draft too
