"""Fog and transparent layers in the window: the window's froxel grid, the froxels view (a
heat map of one depth slice's froxel light counts) and the HUD's lines of both features.
No GL but the froxel map's texture (FroxelView.upload).

    window grid   the froxel sets are built on the CPU every rendered frame, seconds at
                  capture's default 160x90x64; the window's default is WINDOW_FROXELS
                  (about 31x fewer froxels: ~0.1 s a frame on llvmpipe's 2 cores), W and H
                  at most the render's pixels (a reduced moving frame, one eye of stereo);
                  --froxels WxHxD overrides (clamped likewise), 'matched' as capture's
    froxels view  froxel_count of slice k (the frame's froxel_stats buffer, written by
                  fog_light: app/pipeline/fog.py), each froxel over the pixels its column
                  and row cover, log2(1 + n) turbo on one scale over the whole grid (so
                  that slices compare); < and > step k; the HUD gives the slice's depths
"""
from __future__ import annotations

import numpy as np

from cpu_prep import froxels as fx

from .. import images
from ..errors import UserError
from ..pipeline import fog as pfog
from ..pipeline.fog import FogOptions

WINDOW_FROXELS = (40, 23, 32)
FROXEL_VIEW = "froxels"
LAYERS_VIEW = "layers"


def scene_views(scene) -> tuple[str, ...]:
    """The window's views a scene has: froxels in fog, layers with transparent surfaces."""
    return tuple(v for v, has in ((LAYERS_VIEW, bool(scene.transparent_meshes())),
                                  (FROXEL_VIEW, scene.fog is not None)) if has)


def refuse_view(view: str, scene) -> None:
    """--view froxels / layers on a scene without that feature: one line."""
    if view == FROXEL_VIEW and scene.fog is None:
        raise UserError(f"--view {view}: the scene has no fog (the builtin hangar-fog, or a "
                        f"scene file's `fog` block)")
    if view == LAYERS_VIEW and not scene.transparent_meshes():
        raise UserError(f"--view {view}: the scene has no transparent surfaces (the builtin "
                        f"city-glass, or a mesh with opacity below 1)")


def layers_map(renderer):
    """The layers view of the frame just rendered: (lights evaluated per pixel over the
    opaque surface and every transparent layer, (h, w) GL rows; top; label; layers)."""
    from cpu_prep import layouts
    t = renderer.transparent
    w, h = renderer.size
    total = renderer.read("out_stats")["evaluated"][:w * h].astype(np.float32)
    n = w * h * layouts.PIXEL_STATS.itemsize
    used = t.used if t is not None else 0
    for k in range(used):           # 0 where a layer has no fragment
        total += np.frombuffer(t.stats.read(size=n, offset=k * n), layouts.PIXEL_STATS)["evaluated"]
    top = images.heat_top(float(total.max(initial=0.0)))
    return total.reshape(h, w), top, f"lights evaluated, opaque + {used} layers", used


def layers_note(top: float, used: int) -> str:
    return (f"layers: lights evaluated per pixel, the opaque surface and its {used} transparent "
            f"layers summed (the pixel's shading work), 0 .. {top:g}, log2(1 + n) turbo")


def window_options(given: FogOptions | None, size) -> FogOptions:
    """The window's fog options at render size `size`: the given grid (or WINDOW_FROXELS),
    its columns and rows at most the render's pixels."""
    fo = given or FogOptions()
    dims = fo.froxels if fo.froxels is not None else WINDOW_FROXELS
    if isinstance(dims, tuple):
        w, h = size
        dims = (min(dims[0], w), min(dims[1], h), dims[2])
    return FogOptions(dims, fo.samples, fo.lookup, fo.depth)


def grid_text(given: FogOptions | None) -> str:
    """Where the grid comes from, for the HUD."""
    if given is not None and given.froxels is not None:
        return "--froxels"
    w, h, d = WINDOW_FROXELS
    return f"window default {w}x{h}x{d}, capture's {'x'.join(map(str, fx.DEFAULT_FROXELS))}; --froxels sets it"


def feature_lines(f: dict) -> list[str]:
    """The HUD's lines of a frame's transparent layers and fog (figures 'transparent', 'fog')."""
    out = []
    t = f.get("transparent")
    if t:
        gpu = sum(t["gpu_ms"].values())
        out.append(f"transparent: {t['layers']} layers (of {t['max_layers']}) over the opaque "
                   f"image, GPU {gpu:.1f} ms (not in the GPU line); heat and diff: the opaque "
                   f"surface's (view layers: with the layers)")
    g = f.get("fog")
    if g:
        out.append(f"fog {g['froxels']} froxels ({g['grid']}): {g['lights_mean']:.3g} lights a "
                   f"froxel, sets built in {g['sets_ms']:.0f} ms"
                   + (f"; frame held since frame {g['held']} (nothing moved: no rebuild)"
                      if g.get("held") is not None else ""))
    return out


