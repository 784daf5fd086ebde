"""Every URDF of example-robot-data: a robot file drafted for it, described and planned, or refused by name.

    python -m tests.robot_sweep                 # every URDF, the table of outcomes (Markdown)
    python -m tests.robot_sweep z1 panda        # the URDFs whose path holds one of the words

For each URDF under example-robot-data's ``robots/`` folder (:func:`urdf_specs`) a robot file
is drafted the way a newcomer would write one (:func:`draft_robot`): the sensor on the link at
the end of the longest chain of joints that are not a gripper's, X of S along the last joint's
axis, every other joint locked, the links beyond the sensor left out of the collision checks,
the description's SRDF when it has one, the floor under the lowest link. ``fts-calib robots
FILE`` then describes it and ``fts-calib trajectory`` plans it on the cheapest raster
(:data:`PLAN_ARGS`). Each outcome is one of: planned (every check passed), planned with a
failed check (exit 1, the check named), refused (a one-line fts-calib error: its exit code
and message), or not loaded (Pinocchio cannot read the URDF at all: counted and named, not
run). An exception other than fts-calib's (a traceback) is never an outcome: it propagates.

``tests/test_robot_data.py`` runs the drafting and the description for every URDF and the
planning for a few; this script plans all of them (about a minute per ten arms on one core)
and prints the table of docs/robots.md.
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from fts_calib.app import cli
from fts_calib.core.resources import example_robot_data_dir
from fts_calib.robot.definition import ROBOT_DATA_PREFIX

#: Joints whose name says they move a gripper or a hand: never the end of the sensor's chain.
GRIPPER = re.compile(r"grip|finger|hand|thumb|index|middle|ring|pinky|little|palm|claw|jaw", re.IGNORECASE)

#: The cheapest plan that still runs every step of ``fts-calib trajectory``: a fixed 2 x 3 raster, few samples.
PLAN_ARGS = ("--tool", "paper_tool", "--levels", "2", "--stops", "3", "--rate", "10", "--no-plot")


def robots_dir() -> Path:
    """example-robot-data's ``robots/`` folder (the package's URDFs and meshes)."""
    return example_robot_data_dir() / "robots"


def urdf_specs() -> list[str]:
    """Every URDF of example-robot-data, as paths inside its ``robots/`` folder, sorted."""
    root = robots_dir()
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*.urdf"))


def load_urdf(spec: str) -> pin.Model | None:
    """Pinocchio's model of a URDF of example-robot-data, or None when Pinocchio cannot read it at all."""
    try:
        with _quiet():
            return pin.buildModelFromUrdf(str(robots_dir() / spec))
    except (ValueError, RuntimeError):
        return None


@contextlib.contextmanager
def _quiet():
    """Pinocchio's URDF parser prints to the terminal: silence the file descriptors while it reads."""
    import os

    saved = [os.dup(1), os.dup(2)]
    with open(os.devnull, "w") as null:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)


