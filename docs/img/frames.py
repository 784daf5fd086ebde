"""Draw docs/img/frames.png: the frames of an orientation source (docs/real-sensors.md, "Orientation sources").

World, robot base, TCP (flange) and sensor frames in an orthographic view, gravity along -Z
of the world, and where R_world_sensor and the mount rotation sit. Drawn with matplotlib
(headless) and written through the output guard, as the plots of fts_calib/report/plots.py
(whose demo plot is docs/img/convergence_c11.png); tests/test_orientation_sources.py runs it.
Run: .venv/bin/python docs/img/frames.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from fts_calib.core.files import AtomicFile

matplotlib.use("Agg")

WIDTH, HEIGHT = 860, 400
SCALE = 330.0  # pixels per metre of the drawing
ORIGIN = np.array([215.0, 320.0])  # where the robot base is drawn [px]
AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z
GRAVITY = "#7f3fbf"
AZIMUTH, ELEVATION = np.radians(30.0), np.radians(20.0)


def rot(axis: str, angle_deg: float) -> np.ndarray:
    """The rotation about x, y or z by ``angle_deg`` [deg], shape (3, 3)."""
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def screen(p) -> np.ndarray:
    """A point [m] of the world on the page [px] (orthographic view from the azimuth and elevation)."""
    x, y, z = np.asarray(p, dtype=float)
    u = -np.sin(AZIMUTH) * x + np.cos(AZIMUTH) * y
    v = -np.sin(ELEVATION) * (np.cos(AZIMUTH) * x + np.sin(AZIMUTH) * y) + np.cos(ELEVATION) * z
    return ORIGIN + SCALE * np.array([u, -v])


def arrow(ax, a, b, colour: str, width: float = 2.0) -> None:
    """An arrow from ``a`` to ``b`` [m]."""
    ax.annotate(
        "", xy=screen(b), xytext=screen(a), arrowprops={"arrowstyle": "-|>", "color": colour, "lw": width, "shrinkA": 0, "shrinkB": 0}
    )


def segment(ax, a, b, colour: str, width: float, style: str = "-") -> None:
    """A plain line from ``a`` to ``b`` [m]."""
    (x1, y1), (x2, y2) = screen(a), screen(b)
    ax.plot([x1, x2], [y1, y2], style, color=colour, lw=width, solid_capstyle="round")


def label(ax, at, words: str, size: float = 10, colour: str = "#222", dx: float = 0.0, dy: float = 0.0, ha: str = "left") -> None:
    """Text at a point of the world (3 numbers, [m]) or of the page (2 numbers, [px]), moved by ``dx``, ``dy`` [px]."""
    x, y = screen(at) if len(at) == 3 else np.asarray(at, dtype=float)
    ax.text(x + dx, y + dy, words, fontsize=size, color=colour, ha=ha, va="center")


def frame(ax, origin, R, length: float = 0.11) -> None:
    """The three axes of a frame at ``origin`` [m] with orientation ``R`` (columns: its axes in the world)."""
    origin = np.asarray(origin, dtype=float)
    for k in range(3):
        arrow(ax, origin, origin + length * R[:, k], AXIS_COLOURS[k], 2.0)
        label(ax, origin + 1.22 * length * R[:, k], "xyz"[k], 9, AXIS_COLOURS[k], ha="center")


def draw(path: Path) -> Path:
    """Draw the picture into ``path`` (PNG) through the output guard."""
    world, base = np.array([0.10, -0.50, 0.0]), np.zeros(3)
    R_world_tcp = rot("z", 100.0) @ rot("y", 145.0)  # the tool pointing down and away
    R_mount = rot("z", 45.0)  # --mount 0 0 0.785: the sensor turned about the flange's z
    tcp = np.array([0.10, 0.52, 0.42])
    sensor = tcp + R_world_tcp @ np.array([0.0, 0.0, 0.17])
    tool = sensor + R_world_tcp @ np.array([0.0, 0.0, 0.14])
    arm = [base, np.array([0.0, 0.0, 0.30]), np.array([0.0, 0.20, 0.62]), np.array([0.05, 0.45, 0.60]), tcp]
    fig, ax = plt.subplots(figsize=(WIDTH / 100, HEIGHT / 100))
    ax.set_xlim(0, WIDTH)
    ax.set_ylim(HEIGHT, 0)
    ax.axis("off")
    for a, b in zip(arm, arm[1:], strict=False):  # the robot, in grey
        segment(ax, a, b, "#c8c8c8", 9.0)
    segment(ax, tcp, sensor, "#8a8a8a", 12.0)  # the sensor body
    segment(ax, sensor, tool, "#a0a0a0", 3.0, "--")  # the tool
    ax.plot(*screen(tool), "o", ms=14, color="#f2c14e", mec="#8a6d1f")
    label(ax, tool, "tool: mass m, centre of mass c", 9, dx=14, dy=-10)
    arrow(ax, tool, tool + np.array([0.0, 0.0, -0.15]), GRAVITY, 2.2)
    label(ax, tool + np.array([0.0, 0.0, -0.15]), "m g", 10, GRAVITY, dx=8, dy=4)
    frame(ax, world, np.eye(3))
    label(ax, world, "world", 11, dy=20, ha="center")
    g_at = world + np.array([0.0, 0.0, 0.50])
    arrow(ax, g_at, g_at + np.array([0.0, 0.0, -0.16]), GRAVITY, 2.5)
    label(ax, g_at + np.array([0.0, 0.0, -0.08]), "g: −Z of the world", 10, GRAVITY, dx=10)
    frame(ax, base, np.eye(3), 0.09)
    label(ax, base, "robot base", 11, dy=22, ha="center")
    middle = world + 0.25 * (tcp - world)
    segment(ax, world, tcp, "#555555", 1.2, ":")
    label(ax, middle, "R_world_tcp", 10, "#555555", dx=-34, dy=-22)
    label(ax, tcp + R_world_tcp @ np.array([0.0, 0.0, 0.085]), "R_mount", 10, "#555555", dx=-22, dy=12, ha="right")
    frame(ax, tcp, R_world_tcp, 0.10)
    label(ax, tcp, "TCP / flange", 11, dx=-16, dy=-12, ha="right")
    frame(ax, sensor, R_world_tcp @ R_mount, 0.10)
    label(ax, sensor, "sensor", 11, dx=22, dy=4)
    notes = [
        ("R_world_sensor = R_world_tcp · R_mount", 11, "#000"),
        ("", 6, "#000"),
        ("without --robot, R_world_tcp is given by:", 9.5, "#333"),
        ("  qw,qx,qy,qz  |  roll,pitch,yaw = Rz·Ry·Rx", 9.5, "#333"),
        ('  a bag\'s PoseStamped  |  a datagram\'s "R", "quat"', 9.5, "#333"),
        ("  tcp_rx,tcp_ry,tcp_rz: R_base_tcp, base Z up", 9.5, "#333"),
        ("R_mount = --mount R P Y (default 0 0 0: the", 9.5, "#333"),
        ("  orientation given is the sensor's own)", 9.5, "#333"),
        ("with --robot: the joints and the robot file", 9.5, "#333"),
        ("  give R_world_base, R_base_tcp and R_mount", 9.5, "#333"),
        ("", 6, "#000"),
        ("gravity: −Z of the world, |g| the tool file's", 9.5, GRAVITY),
    ]
    y = 24.0
    for words, size, colour in notes:
        label(ax, (WIDTH - 330.0, y), words, size, colour)
        y += 2.1 * size
    fig.subplots_adjust(0, 0, 1, 1)
    try:
        with AtomicFile(path) as target:  # the output guard
            fig.savefig(target.handle, format="png", dpi=100, metadata={"Software": None})
    finally:
        plt.close(fig)
    return path


def main(argv: list[str]) -> int:
    """Draw into the one path given, or docs/img/frames.png."""
    print(draw(Path(argv[0]) if argv else Path(__file__).with_name("frames.png")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
