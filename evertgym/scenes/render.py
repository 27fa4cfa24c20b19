"""Drawing scenes (and a robot) with matplotlib's Agg backend; no display needed.

Walls are drawn with their true thickness outside the lumen (grey: rigid, rose: compliant);
the lumen is filled, the centreline dashed, the entry marked by an arrow and the goal by a
red line across the lumen.  A robot is drawn as discs of its radius on its centreline points
(or a thick line when no radius is given).  Lengths are shown in mm.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from evertgym.scenes.geometry import polyline_normals
from evertgym.scenes.scene import Scene, SceneHandles

if TYPE_CHECKING:
    from matplotlib.axes import Axes

LUMEN_COLOUR = "#e8f0f7"
RIGID_COLOUR = "#5a5a5a"
COMPLIANT_COLOUR = "#d08080"
ROBOT_COLOUR = "#f08c00"


def _wall_band(wall: np.ndarray, outward: float, thickness: float) -> np.ndarray:
    outer = wall + outward * polyline_normals(wall) * thickness
    return np.vstack([wall, outer[::-1]])


def draw_scene(ax: Axes, scene: Scene, robot_xy: np.ndarray | None = None, robot_radius: float | None = None,
               handles: SceneHandles | None = None, title: str | None = None) -> None:
    """Draw ``scene`` (SI, shown in mm) on ``ax``; compliant pieces at their current place if ``handles``."""
    from matplotlib.collections import LineCollection, PatchCollection  # (matplotlib only when drawing)
    from matplotlib.patches import Circle, Polygon

    mm = 1e3
    left, right = scene.walls
    ax.add_patch(Polygon(np.vstack([left, right[::-1]]) * mm, closed=True, facecolor=LUMEN_COLOUR, edgecolor="none"))
    thickness = 2.0 * scene.wall_radius
    split = min(scene.compliant_start + 1, len(scene.arclength))
    moved = handles is not None and handles.network is not None
    for wall, outward in ((left, 1.0), (right, -1.0)):
        parts = [(wall[:split], RIGID_COLOUR)]
        if scene.compliant and not moved:
            parts.append((wall[split - 1:], COMPLIANT_COLOUR))
        for part, colour in parts:
            if len(part) > 1:
                ax.add_patch(Polygon(_wall_band(part, outward, thickness) * mm, closed=True,
                                     facecolor=colour, edgecolor="none"))
    if moved and handles is not None and handles.network is not None:
        net = handles.network
        segments = []
        for body, outline in zip(handles.bodies, net.outline):
            c, s = np.cos(body.angle), np.sin(body.angle)
            pts = outline @ np.array([[c, s], [-s, c]]) + np.array(tuple(body.position))
            segments.append(pts * mm)
        ax.add_collection(LineCollection(segments, colors=COMPLIANT_COLOUR, linewidths=2.0, capstyle="round"))
    ax.plot(*(scene.centreline * mm).T, ls="--", lw=0.6, color="#7a9cc0")
    e, d = scene.entry * mm, scene.entry_direction
    w0 = scene.lumen_width[0] * mm
    ax.annotate("", xy=tuple(e + d * 0.6 * w0), xytext=tuple(e), arrowprops=dict(arrowstyle="->", color="#2b8a3e", lw=1.5))
    i = int(np.searchsorted(scene.arclength, scene.goal_arclength).clip(0, len(scene.arclength) - 1))
    n = np.array([-np.sin(scene.heading[i]), np.cos(scene.heading[i])])
    half = 0.5 * scene.lumen_at(scene.goal_arclength)
    ax.plot(*((scene.goal + np.outer([-1.0, 1.0], n) * half) * mm).T, color="#e03131", lw=1.5)
    if robot_xy is not None:
        xy = np.atleast_2d(np.asarray(robot_xy, float)) * mm
        if robot_radius is not None:
            ax.add_collection(PatchCollection([Circle(p, robot_radius * mm) for p in xy], facecolor=ROBOT_COLOUR,
                                              edgecolor="none", alpha=0.85))
            ax.plot(*xy.T, color="#a85d00", lw=0.8)
        else:
            ax.plot(*xy.T, color=ROBOT_COLOUR, lw=3.0, solid_capstyle="round")
    pts = np.vstack(scene.walls) * mm
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.06 * float(np.max(hi - lo)) + thickness * mm
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=7)


def render_rgb(scene: Scene, robot_xy: np.ndarray | None = None, robot_radius: float | None = None,
               width: int = 480, height: int = 480, handles: SceneHandles | None = None) -> np.ndarray:
    """RGB image (height, width, 3) uint8 of ``scene`` and, if given, the robot's centreline points (m)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    draw_scene(ax, scene, robot_xy=robot_xy, robot_radius=robot_radius, handles=handles)
    ax.axis("off")
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
