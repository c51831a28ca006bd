"""The debug draws of the cursor (inspect mode): what is under it, from the frame's own data.

    pixel   its view depth; the lights the shading pass found affecting it (the renderer's
            debug_pixel: ids recorded by the shading loop itself); how many the technique
            evaluated there (its out_stats)
    light   of those, the one whose centre is nearest the surface point relative to its
            radius; its bounding sphere (the culling sphere the CPU stage uses, margins
            included) is drawn: silhouette, and the surfaces inside it tinted
    tile    the technique's tile under the cursor (its Build's grid) with its light list:
            the visible lights whose screen rectangle overlaps the tile and whose depth range
            overlaps the tile's depth range (the G-buffer's min/max there), i.e. a 2D tile
            list with Harada's depth test; a technique's own list is this or tighter (2.5D
            cells, trees): its `evaluated` count at the pixel says how much it walked

Pixel coordinates here are GL's (x, y from the bottom) at the render size.  No GL calls:
the app reads the G-buffer rectangle and the pixel's counters and passes them in.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Inspection:
    pixel: tuple[int, int]                    # GL coordinates
    depth: float = 0.0                        # linear view depth, 0 = sky
    evaluated: int = 0
    affecting: list[int] = field(default_factory=list)      # light ids
    light: int | None = None                  # the picked light's id
    light_type: int = 0
    sphere: tuple[float, float, float, float] | None = None  # view-space centre, radius
    tile: tuple[int, int, int, int] | None = None            # x0, y0, x1, y1 (GL, exclusive)
    tile_index: tuple[int, int] | None = None
    tile_depth: tuple[float, float] | None = None
    tile_lights: list[int] = field(default_factory=list)    # ids, depth order

    def as_dict(self) -> dict:
        return {"pixel": list(self.pixel), "depth": round(self.depth, 4), "evaluated": self.evaluated,
                "affecting": self.affecting, "light": self.light,
                "sphere": [round(v, 4) for v in self.sphere] if self.sphere else None,
                "tile": list(self.tile) if self.tile else None,
                "tile_index": list(self.tile_index) if self.tile_index else None,
                "tile_lights": len(self.tile_lights)}

    def lines(self, most: int = 24) -> list[str]:
        """The panel's text."""
        x, y = self.pixel
        out = [f"pixel ({x}, {y}) " + (f"depth {self.depth:.2f} m" if self.depth > 0 else "sky"),
               f"  evaluated {self.evaluated}, affected by {len(self.affecting)}: "
               + _ids(self.affecting, most)]
        if self.light is not None:
            cx, cy, cz, r = self.sphere
            out.append(f"  light {self.light}: bounding sphere r {r:.2f} m at depth {-cz:.1f} m (drawn)")
        if self.tile is not None:
            tx, ty = self.tile_index
            lo, hi = self.tile_depth or (0.0, 0.0)
            out.append(f"tile ({tx}, {ty}) {self.tile[2] - self.tile[0]}x{self.tile[3] - self.tile[1]} px, "
                       f"depth {lo:.1f}..{hi:.1f} m: {len(self.tile_lights)} light"
                       + ("" if len(self.tile_lights) == 1 else "s"))
            out.append("  " + _ids(self.tile_lights, most))
        return out


def _ids(ids, most: int) -> str:
    ids = list(ids)
    return "[" + ", ".join(map(str, ids[:most])) + (f", ... {len(ids)} in all" if len(ids) > most else "") + "]"


def inspect(pixel, build, debug_ids, evaluated: int, tile_positions=None, tile_rect=None) -> Inspection:
    """What is under `pixel` (GL): `build` the frame's Build (visible lights, grid),
    `debug_ids` the ids the shading pass found affecting the pixel, `tile_positions` the
    G-buffer positions (h, w, 4; w = depth) of `tile_rect` (x0, y0, x1, y1), the cursor's
    tile when the technique has a grid (else a small square around the pixel)."""
    ins = Inspection(tuple(int(v) for v in pixel), evaluated=int(evaluated),
                     affecting=sorted(int(i) for i in debug_ids))
    pl = build.lights
    P = None
    if tile_positions is not None and tile_rect is not None:
        x0, y0, x1, y1 = tile_rect
        px, py = ins.pixel
        here = tile_positions[py - y0, px - x0]
        if here[3] > 0:
            ins.depth = float(here[3])
            P = np.asarray(here[:3], np.float64)
        depths = tile_positions[..., 3]
        depths = depths[depths > 0]
        if build.grid is not None:
            ins.tile = tuple(int(v) for v in tile_rect)
            g = build.grid.tile
            ins.tile_index = (x0 // g, y0 // g)
            if len(depths):
                lo, hi = float(depths.min()), float(depths.max())
                ins.tile_depth = (lo, hi)
                ins.tile_lights = tile_list(pl, tile_rect, lo, hi)
    if P is not None and ins.affecting and len(pl):
        ids = np.asarray(pl.ids)
        rows = np.flatnonzero(np.isin(ids, ins.affecting))
        if len(rows):
            centre = np.asarray(pl.center)[rows]
            radius = np.asarray(pl.bound_radius)[rows]
            k = rows[int(np.argmin(np.linalg.norm(centre - P, axis=1) / np.maximum(radius, 1e-30)))]
            ins.light = int(ids[k])
            ins.light_type = int(np.asarray(pl.type)[k])
            c = np.asarray(pl.center)[k]
            ins.sphere = (float(c[0]), float(c[1]), float(c[2]), float(pl.bound_radius[k]))
    return ins


def tile_list(pl, rect, depth_lo: float, depth_hi: float) -> list[int]:
    """Ids of the visible lights whose screen rectangle overlaps `rect` (GL x0, y0, x1, y1,
    exclusive ends) and whose depth range overlaps [depth_lo, depth_hi], in depth order."""
    if not len(pl):
        return []
    x0, y0, x1, y1 = rect
    keep = (np.asarray(pl.depth_hi) >= depth_lo) & (np.asarray(pl.depth_lo) <= depth_hi)
    r = getattr(pl, "rect", None)
    if r is not None:
        r = np.asarray(r)
        keep &= (r[:, 0] < x1) & (r[:, 1] >= x0) & (r[:, 2] < y1) & (r[:, 3] >= y0)
    return [int(v) for v in np.asarray(pl.ids)[keep]]
