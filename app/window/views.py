"""The views and their overlays: what each view shows, and which of the technique's own
structure (its Build's grid) the tiles and slices views draw.  No GL here.

    shaded   the tone-mapped image (capture's --out)
    heat     lights evaluated per pixel, log turbo ramp
    classes  traversal case of each 8x8 wave (list / tree / mixed / empty)
    tiles    the technique's screen tiles (grid.tile), when it has a grid
    slices   the technique's depth slices (grid.slices > 1, listing 4)

A technique without a grid (brute, perfect) or without depth slices (tiled, tree) gets no
overlay it does not have: the view shows the shaded image and the HUD says why.
"""
from __future__ import annotations

from dataclasses import dataclass

VIEWS = ("shaded", "heat", "classes", "tiles", "slices")


@dataclass(frozen=True)
class Overlay:
    """The grid the overlays draw (present.frag u_tile, u_slices, ...); tile 0: no tiles,
    slices <= 1: no depth slices."""
    tile: int = 0
    tiles: tuple[int, int] = (0, 0)
    slices: int = 0
    slice_scale: float = 0.0
    slice_bias: float = 0.0

    @classmethod
    def of(cls, grid) -> "Overlay":
        """The overlay of a Build's grid (cpu_prep.grid.Grid), or of none (None)."""
        if grid is None:
            return cls()
        return cls(int(grid.tile), (int(grid.tiles_x), int(grid.tiles_y)), int(grid.slices),
                   float(grid.slice_scale), float(grid.slice_bias))

    def as_dict(self) -> dict | None:
        """For the frame's JSON line: None when the technique has no grid."""
        return {"tile": self.tile, "tiles": list(self.tiles), "slices": self.slices} if self.tile else None


def view_note(view: str, technique: str, overlay: Overlay, heat_top: float) -> str | None:
    """The HUD line that explains the current view (None: the shaded view needs none)."""
    if view == "heat":
        return f"heat: lights evaluated per pixel, 0 .. {heat_top:g}, log turbo ramp"
    if view == "classes":
        return "8x8 waves: blue list, green tree, white mixed, grey empty"
    if view == "tiles":
        if not overlay.tile:
            return f"no tiles for {technique}: it has no screen grid (shaded image shown)"
        tx, ty = overlay.tiles
        return f"tiles: {overlay.tile} px, {tx}x{ty} ({technique}'s grid)"
    if view == "slices":
        if overlay.slices > 1:
            return f"depth slices: {overlay.slices} (listing 4), slice 0 grey = near slice"
        what = "2D tiles only" if overlay.tile else "no screen grid"
        return f"no depth slices for {technique}: {what} (shaded image shown)"
    return None
