"""A fast frame rasteriser (Pillow, no matplotlib figure per frame).

:class:`FrameRenderer` draws a scene once into a cached background (lumen, rigid walls,
dashed centreline, entry arrow, goal line); each frame copies it and draws what moves:
the compliant wall pieces where they are now, the robot as the tube it is (its radius
``r``, and ``r (1 - rho)`` over each band's strip, drawn dark and marked with ticks across
the body), and an overlay strip with time, pressure (command and measured), insertion and
outcome.  Drawing is supersampled (``supersample`` x) and reduced with a box filter, so
edges are anti-aliased.

Colours: lumen pale blue, rigid walls grey, compliant walls rose, robot orange, bands
dark grey, entry green, goal red.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from evertgym.scenes.geometry import polyline_normals
from evertgym.scenes.scene import Scene, SceneHandles

if TYPE_CHECKING:  # Pillow is imported when a renderer is made, not with an env
    from PIL import Image, ImageDraw

LUMEN = (232, 240, 247)
RIGID = (90, 90, 90)
COMPLIANT = (208, 128, 128)
ROBOT = (240, 140, 0)
ROBOT_EDGE = (168, 93, 0)
BAND = (52, 58, 64)
CENTRELINE = (122, 156, 192)
ENTRY = (43, 138, 62)
GOAL = (224, 49, 49)
BACKGROUND = (255, 255, 255)
TEXT = (20, 20, 20)
#: Resampling step of the robot's centreline (m): fine enough that a 15 mm band shows.
ROBOT_STEP_M = 1e-3


@dataclass(frozen=True)
class Overlay:
    """What the overlay strip prints (SI; shown in s, kPa and mm)."""

    time_s: float
    command_pa: float
    pressure_pa: float
    insertion_m: float
    robot_length_m: float
    outcome: str = "running"


def robot_profile(centreline: np.ndarray, radius_m: float, bands: Sequence[tuple[float, float, float]],
                  step_m: float = ROBOT_STEP_M) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Resample the robot's centreline (base to tip, m) every ``step_m``.

    ``bands`` holds ``(position_m, reduction, width_m)`` from the base.  Returns the points
    (K, 2), their arc length (K,) and each point's radius (K,): ``radius_m (1 - reduction)``
    inside a band's strip, ``radius_m`` elsewhere.
    """
    xy = np.asarray(centreline, dtype=float)
    seg = np.hypot(*np.diff(xy, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if len(xy) < 2 or s[-1] <= 0:
        return xy[:1], np.zeros(1), np.full(1, radius_m)
    fine = np.append(np.arange(0.0, s[-1], step_m), s[-1])
    pts = np.column_stack([np.interp(fine, s, xy[:, 0]), np.interp(fine, s, xy[:, 1])])
    r = np.full(len(fine), radius_m)
    for pos, red, width in bands:
        r[np.abs(fine - pos) <= 0.5 * width] = radius_m * (1.0 - red)
    return pts, fine, r


def _decimate(px: np.ndarray, min_px: float) -> np.ndarray:
    """About one point per ``min_px`` of length (first and last kept): Pillow's wide lines
    leave slits between very short segments."""
    if len(px) < 3:
        return px
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(px, axis=0).T))])
    bucket = np.floor(cum / min_px)
    keep = np.flatnonzero(np.diff(bucket, prepend=-1.0) > 0)
    if keep[-1] != len(px) - 1:
        keep = np.append(keep, len(px) - 1)
    return px[keep]


