"""Plots people look at rather than read: planned motion, gravity coverage, convergence, errors.

Every function writes one PNG and returns its path; matplotlib runs headless (Agg).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)
import numpy as np  # noqa: E402


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_plan(path: str | Path, time: np.ndarray, sweep: np.ndarray, sweep_names: tuple[str, str], still: np.ndarray,
              g_sensor: np.ndarray, title: str) -> Path:
    """Planned sweep-joint motion and gravity directions on the unit sphere in the sensor frame.

    Args:
        path: PNG to write.
        time: Sample times [s], shape (N,).
        sweep: Positions of the two sweep joints [rad], shape (N, 2).
        sweep_names: Their names.
        still: Quasi-static samples (kept by the filter), shape (N,) bool.
        g_sensor: Gravity in the sensor frame [m/s^2], shape (N, 3).
        title: Figure title.
    """
    fig = plt.figure(figsize=(13, 5.2))
    ax = fig.add_subplot(1, 2, 1)
    for k, name in enumerate(sweep_names):
        ax.plot(time, np.degrees(sweep[:, k]), lw=1.2, label=name)
    ymin, ymax = ax.get_ylim()
    ax.fill_between(time, ymin, ymax, where=still, color="tab:green", alpha=0.15, lw=0, label="quasi-static samples")
    ax.set_ylim(ymin, ymax)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("joint position [deg]")
    ax.set_title("planned sweep (ruckig, jerk-limited)")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)

    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    u, v = np.mgrid[0:2 * np.pi:36j, 0:np.pi:18j]
    ax3.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", lw=0.4)
    unit = g_sensor / np.linalg.norm(g_sensor, axis=1, keepdims=True)
    step = max(1, len(unit) // 4000)
    moving = ~still
    ax3.plot(*unit[moving][::step].T, ".", ms=1.0, color="0.55", label="while moving")
    ax3.plot(*unit[still].T, "o", ms=3.0, color="tab:green", label="quasi-static")
    ax3.set_xlabel("X (tool axis)")
    ax3.set_ylabel("Y")
    ax3.set_zlabel("Z")
    ax3.set_box_aspect((1, 1, 1))
    ax3.set_title("gravity direction in the sensor frame")
    ax3.legend(loc="upper left", fontsize=8)
    fig.suptitle(title)
    return _save(fig, path)
