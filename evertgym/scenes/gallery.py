"""The scene gallery (docs/scene_gallery.png): one panel per scene family, titled with its parameters.

Usage: ``python -m evertgym.scenes.gallery [--out docs/scene_gallery.png] [--seed 3]``
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

import numpy as np
import pymunk
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from evertgym.scenes import FAMILIES, make_scene
from evertgym.scenes.render import draw_scene

#: Parameters shown in each panel's title (the rest are at their defaults or drawn).
SHOWN = {
    "straight": ("length_mm", "lumen_mm"),
    "ubend": ("radius_mm", "lumen_mm", "pipe_length_mm"),
    "bend": ("angle_deg", "radius_mm", "lumen_mm"),
    "sbend": ("angle_deg", "radius_mm", "middle_mm"),
    "tortuous": ("n_bends", "radius_mm", "angle_deg", "lumen_mm"),
    "colon": ("lumen_mm", "bend_radius_start_mm", "bend_radius_end_mm", "fold_depth_mm"),
    "colon_random": ("lumen_mm", "bend_angle_deg", "bend_radius_end_mm", "fold_spacing_mm", "wall_modulus_kpa"),
}


def _fmt(v) -> str:
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def title(scene) -> str:
    """Panel title: family, seed and the family's key parameters."""
    body = ", ".join(f"{k}={_fmt(scene.params[k])}" for k in SHOWN.get(scene.spec.family, ()))
    return f"{scene.spec.family} (seed {scene.spec.seed})\n" + textwrap.fill(body, 62)


def pushed_colon(force: float = 0.2, steps: int = 300):
    """The default colon built into pymunk, its outer wall at the bend pushed outwards by ``force`` (N)."""
    scene = make_scene({"family": "colon", "params": {}})
    space = pymunk.Space()
    handles = scene.build(space)
    net = handles.network
    assert net is not None  # the colon's walls are compliant
    s, e = scene.project(net.position)
    i = int(np.argmin(np.where(e < 0, np.abs(s - 0.39), np.inf)))  # right (outer) wall, just into the bend
    body = handles.bodies[i]
    for _ in range(steps):
        fx, fy = (float(v) for v in force * net.normal[i])
        body.apply_force_at_world_point((fx, fy), (float(body.position.x), float(body.position.y)))
        space.step(1e-3)
    return scene, handles, scene.point_at(np.linspace(0.0, 0.36, 73))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m evertgym.scenes.gallery", description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs") / "scene_gallery.png", help="the PNG to write")
    ap.add_argument("--seed", type=int, default=3, help="the scene seed of every panel")
    args = ap.parse_args(argv)
    scenes = [make_scene({"family": name, "params": {}, "seed": args.seed}) for name in FAMILIES]
    cols = 4
    rows = int(np.ceil(len(scenes) / cols))
    fig = Figure(figsize=(4.0 * cols, 3.4 * rows), dpi=110)
    FigureCanvasAgg(fig)
    for k, scene in enumerate(scenes):
        ax = fig.add_subplot(rows, cols, k + 1)
        draw_scene(ax, scene, title=title(scene))
        ax.set_xlabel(f"length {scene.length * 1e3:.0f} mm, goal at {scene.goal_arclength * 1e3:.0f} mm", fontsize=7)
    ax = fig.add_subplot(rows, cols, len(scenes) + 1)
    scene, handles, robot = pushed_colon()
    draw_scene(ax, scene, robot_xy=robot, robot_radius=0.01, handles=handles,
               title="colon (zoomed), drawn with a 20 mm robot to 360 mm;\nouter wall pushed by 0.2 N at the bend in pymunk")
    near = scene.centreline[scene.arclength > 0.27] * 1e3
    ax.set_xlim(near[:, 0].min() - 30, near[:, 0].max() + 30)
    ax.set_ylim(near[:, 1].min() - 30, near[:, 1].max() + 30)
    ax.set_xlabel(f"deepest indentation {handles.wall_displacement() * 1e3:.1f} mm", fontsize=7)
    for k in range(len(scenes) + 1, rows * cols):
        fig.add_subplot(rows, cols, k + 1).axis("off")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
