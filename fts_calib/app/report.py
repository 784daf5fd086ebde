"""Text reports for the command line: tables with units, for people to read; and the ``report`` command (HTML)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..budget.propagation import AccuracyBudget
from ..core.resources import resolve, shipped
from ..core.tables import table
from ..model.channels import WRENCH_AXES, WRENCH_UNITS
from ..robot.definition import load_robot
from ..robot.kinematics import Kinematics
from .setup import Setup


def _limit(value: float) -> str:
    return "none" if not math.isfinite(value) else f"{value:+.4f}"


def robots_list() -> str:
    """The shipped robot definitions, one line each."""
    rows = []
    for name in shipped("robots"):
        robot = load_robot(resolve(name, "robots"))
        kin = Kinematics(robot)
        rows.append([name, str(kin.n_joints), ", ".join(kin.sweep_joints), robot.sensor.parent_frame, robot.urdf_spec])
    return "shipped robot definitions (robots/*.yaml):\n" + table(["name", "joints", "sweep joints", "sensor on", "URDF"], rows)


def robot_details(name_or_path: str) -> str:
    """Joints, limits, frames and the sensor mount of one robot definition."""
    path = resolve(name_or_path, "robots")
    robot = load_robot(path)
    kin = Kinematics(robot)
    lim = kin.limits
    out = [f"{robot.name} ({path})", f"  URDF: {robot.urdf_spec} -> {robot.urdf}"]
    rows = []
    for k, joint in enumerate(kin.joints):
        rows.append(
            [
                joint.name,
                joint.kind,
                _limit(lim.lower[k]),
                _limit(lim.upper[k]),
                f"{lim.velocity[k]:.3f}",
                f"{joint.velocity:.3f}",
                f"{lim.acceleration[k]:.2f}",
                f"{lim.jerk[k]:.1f}",
            ]
        )
    out.append(f"  actuated joints ({kin.n_joints}) and the limits used for planning:")
    out.append(
        table(
            ["joint", "kind", "lower [rad]", "upper [rad]", "velocity [rad/s]", "URDF velocity", "accel. [rad/s²]", "jerk [rad/s³]"],
            rows,
            "    ",
        )
    )
    out.append(f"  sweep joints: {', '.join(kin.sweep_joints)}")
    locked = ", ".join(f"{k} = {v:g}" for k, v in robot.locked_joints.items()) or "none"
    out.append(f"  locked joints: {locked}")
    home = "planned automatically (none given)" if robot.home is None else ", ".join(f"{k} {v:+.4f}" for k, v in robot.home.items())
    out.append(f"  home [rad]: {home}")
    mount = robot.sensor
    out.append(
        f"  sensor frame '{mount.name}' on '{mount.parent_frame}': xyz {np.round(mount.xyz, 4).tolist()} m, "
        f"rpy {np.round(mount.rpy, 4).tolist()} rad"
    )
    neutral = np.clip(np.zeros(kin.n_joints), lim.lower, lim.upper)
    pose = kin.sensor_pose(neutral)
    out.append(
        f"    at zero readings (clipped to limits): p_world_sensor {np.round(pose.translation, 4).tolist()} m, "
        f"sensor X axis in world {np.round(pose.rotation[:, 0], 4).tolist()}"
    )
    out.append(f"  collision: floor at z = {robot.floor_z} m; links left out: {', '.join(robot.ignore_links) or 'none'}")
    frames = [f.name for f in kin.model.frames]
    out.append(f"  frames ({len(frames)}): {', '.join(frames)}")
    return "\n".join(out)


def format_budget(budget: AccuracyBudget, what: str) -> list[str]:
    """Lines: the accuracy budget per term and axis in % of full scale, its total in % and in N or N·m."""
    full = ", ".join(f"{a} {v:g} {u}" for a, v, u in zip(WRENCH_AXES, budget.full_scale, WRENCH_UNITS, strict=True))
    lines = [f"{what} accuracy budget (each term ×{budget.coverage:g}, about 95 %; RMS over loads spread across the full scale: {full}):"]
    rows = [[name, *[f"{v:.4f}" for v in budget.percent(name)]] for name in budget.terms]
    rows.append(["total, % FS", *[f"{v:.4f}" for v in budget.total_percent]])
    rows.append(["total", *[f"{v:.3g} {u}" for v, u in zip(budget.total, WRENCH_UNITS, strict=True)]])
    lines.append(table(["% of full scale", *WRENCH_AXES], rows, "  "))
    term, axis = budget.dominant()
    lines.append(f"  largest error: {budget.largest_percent:.4f} % of full scale ({axis}; the largest term there: {term})")
    return lines


def _terms(model: str, columns) -> str:
    """A model with its drift terms, e.g. 'drift (time^1, temperature)'."""
    extra = [c for c in columns if not c.startswith("offset")]
    return f"{model} ({', '.join(extra)})" if extra else model


def format_offsets(offset_model) -> list[str]:
    """The offset model of a calibration in words: the model chosen and why, and how far D moved, with units.

    Args:
        offset_model: A calibration's ``offset_model`` (:func:`fts_calib.model.offset_models.describe`),
            or None (a file written before offset models: constant offsets).
    """
    if not offset_model:
        return ["offsets: constant (the paper's model)"]
    columns = "" if offset_model["model"] == "constant" else f"; columns {', '.join(offset_model['columns'])}"
    if str(offset_model.get("criterion", "")).startswith("held-out"):
        how = "chosen by held-out error, above" if offset_model.get("setting") == "auto" else "set by --offsets"
        lines = [f"offsets: {offset_model['model']} ({how}){columns}"]
    else:
        how = "chosen by BIC" if offset_model.get("setting") == "auto" else "set by --offsets"
        scores = ", ".join(f"{_terms(c['model'], c['columns'])} +{c['bic_above_best']:.0f}" for c in offset_model.get("candidates", []))
        lines = [f"offsets: {offset_model['model']} ({how}; BIC above the best: {scores or 'none'}){columns}"]
    trajectory = offset_model.get("trajectory") or []
    if len(trajectory) >= 2 and offset_model["model"] != "constant":  # constant offsets do not move
        first, last = trajectory[0], trajectory[-1]
        moved = np.array(last["D"]) - np.array(first["D"])
        span = last["time_s"] - first["time_s"]
        words = ", ".join(f"{a} {m:+.4g} {u}" for a, m, u in zip(WRENCH_AXES, moved, WRENCH_UNITS, strict=True))
        lines.append(f"  D moved over the run ({span:.1f} s, {first['configuration']} to {last['configuration']}): {words}")
        lines.append(
            f"  D below is the offset at the end of the run: t = {last['time_s']:.2f} s, configuration {last['configuration']}"
            + (f", {last['temperature_C']:.2f} °C" if "temperature" in offset_model["columns"] else "")
        )
    return lines


def format_model_selection(selection, quality=None) -> list[str]:
    """The held-out choice of the sensor and offset models: a table of candidates, the chosen one marked, with units.

    Args:
        selection: A calibration's ``model_selection`` (:meth:`fts_calib.model.model_choice.Selection.as_dict`), or
            None (the linear model, offsets by BIC: nothing to print).
        quality: The calibration's quality, for the directions held (or None).
    """
    if not selection:
        return []
    units = [f"{a} [{u}]" for a, u in zip(WRENCH_AXES, WRENCH_UNITS, strict=True)]
    rows = []
    for c in selection["candidates"]:
        mark = "*" if c["chosen"] else ""
        rms = [f"{v:.3g}" for v in c["heldout_rms"]]
        rows.append([mark, c["model"], c["offsets"], str(c["parameters_per_axis"]), *rms, f"{c['heldout_error']:.3g}"])
    lines = [
        f"model: {selection['chosen']} (--model {selection['setting']['model']}, --offsets {selection['setting']['offsets']}): "
        f"held-out RMS per axis, leaving out one of {selection['units']} units (a configuration and a 10° cell of gravity's "
        f"direction) at a time; * chosen: the fewest parameters within {selection.get('equal_within_standard_errors', 2):g} "
        "standard errors of the best"
    ]
    lines.append(table(["", "model", "offsets", "params", *units, "error"], rows, "  "))
    for family, found in selection.get("determination", {}).items():
        if not found.get("determined", True):
            lines.append(f"  {family}: not a candidate: {found.get('lacks', '')}")
    check = selection.get("load_groups")
    if check:
        words = ", ".join(f"{c['model']} {c['heldout_error']:.3g}" for c in check["candidates"])
        lines.append(f"  leaving one of {check['groups']} configurations out (each with its own offset), held-out error: {words}")
    held = None if quality is None else quality.held_directions
    if held and held.get("count"):
        lines.append(f"  {held['count']} directions no load excites held by the rule: {held['rule']}")
    return lines


#: What to do when a report's recording is not of its calibration's sensor.
REPORT_HINT = "give the recording this calibration was made from (or the calibration of the recording's sensor)"


def run(
    setup: Setup,
    *,
    calibration: str | Path,
    output: str | Path,
    recording: str | Path | None = None,
    against: str | Path | None = None,
    target_error_percent: float | None = None,
) -> int:
    """Write the HTML report of a calibration file, or its comparison with an older one (``fts-calib report``).

    Args:
        setup: For the recording: the robot and the tool (None: the files the calibration
            records, :meth:`fts_calib.app.setup.Setup.recorded`), the pipeline settings (filter
            thresholds) and the sensor file (channel limits, full scale).
        calibration: The calibration file (fts-calib YAML).
        output: HTML file to write.
        recording: The recording it was made from: the kept samples are found again with the
            pipeline's filter and their residuals computed through ``calibration``; None for none.
        against: An older calibration of the same sensor: write the comparison instead.
        target_error_percent: Accuracy target of the budget total, in [%] of full scale; when
            None, the one the file records (``calibrate --target-error``), else 0.05.

    Returns:
        0.
    """
    from ..core.files import check_outputs
    from ..model.calibration import load_calibration
    from ..report.compare import render_comparison
    from ..report.content import KeptCollector, ReportContent, check_target, target_of
    from ..report.html import render_report, write_report
    from .exit_codes import writing

    inputs = {"the calibration": calibration, "the recording": recording, "--against": against}
    check_outputs({"-o": output}, inputs)
    given = check_target(target_error_percent)
    cal = load_calibration(calibration)
    target = target_of(cal, given)  # the option, else the target the file records (calibrate --target-error), else 0.05
    files = {"the calibration": calibration, "the recording": recording}
    if against is not None:
        old = load_calibration(against)
        page = render_comparison(cal, old, str(calibration), str(against), {"new": calibration, "old": against})
    else:
        prov = dict(cal.provenance)
        tools = prov.get("tools") or {}
        names = tuple(str(c.get("name")) for c in tools.get("configurations", []))
        samples, skipped, seen, kept = None, None, None, None
        if recording is not None:
            from ..model.channels import check_channels
            from ..session.calibration_run import calibrate_recording
            from ..sources.source import open_recording

            setup = setup.recorded(prov, calibration)  # the robot and tool it was made with, unless given
            files.update(setup.inputs())
            kin, loaded, settings, spec = setup.kinematics, setup.tool, setup.settings, setup.sensor
            with open_recording(recording, None, None) as reader:  # the header only: a recording of another sensor is refused
                n = getattr(reader, "n_channels", None)  # a bag's: known once read (its layout checked then)
            if n is not None:
                check_channels(cal.layout, n, str(recording), (f"the calibration {calibration} of layout", REPORT_HINT))
            collector = KeptCollector()
            # the recording is the calibration's: read with its layout
            same = spec.layout.n_channels == cal.layout.n_channels
            again = calibrate_recording(
                recording, kin, loaded, settings, on_kept=collector, accept_poor_fit=True, layout=cal.layout,
                limits=spec.limits if same else None,
            )  # fmt: skip
            samples = collector.samples(cal)
            progress = again.session.progress()
            skipped, seen, kept, names = progress.skipped, progress.seen, progress.kept, tuple(loaded.names)
        title = f"Calibration on {(prov.get('robot') or {}).get('name', 'an unnamed robot')} with {tools.get('name', 'an unnamed tool')}"
        content = ReportContent(
            title=title,
            calibration=cal,
            skipped=skipped,
            seen=seen,
            kept=kept,
            samples=samples,
            configurations=names,
            files=files,
            target_percent=target,
        )
        page = render_report(content)
    with writing(output):
        print(f"wrote {write_report(output, page)}")
    return 0
