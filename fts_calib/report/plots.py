"""Plots people look at rather than read: planned motion, gravity coverage, convergence, errors.

Every function writes one PNG and returns its path; matplotlib runs headless (Agg).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)
import numpy as np  # noqa: E402

from ..core.files import AtomicFile

matplotlib.use("Agg")


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    try:
        with AtomicFile(path) as target:  # the output guard: whole files, devices kept, one writer
            fig.savefig(target.handle, format=path.suffix.lstrip(".").lower() or "png", dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def plot_plan(
    path: str | Path,
    time: np.ndarray,
    sweep: np.ndarray,
    sweep_names: tuple[str, str],
    still: np.ndarray,
    g_sensor: np.ndarray,
    title: str,
    motion: str = "planned sweep (ruckig, jerk-limited)",
    kept: str = "quasi-static samples",
) -> Path:
    """Planned sweep-joint motion and gravity directions on the unit sphere in the sensor frame.

    Args:
        path: PNG to write.
        time: Sample times [s], shape (N,).
        sweep: Positions of the two sweep joints [rad], shape (N, 2).
        sweep_names: Their names.
        still: Quasi-static samples (kept by the filter), shape (N,) bool.
        g_sensor: Gravity in the sensor frame [m/s^2], shape (N, 3).
        title: Figure title.
        motion: Title of the joint panel.
        kept: Label of the samples shaded (``still``).
    """
    fig = plt.figure(figsize=(13, 5.2))
    ax = fig.add_subplot(1, 2, 1)
    for k, name in enumerate(sweep_names):
        ax.plot(time, np.degrees(sweep[:, k]), lw=1.2, label=name)
    ymin, ymax = ax.get_ylim()
    ax.fill_between(time, ymin, ymax, where=still, color="tab:green", alpha=0.15, lw=0, label=kept)
    ax.set_ylim(ymin, ymax)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("joint position [deg]")
    ax.set_title(motion)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)

    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    u, v = np.mgrid[0 : 2 * np.pi : 36j, 0 : np.pi : 18j]
    ax3.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", lw=0.4)
    unit = g_sensor / np.linalg.norm(g_sensor, axis=1, keepdims=True)
    step = max(1, len(unit) // 4000)
    moving = ~still
    ax3.plot(*unit[moving][::step].T, ".", ms=1.0, color="0.55", label="while moving" if kept.startswith("quasi") else "not trusted")
    ax3.plot(*unit[still].T, "o", ms=3.0, color="tab:green", label=kept.removesuffix(" samples"))
    # a unit vector: three ticks per axis keep the labels apart
    for axis in (ax3.xaxis, ax3.yaxis, ax3.zaxis):
        axis.set_ticks([-1.0, 0.0, 1.0])
    ax3.set_xlabel("X of S (tool axis)")
    ax3.set_ylabel("Y of S")
    ax3.set_zlabel("Z of S")
    ax3.set_box_aspect((1, 1, 1))
    ax3.set_title("gravity direction in the sensor frame")
    ax3.legend(loc="upper left", fontsize=8)
    fig.suptitle(title)
    return _save(fig, path)


def plot_wrench(path: str | Path, time: np.ndarray, wrench: np.ndarray, tools: np.ndarray, names: list[str], title: str) -> Path:
    """Forces and torques on the sensor during calibration (the paper's Figs 5 and 6).

    Args:
        path: PNG to write.
        time: [s], shape (N,).
        wrench: ``[Fx, Fy, Fz, Mx, My, Mz]`` [N, N m], shape (N, 6).
        tools: Configuration index of each sample, shape (N,).
        names: Configuration names.
        title: Figure title.
    """
    fig, axes = plt.subplots(2, 1, figsize=(12, 7), sharex=True)
    rows = ((axes[0], slice(0, 3), "force [N]", ("Fx", "Fy", "Fz")), (axes[1], slice(3, 6), "torque [N·m]", ("Mx", "My", "Mz")))
    for ax, part, quantity, labels in rows:
        for k, label in enumerate(labels):
            ax.plot(time, wrench[:, part][:, k], lw=0.8, label=label)
        ax.set_ylabel(quantity)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8)
        for c, name in enumerate(names):
            mine = np.nonzero(tools == c)[0]
            if len(mine):
                ax.axvspan(time[mine[0]], time[mine[-1]], color=f"C{c + 3}", alpha=0.06)
                if ax is axes[0]:
                    ax.text(time[mine[0]], ax.get_ylim()[1], f" configuration {name}", va="top", fontsize=8)
    axes[0].set_title("forces on the sensor (paper Fig. 5)")
    axes[1].set_title("torques on the sensor (paper Fig. 6)")
    axes[1].set_xlabel("time [s]")
    fig.suptitle(title)
    return _save(fig, path)


def plot_convergence(
    path: str | Path, samples: np.ndarray, error: np.ndarray, changes: list[tuple[int, str]], noise_floor: float, title: str
) -> Path:
    """Relative error of C_bar_11 against the samples used, tool changes marked (the paper's Fig. 7).

    Args:
        path: PNG to write.
        samples: Quasi-static samples used so far, shape (K,).
        error: |C_bar_11 estimate / true - 1| after each, shape (K,).
        changes: (samples used when it started, configuration name) for each configuration.
        noise_floor: The final standard error of C_bar_11, relative, for reference.
        title: Figure title.
    """
    fig, ax = plt.subplots(figsize=(11, 5))
    ax.semilogy(samples, np.maximum(error, 1e-12), lw=1.5, color="tab:blue", label="relative error of C̄₁₁")
    ax.axhline(noise_floor, color="tab:gray", ls="--", lw=1, label=f"final standard error ({noise_floor:.1e})")
    for start, name in changes:
        ax.axvline(start, color="tab:red", lw=1, alpha=0.7)
        ax.text(start, ax.get_ylim()[1], f" configuration {name}", va="top", fontsize=9, color="tab:red")
    ax.set_xlabel("quasi-static samples used")
    ax.set_ylabel("|C̄₁₁ estimate / true − 1|")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower left", fontsize=9)
    ax.set_title(title)
    return _save(fig, path)


def plot_validation(
    path: str | Path, time: np.ndarray, expected: np.ndarray, measured: list[np.ndarray], labels: list[str], full_scale: float, title: str
) -> Path:
    """Force Fx acting on the sensor and measured, and the error (the paper's Figs 9 and 10).

    Args:
        path: PNG to write.
        time: [s], shape (N,).
        expected: Expected Fx [N], shape (N,).
        measured: Measured Fx [N] per calibration, shape (N,) each.
        labels: Name of each calibration.
        full_scale: Full scale of Fx [N] (for the % axis).
        title: Figure title.
    """
    fig, axes = plt.subplots(2, 1, figsize=(12, 7), sharex=True)
    axes[0].plot(time, expected, lw=1.6, color="black", label="acting (tool model)")
    # the first calibration is the one under test: drawn last, on top; the others lighter
    for k in reversed(range(len(measured))):
        m, label = measured[k], labels[k]
        alpha = 1.0 if k == 0 else 0.45
        axes[0].plot(time, m, lw=0.8, ls="--", color=f"C{k}", alpha=alpha, label=f"measured, {label}")
        axes[1].plot(time, m - expected, lw=0.6, color=f"C{k}", alpha=alpha, label=label)
    axes[0].set_ylabel("Fx [N]")
    axes[0].set_title("force Fx acting on the sensor (paper Fig. 9)")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[1].set_ylabel("error [N]")
    axes[1].set_xlabel("time [s]")
    axes[1].set_title("error of the measured Fx (paper Fig. 10)")
    axes[1].legend(loc="upper right", fontsize=8)
    right = axes[1].secondary_yaxis("right", functions=(lambda v: 100 * v / full_scale, lambda p: p * full_scale / 100))
    right.set_ylabel("% of full scale")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    return _save(fig, path)


def plot_offsets(
    path: str | Path,
    time: np.ndarray,
    estimated: np.ndarray,
    true: np.ndarray,
    constant: np.ndarray | None,
    title: str,
    changes: list[tuple[float, str]] | None = None,
) -> Path:
    """The offsets D over a calibration run: estimated (the offset model) against the truth, per axis.

    Args:
        path: PNG to write.
        time: Sample times [s], shape (N,).
        estimated: The calibration's offset model at those samples, [N, N m]. Shape (N, 6).
        true: The simulated sensor's offsets, [N, N m]. Shape (N, 6).
        constant: D of the paper's constant-offset model, drawn as a level line; None for none. Shape (6,).
        title: Figure title.
        changes: (time [s], configuration name) where each tool configuration starts, marked; None for none.
    """
    axes_names = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
    fig, axes = plt.subplots(2, 3, figsize=(14, 6.5), sharex=True)
    for i, ax in enumerate(axes.flat):
        unit = "N" if i < 3 else "N·m"
        # the estimate lies on the truth to a fraction of a line width: the truth is drawn wide and
        # light so that it shows on both sides, and each panel states the largest difference
        ax.plot(time, true[:, i], color="tab:orange", lw=5.0, alpha=0.45, solid_capstyle="butt", label="true offset (simulated sensor)")
        ax.plot(time, estimated[:, i], color="tab:blue", lw=1.2, label="estimated (drift offset model)")
        if constant is not None:
            ax.axhline(constant[i], color="tab:red", ls="--", lw=1, label="constant offset (the paper's model, one D for the run)")
        for start, name in changes or []:
            ax.axvline(start, color="0.5", ls=":", lw=1)
            ax.text(start, 1.0, f" {name}", transform=ax.get_xaxis_transform(), va="top", fontsize=8, color="0.35")
        error = np.abs(estimated[:, i] - true[:, i]).max()
        ax.set_title(f"offset D, {axes_names[i]} [{unit}]\nlargest |estimated − true|: {error:.1e} {unit}", fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time in the run [s]")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if changes:
        handles.append(plt.Line2D([], [], color="0.5", ls=":", lw=1))
        labels.append("tool change (configuration mounted)")
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=9, bbox_to_anchor=(0.5, -0.04))
    fig.suptitle(title)
    return _save(fig, path)
