"""Rendering above the simulator: fast RGB frames of a scene, a robot with its bands and an overlay.

:class:`FrameRenderer` caches a scene's background and draws each frame with Pillow (no
matplotlib figure per frame); :class:`Overlay` is the strip's text.  The matplotlib
drawing of scenes for figures stays in :mod:`evertgym.scenes.render`.
"""

from evertgym.render.raster import FrameRenderer, Overlay, robot_profile

__all__ = ["FrameRenderer", "Overlay", "robot_profile"]