def fog_figures(meta: dict, given: FogOptions | None, held: int | None) -> dict | None:
    """The frame's fog figures (None without fog)."""
    if "fog" not in meta:
        return None
    s = meta["stats"]
    return {"froxels": s["froxels"], "lights_mean": s["froxel_lights_mean"],
            "sets_ms": round(float(meta["cpu_ms"].get("froxels", 0.0)), 2),
            "grid": grid_text(given), "held": held}


def transparent_figures(meta: dict) -> dict | None:
    t = meta.get("transparent")
    if not t:
        return None
    return {"layers": int(t["layers"]), "max_layers": int(t["max_layers"]),
            "gpu_ms": {k: round(float(v), 3) for k, v in t["gpu_ms"].items()}}


def slice_pixels(counts_k: np.ndarray, fg: fx.FroxelGrid, size) -> np.ndarray:
    """(h, w) float32 GL rows (row 0 at the bottom): each pixel the count of the froxel of
    slice k its centre lies in (counts_k: (H, W) GL rows, as fog_light writes them)."""
    w, h = size
    sx, sy = fg.width / w, fg.height / h             # the grid's pixels per render pixel
    cols = np.clip(np.searchsorted(fg.xs, (np.arange(w) + 0.5) * sx, "right") - 1, 0, len(fg.xs) - 2)
    rows = np.clip(np.searchsorted(fg.ys, (np.arange(h) + 0.5) * sy, "right") - 1, 0, len(fg.ys) - 2)
    return counts_k[rows][:, cols].astype(np.float32)


class FroxelView:
    """The froxels view of the frame just rendered: slice `k` of its grid."""

    def __init__(self):
        self.k = 0
        self.shown = None            # (k, D, z0, z1, top, lights mean of the slice)

    def step(self, by: int, depth: int | None) -> None:
        self.k += by
        if depth:
            self.k %= depth

    def note(self) -> str:
        if self.shown is None:
            return "froxels: no fog grid in this frame"
        k, d, z0, z1, top, mean = self.shown
        return (f"froxels: slice {k}/{d} (0 nearest), depth {z0:.2f} .. {z1:.2f} m: lights "
                f"meeting each froxel, {mean:.2f} on average, 0 .. {top:g}, log2(1 + n) "
                f"turbo (< > slice)")

    def figures(self) -> dict | None:
        """The slice shown, for the frame's JSON line."""
        if self.shown is None:
            return None
        k, d, z0, z1, top, mean = self.shown
        return {"k": k, "slices": d, "depth": [round(z0, 4), round(z1, 4)], "top": top,
                "mean": round(mean, 4)}

    def map_of(self, renderer, scene, result, size):
        """(pixels (h, w) GL rows, top of the scale, label) of slice k of this frame."""
        if scene.fog is None or "froxel_stats" not in renderer.provided():
            raise UserError("the froxels view needs a fog scene (the builtin hangar-fog, or a "
                            "scene file's `fog` block)")
        fo = renderer.fog_options or FogOptions()
        fg = pfog.froxel_grid(result.build, scene.fog, fo)
        w, h, d = fg.dims
        counts = renderer.read("froxel_stats")["count"].reshape(d, h, w)
        self.k = min(self.k, d - 1)          # --froxel-slice past the grid: its farthest
        top = images.heat_top(int(counts.max(initial=0)))
        k = self.k
        self.shown = (k, d, float(fg.zs[k]), float(fg.zs[k + 1]), top, float(counts[k].mean()))
        return slice_pixels(counts[k], fg, size), top, f"slice {k}/{d} lights a froxel"


def window_renderer(scene, size, given: FogOptions | None, layers: int | None):
    """The window's Renderer: its fog options the window's grid at whatever size it renders
    (the probe's small frames, a reduced moving frame, one eye)."""
    from ..pipeline.renderer import Renderer

    class WindowRenderer(Renderer):
        @property
        def fog_options(self):
            return window_options(self._fog_given, self.size)

        @fog_options.setter
        def fog_options(self, value):
            self._fog_given = value

    r = WindowRenderer(scene, size, transparent_layers=layers)
    r.fog_options = given
    return r