class FrameRenderer:
    """Frames of one scene, ``width`` x ``height`` RGB, the scene's background drawn once.

    The top ``overlay_px`` rows are the overlay strip; the scene fills the rest at equal
    aspect, shown in the box of its walls plus a margin.
    """

    def __init__(self, scene: Scene, width: int = 480, height: int = 480, supersample: int = 2,
                 overlay_px: int = 40, handles: SceneHandles | None = None):
        if width < 32 or height < 32 + overlay_px:
            raise ValueError(f"width = {width}, height = {height}: need at least 32 x {32 + overlay_px} pixels")
        if supersample not in (1, 2, 3, 4):
            raise ValueError(f"supersample = {supersample!r}: allowed 1, 2, 3 or 4")
        self.scene, self.width, self.height, self.k, self.overlay_px = scene, width, height, supersample, overlay_px
        thickness = 2.0 * scene.wall_radius
        pts = np.vstack(scene.walls)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.06 * float(np.max(hi - lo)) + thickness
        lo, hi = lo - pad, hi + pad
        w, h = width * supersample, (height - overlay_px) * supersample
        self.scale = min(w / (hi[0] - lo[0]), h / (hi[1] - lo[1]))  # pixels per metre (supersampled)
        centre = 0.5 * (lo + hi)
        self._offset = np.array([0.5 * w, overlay_px * supersample + 0.5 * h])
        self._centre = centre
        self._moved = handles is not None and handles.network is not None
        self._background = self._draw_background(thickness)
        from PIL import ImageFont

        try:
            self.font = ImageFont.load_default(size=11)
        except TypeError:  # Pillow < 10.1: a bitmap font of one size
            self.font = ImageFont.load_default()

    # ---- geometry --------------------------------------------------------------
    def to_px(self, xy: np.ndarray) -> np.ndarray:
        """World points (m) -> supersampled pixel coordinates (y down)."""
        d = (np.asarray(xy, dtype=float) - self._centre) * self.scale
        return np.stack([self._offset[0] + d[..., 0], self._offset[1] - d[..., 1]], axis=-1)

    def _poly(self, xy: np.ndarray) -> list[tuple[float, float]]:
        return [tuple(p) for p in self.to_px(xy)]

    # ---- background ----------------------------------------------------------
    def _draw_background(self, thickness: float) -> Image.Image:
        from PIL import Image, ImageDraw

        sc, k = self.scene, self.k
        img = Image.new("RGB", (self.width * k, self.height * k), BACKGROUND)
        d = ImageDraw.Draw(img)
        left, right = sc.walls
        d.polygon(self._poly(np.vstack([left, right[::-1]])), fill=LUMEN)
        split = min(sc.compliant_start + 1, len(sc.arclength))
        for wall, outward in ((left, 1.0), (right, -1.0)):
            parts = [(wall[:split], RIGID)]
            if sc.compliant and not self._moved:
                parts.append((wall[split - 1:], COMPLIANT))
            for part, colour in parts:
                if len(part) > 1:
                    outer = part + outward * polyline_normals(part) * thickness
                    d.polygon(self._poly(np.vstack([part, outer[::-1]])), fill=colour)
        c = self.to_px(sc.centreline)
        for i in range(0, len(c) - 1, 2):  # dashed: every other sample interval
            d.line([tuple(c[i]), tuple(c[i + 1])], fill=CENTRELINE, width=max(1, k))
        e, u = sc.entry, np.asarray(sc.entry_direction, float)
        w0 = sc.lumen_width[0]
        tip = e + u * 0.6 * w0
        nrm = np.array([-u[1], u[0]])
        d.line(self._poly(np.vstack([e, tip])), fill=ENTRY, width=2 * k)
        d.polygon(self._poly(np.vstack([tip, tip - u * 0.15 * w0 + nrm * 0.08 * w0, tip - u * 0.15 * w0 - nrm * 0.08 * w0])),
                  fill=ENTRY)
        i = int(np.searchsorted(sc.arclength, sc.goal_arclength).clip(0, len(sc.arclength) - 1))
        n = np.array([-np.sin(sc.heading[i]), np.cos(sc.heading[i])])
        half = 0.5 * sc.lumen_at(sc.goal_arclength)
        d.line(self._poly(sc.goal + np.outer([-1.0, 1.0], n) * half), fill=GOAL, width=2 * k)
        return img

    # ---- frame -------------------------------------------------------------------
    def frame(self, centreline: np.ndarray | None = None, radius_m: float | None = None,
              bands: Sequence[tuple[float, float, float]] = (), handles: SceneHandles | None = None,
              overlay: Overlay | None = None) -> np.ndarray:
        """One RGB frame (height, width, 3) uint8.

        ``centreline``: the robot's nodes from base to tip (m); ``radius_m`` its bare radius;
        ``bands``: ``(position_m from the base, reduction, width_m)`` each; ``handles``: the
        scene's pymunk handles (compliant walls drawn where they are); ``overlay``: the
        strip's text (none if None).
        """
        from PIL import ImageDraw

        img = self._background.copy()
        d = ImageDraw.Draw(img)
        if self._moved and handles is not None and handles.network is not None:
            lw = max(1, int(round(2.0 * handles.network.shape_radius * self.scale)))
            for body, outline in zip(handles.bodies, handles.network.outline):
                c, s = np.cos(body.angle), np.sin(body.angle)
                pts = outline @ np.array([[c, s], [-s, c]]) + np.array(tuple(body.position))
                d.line(self._poly(pts), fill=COMPLIANT, width=lw)
        if centreline is not None and len(centreline) > 1 and radius_m is not None:
            self._draw_robot(d, np.asarray(centreline, float), float(radius_m), bands)
        if self.k > 1:
            img = img.reduce(self.k)
        if overlay is not None:
            self._draw_overlay(ImageDraw.Draw(img), overlay)
        return np.asarray(img)

    def _draw_robot(self, d: ImageDraw.ImageDraw, centreline: np.ndarray, radius_m: float,
                    bands: Sequence[tuple[float, float, float]]) -> None:
        pts, s, r = robot_profile(centreline, radius_m, bands)
        px = self.to_px(pts)
        rpx = r * self.scale
        # runs of equal radius: bare tube orange, band strips dark and narrower (butt ends give the step)
        cuts = np.flatnonzero(np.diff(r) != 0) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(r)]):
            run = _decimate(px[max(a - 1, 0):b], 3.0 * self.k)
            if len(run) < 2:
                continue
            colour = BAND if r[a] < radius_m else ROBOT
            # the tube's outline (offset curves) fills the outer side of bends; the wide line its inner side
            off = polyline_normals(run) * rpx[a]
            d.polygon([tuple(q) for q in np.vstack([run + off, (run - off)[::-1]])], fill=colour)
            d.line([tuple(q) for q in run], fill=colour, width=max(1, int(round(2 * rpx[a]))), joint="curve")
        tip, rt = px[-1], rpx[-1]
        d.ellipse([tip[0] - rt, tip[1] - rt, tip[0] + rt, tip[1] + rt], fill=BAND if r[-1] < radius_m else ROBOT)
        d.line([tuple(p) for p in _decimate(px, 3.0 * self.k)], fill=ROBOT_EDGE, width=max(1, self.k))
        # ticks across the body at each visible band's centre, reaching past the bare radius
        nrm = polyline_normals(pts) if len(pts) > 1 else np.zeros((1, 2))
        for pos, _, _ in bands:
            if pos > s[-1]:
                continue
            i = int(np.clip(np.searchsorted(s, pos), 0, len(s) - 1))
            n = nrm[i] * np.array([1.0, -1.0])  # y down in pixels
            reach = 1.35 * radius_m * self.scale
            d.line([tuple(px[i] - n * reach), tuple(px[i] + n * reach)], fill=BAND, width=max(1, self.k))

    def _draw_overlay(self, d: ImageDraw.ImageDraw, o: Overlay) -> None:
        """The strip's text, drawn at the output resolution."""
        d.rectangle([0, 0, self.width, self.overlay_px - 1], fill=(250, 250, 250))
        d.line([(0, self.overlay_px - 1), (self.width, self.overlay_px - 1)], fill=(200, 200, 200))
        line1 = f"t {o.time_s:5.1f} s   pressure {o.pressure_pa / 1e3:4.2f} kPa (command {o.command_pa / 1e3:4.2f})"
        line2 = f"insertion {o.insertion_m * 1e3:4.0f} / {o.robot_length_m * 1e3:.0f} mm   {o.outcome}"
        d.text((6, 4), line1, fill=TEXT, font=self.font)
        colour = {"success": ENTRY, "stalled": GOAL, "ruptured": GOAL}.get(o.outcome, TEXT)
        d.text((6, 21), line2, fill=colour, font=self.font)
