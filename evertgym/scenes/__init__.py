"""Scenes: seeded generators that build a channel into a pymunk space and describe it.

>>> from evertgym.scenes import make_scene
>>> scene = make_scene({"family": "ubend", "params": {"radius_mm": 25}})
>>> round(scene.lumen_at(0.1) * 1e3)
55

A scene is data (:class:`SceneSpec`: family, parameters in mm/degrees, seed); :func:`make_scene`
turns it into a :class:`Scene` (SI) that describes the channel (centreline, lumen width along
it, entry, goal, walls) and builds its walls into a space (:meth:`Scene.build`).  See
``docs/scenes.md`` for the families and their parameters.
"""

from evertgym.scenes.compliant import (
    WALL_CATEGORY,
    WALL_COLLISION_TYPE,
    WallMechanics,
    WallNetwork,
    wall_shape_filter,
)
from evertgym.scenes.families import FAMILIES, PAPER_UBEND_RADII_MM, make_scene
from evertgym.scenes.render import draw_scene, render_rgb
from evertgym.scenes.scene import Scene, SceneHandles
from evertgym.scenes.spec import Family, Param, SceneError, SceneSpec

__all__ = [
    "FAMILIES",
    "PAPER_UBEND_RADII_MM",
    "WALL_CATEGORY",
    "WALL_COLLISION_TYPE",
    "Family",
    "Param",
    "Scene",
    "SceneError",
    "SceneHandles",
    "SceneSpec",
    "WallMechanics",
    "WallNetwork",
    "draw_scene",
    "make_scene",
    "render_rgb",
    "wall_shape_filter",
]