def _axis(model: pin.Model, joint: int) -> np.ndarray:
    """Unit axis of a one-dof joint in its own frame (the angular part of its motion subspace; the linear one when prismatic)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    S = np.asarray(data.joints[joint].S).reshape(6, -1)[:, 0]
    axis = S[3:] if np.linalg.norm(S[3:]) > 1e-9 else S[:3]
    return axis / np.linalg.norm(axis)


def _rpy_x_along(axis: np.ndarray) -> list[float]:
    """Roll, pitch, yaw [rad] of a frame whose X axis is ``axis`` (the smallest rotation from X)."""
    x = np.array([1.0, 0.0, 0.0])
    c = float(np.dot(x, axis))
    if c < -1.0 + 1e-12:
        R = np.diag([-1.0, -1.0, 1.0])  # a half turn about Z
    else:
        v = np.cross(x, axis)
        K = pin.skew(v)
        R = np.eye(3) + K + K @ K / (1.0 + c)
    return [round(float(a), 6) + 0.0 for a in pin.rpy.matrixToRpy(R)]


def _beyond(model: pin.Model, parent: int) -> list[str]:
    """Links (BODY frames) whose way to the root passes through frame ``parent``, in frame order."""
    out = []
    for k, frame in enumerate(model.frames):
        if frame.type != pin.FrameType.BODY or k == parent:
            continue
        f, seen = k, set()
        while f not in (parent, 0) and f not in seen:
            seen.add(f)
            f = model.frames[f].parentFrame
        if f == parent:
            out.append(frame.name)
    return out


def _flange(spec: str, model: pin.Model, link: int, joint: int, meshes: bool) -> np.ndarray:
    """Where the sensor goes on ``link``, carried by ``joint``: out along the joint's axis, past the link [m], shape (3,).

    The tool axis points away from the joint before (the wrist), or towards the frames fixed
    to the link (a flange, ``tool0``) when that joint is beside the axis; the sensor sits 2 cm
    (an adapter plate) past the link's collision geometry along it, as the shipped robots' do
    (past the link's origin without ``meshes``: faster, the same frames looked up).
    """
    axis = _axis(model, joint)
    along = float(model.jointPlacements[joint].inverse().translation @ axis)  # the joint before, along the axis
    fixed = [k for k, f in enumerate(model.frames) if f.parentFrame == link and f.type == pin.FrameType.FIXED_JOINT]
    kids = [float(f.placement.translation @ axis) for f in model.frames if f.parentFrame in fixed]
    if abs(along) > 1e-3:
        axis = -np.sign(along) * axis
    elif kids and abs(max(kids, key=abs)) > 1e-3:
        axis = np.sign(max(kids, key=abs)) * axis
    reach, geometry = 0.0, None
    try:
        if meshes:
            with _quiet():
                dirs = [str(robots_dir().parents[1])]
                geometry = pin.buildGeomFromUrdf(model, str(robots_dir() / spec), pin.COLLISION, package_dirs=dirs)
    except (ValueError, RuntimeError):  # a mesh missing: the link's origin
        pass
    frame = model.frames[link]
    for obj in geometry.geometryObjects if geometry is not None else []:
        if obj.parentFrame != link:
            continue
        obj.geometry.computeLocalAABB()
        low, high = obj.geometry.aabb_local.min_, obj.geometry.aabb_local.max_
        corners = np.array([[(low, high)[i >> k & 1][k] for k in range(3)] for i in range(8)])
        placement = frame.placement.inverse() * obj.placement  # the body in the link's frame
        reach = max(reach, float(np.max((corners @ placement.rotation.T + placement.translation) @ axis)))
    return axis * (min(reach, 0.5) + 0.02)


def _srdf(spec: str) -> str | None:
    """The description's SRDF for a URDF: the one of the same name, else the longest whose name starts the URDF's."""
    urdf = robots_dir() / spec
    folder = urdf.parent.parent / "srdf"
    found = sorted(folder.glob("*.srdf")) if folder.is_dir() else []
    same = [p for p in found if p.stem == urdf.stem]
    prefix = sorted((p for p in found if urdf.stem.startswith(p.stem)), key=lambda p: -len(p.stem))
    chosen = (same or prefix or [None])[0]
    return None if chosen is None else chosen.relative_to(robots_dir()).as_posix()


@dataclass(frozen=True)
class Draft:
    """A drafted robot file.

    Attributes:
        spec: The URDF, as a path inside example-robot-data's ``robots/`` folder.
        text: The robot file (YAML).
        parent_frame: The link the sensor is mounted on.
        chain: The joints from the root to that link (the ones not locked), in order.
        locked: The joints locked, name -> value [rad or m].
        ignored: The links left out of the collision checks (beyond the sensor).
    """

    spec: str
    text: str
    parent_frame: str
    chain: tuple[str, ...]
    locked: dict[str, float]
    ignored: tuple[str, ...]


def draft_robot(spec: str, model: pin.Model, meshes: bool = True) -> Draft:
    """A robot file for a URDF of example-robot-data, as a newcomer would write it (see the module docstring).

    Args:
        spec: The URDF, as a path inside example-robot-data's ``robots/`` folder.
        model: Pinocchio's model of it (:func:`load_urdf`).
        meshes: Place the sensor past the last link's collision meshes (read for it); without,
            2 cm past the link's origin.
    """
    one_dof = [j for j in range(1, model.njoints) if model.joints[j].nv == 1]
    depth = {j: sum(1 for s in model.supports[j] if s in one_dof) for j in one_dof}
    arm = [j for j in one_dof if not GRIPPER.search(model.names[j])] or one_dof
    tip = max(arm, key=lambda j: (depth[j], -j)) if arm else 0
    chain = [j for j in list(model.supports[tip])[1:]]
    locked = {}
    for j in one_dof:
        if j in chain:
            continue
        joint = model.joints[j]
        lower, upper = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
        value = 0.0 if joint.nq == 2 or not (np.isfinite(lower) and np.isfinite(upper)) else float(np.clip(0.0, lower, upper))
        locked[model.names[j]] = round(value, 6) + 0.0
    if tip:
        joint_frame = next(k for k, f in enumerate(model.frames) if f.type == pin.FrameType.JOINT and f.parentJoint == tip)
        link = next(k for k, f in enumerate(model.frames) if f.type == pin.FrameType.BODY and f.parentFrame == joint_frame)
        offset = _flange(spec, model, link, tip, meshes)
    else:
        link, offset = next(k for k, f in enumerate(model.frames) if f.type == pin.FrameType.BODY), np.array([0.02, 0.0, 0.0])
    parent = model.frames[link].name
    xyz = [round(float(v), 4) + 0.0 for v in offset]
    rpy = _rpy_x_along(offset / np.linalg.norm(offset))
    ignored = _beyond(model, link)
    q = pin.neutral(model)
    for name, value in locked.items():
        joint = model.joints[model.getJointId(name)]
        q[joint.idx_q] = value
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    floor = min(0.0, min(float(data.oMf[k].translation[2]) for k in range(len(model.frames))))
    srdf = _srdf(spec)
    lines = [
        f"# drafted by tests/robot_sweep.py from {spec}",
        f"name: {spec.split('/')[0].removesuffix('_description')}-{Path(spec).stem}",
        f"urdf: {ROBOT_DATA_PREFIX}{spec}",
        "sensor:",
        f"  parent_frame: {parent}",
        f"  xyz: {xyz}",
        f"  rpy: {rpy}",
    ]
    if locked:
        lines.append("locked_joints:")
        lines += [f"  {name}: {value}" for name, value in locked.items()]
    lines.append("collision:")
    if ignored:
        lines.append(f"  ignore_links: [{', '.join(ignored)}]")
    if srdf:
        lines.append(f"  srdf: {ROBOT_DATA_PREFIX}{srdf}")
    lines.append(f"  floor_z: {round(floor - 1e-3, 4)}")
    text = "\n".join(lines) + "\n"
    return Draft(spec, text, parent, tuple(model.names[j] for j in chain), locked, tuple(ignored))


def write_draft(draft: Draft, folder: Path) -> Path:
    """The drafted robot file written into ``folder``, named after its URDF."""
    path = folder / (draft.spec.replace("/", "__").removesuffix(".urdf") + ".yaml")
    path.write_text(draft.text, encoding="utf-8")
    return path


@dataclass(frozen=True)
class Outcome:
    """What fts-calib made of a robot file.

    Attributes:
        code: The command's exit code (0: done; 1: a check failed; another: refused).
        message: The error line (refused), the first failed check (1), or the sweep joints planned (0).
        output: Everything the command printed.
    """

    code: int
    message: str
    output: str


def run_cli(*args: str) -> Outcome:
    """``fts-calib ARGS`` in this process; an exception that is not fts-calib's propagates (the test fails on it)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = cli.main(list(args))
    printed = out.getvalue() + err.getvalue()
    if code == 0:
        sweep, clearance = _SWEEP.search(printed), _CLEARANCE.search(printed)
        message = (f"{sweep.group(1)} and {sweep.group(2)} sweep; " if sweep else "") + (clearance.group(1) if clearance else "")
    elif code == 1:
        message = next((line.removeprefix("CHECK FAILED: ") for line in printed.splitlines() if line.startswith("CHECK FAILED")), "")
    else:
        message = next((line for line in printed.splitlines() if ": error: " in line), (printed.strip().splitlines() or [""])[-1])
        message = message.split(": error: ", 1)[-1]
    return Outcome(code, message, printed)


_SWEEP = re.compile(r"^sweep: (\S+) at .*?\); (\S+) over", re.MULTILINE)
_CLEARANCE = re.compile(r"^clearance: (\S+ m between '[^']*' and '[^']*')", re.MULTILINE)


def plan(robot_file: Path, out: Path) -> Outcome:
    """``fts-calib trajectory`` of a robot file on the cheapest raster (:data:`PLAN_ARGS`)."""
    return run_cli("trajectory", "--robot", str(robot_file), "-o", str(out), *PLAN_ARGS)


def describe(robot_file: Path) -> Outcome:
    """``fts-calib robots FILE``: the robot file resolved against its URDF (kinematics, the sensor frame)."""
    return run_cli("robots", str(robot_file))


#: What a message advises, as the table shows it: the robot file's key with its value, or the words.
_ADVICE = re.compile(
    r"'collision\.ignore_pairs: \[\[[^\]]*\]\]'|'collision\.ignore_links: \[[^\]]*\]'|'locked_joints: \{[^}]*\}'|lock '[^']*'"
    r"|smaller tool shape|give 'home'|set limits\.velocity|'sweep_joints'"
)


def _cell(text: str, folder: Path, width: int = 170) -> str:
    """A message as a table cell: its first clause (one line, no absolute path, at most ``width`` characters), then its advice."""
    text = " ".join(text.replace(f"{robots_dir()}/", ROBOT_DATA_PREFIX).replace(f"{folder}/", "").replace("|", "/").split())
    found = (m.group(0) for m in _ADVICE.finditer(text))
    advice = list(dict.fromkeys(f"`{a.strip(chr(39))}`" if a.startswith("'") else a for a in found))  # a key of the file: as code
    cut = min((k for k in (text.find(", leaving"), text.find(" (at least"), text.find("; expected joints")) if k > 0), default=len(text))
    head = text[:cut] if cut <= width else text[: width - 3] + "..."
    return head + (f"; advice: {'; '.join(advice)}" if advice else "")


def _verdict(outcome: Outcome) -> str:
    if outcome.code == 0:
        return "planned"
    if outcome.code == 1:
        return "planned, a check failed"
    return f"refused (exit {outcome.code})"


def main(words: list[str]) -> int:
    """Print the table of outcomes (Markdown) for the URDFs whose path holds one of ``words`` (all when none)."""
    specs = [s for s in urdf_specs() if not words or any(w in s for w in words)]
    rows, skipped = [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp).resolve()
        for spec in specs:
            model = load_urdf(spec)
            if model is None:
                skipped.append(spec)
                continue
            draft = draft_robot(spec, model)
            path = write_draft(draft, folder)
            described = describe(path)
            outcome = described if described.code else plan(path, folder / path.stem)
            rows.append((spec, draft, outcome))
            print(f"{spec}: {_verdict(outcome)}", file=sys.stderr, flush=True)
    print("| URDF (example-robot-data) | sensor on | joints | outcome | what fts-calib said |")
    print("|---|---|---|---|---|")
    for spec, draft, outcome in rows:
        print(f"| `{spec}` | `{draft.parent_frame}` | {len(draft.chain)} | {_verdict(outcome)} | {_cell(outcome.message, folder)} |")
    counts = {v: sum(1 for *_, o in rows if _verdict(o).startswith(v)) for v in ("planned", "planned, a check failed", "refused")}
    print(
        f"\n{len(specs)} URDFs: {counts['planned'] - counts['planned, a check failed']} planned, "
        f"{counts['planned, a check failed']} planned with a failed check, {counts['refused']} refused, "
        f"{len(skipped)} not loaded by Pinocchio" + (f" ({', '.join(f'`{s}`' for s in skipped)})" if skipped else "")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
