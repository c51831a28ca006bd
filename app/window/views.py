"""The views' overlays of a technique's own structure (its Build's grid), their GLSL ids
and the HUD line that explains the current view.  No GL.  The views themselves, and which
a technique has: app.views."""
from __future__ import annotations

from dataclasses import dataclass

from ..views import VIEWS


# the window's own views, beyond app.views (not a technique's: the scene's), and the view of
# present.frag that draws each (a count per pixel in the map texture, as the maps view):
# froxels (fog scenes) and layers (transparent surfaces), app.window.fog_view
WINDOW_VIEWS = {"froxels": "maps", "layers": "maps"}
# the views the two eyes of stereo show (each eye's own buffers; no second frame)
STEREO_VIEWS = ("shaded", "heat", "tiles", "slices", "classes", "layers", "froxels")


def present_view(view: str) -> str:
    """The present.frag view that draws `view`."""
    return WINDOW_VIEWS.get(view, view)


def view_defines() -> dict[str, int]:
    """VIEW_<NAME> ids for present.frag."""
    return {f"VIEW_{v.upper()}": i for i, v in enumerate(VIEWS)}


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


def view_note(view: str, technique: str, overlay: Overlay, heat_top: float, *,
              heat_of: str = "evaluated", overlay_mode: bool = False, reference: str = "brute",
              differ: int | None = None, split: str = "", split_view: str = "shaded",
              map_name: str = "", map_label: str = "", map_top: float = 0.0) -> str | None:
    """The HUD line that explains the current view (None: the shaded view needs none)."""
    if view == "heat":
        what = "lights evaluated" if heat_of == "evaluated" else "exact lights"
        return (f"heat: {what} per pixel, 0 .. {heat_top:g}, log2(1 + n) turbo"
                + (", over the shaded image" if overlay_mode else ""))
    if view == "classes":
        return "8x8 waves: blue list, green tree, white mixed, grey empty"
    if view == "tiles":
        if not overlay.tile:
            return f"no tiles: {technique} has no screen grid"
        tx, ty = overlay.tiles
        return f"tiles: {overlay.tile} px, {tx}x{ty} ({technique}'s grid)"
    if view == "slices":
        if overlay.slices > 1:
            return f"depth slices: {overlay.slices} (listing 4), slice 0 grey = near slice"
        return f"no depth slices: {technique} has 2D tiles only"
    if view == "diff":
        if differ is None:
            return f"diff vs {reference}: the reference is not rendered for this frame yet"
        if differ == 0:
            return f"diff vs {reference}: 0 pixels differ (the light sets are exact)"
        return f"diff vs {reference}: {differ} pixels differ (red)"
    if view == "split":
        return f"split: {technique} left | {split} right ({split_view})"
    if view == "variants":
        return f"variants: {map_label}"
    if view == "maps":
        if not map_name:
            return f"maps: {technique} has none for this frame"
        return f"map {map_name}: {map_label}, 0 .. {map_top:g}, log2(1 + n) turbo (M: next)"
    return None
