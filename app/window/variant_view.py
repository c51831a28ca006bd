"""The window's feature-variant view (`--feature-variants`, app/techniques/variants.py):
each variant tile tinted by the program that shaded it, its borders dark, as HDRP's "show
feature variants" tile debug view; the legend is a list in the panel (a colour swatch, the
mask, its tiles: app.window.ui), so the image stays clear of text.

    legend(stats)            the masks in program order (most tiles first): colour, tiles
    legend_note(stats)       the HUD's one line about the view (tile size, masks, programs)
    tile_colors(...)         RGBA per variant tile, uploaded as VARIANT_VIEW
    overlay_pass(...)        glsl/variant_view.frag over the present pass's shaded image

Every mask with a program of its own has its own colour: PALETTE holds MAX_PROGRAMS
colours picked far apart in CIELAB (palette()), away from the two shared ones: grey, the
tiles of no lights (every empty mask), and white, the masks past the program cap that ran
the general program.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..pipeline import features as feat
from ..pipeline.passes import Buffer, Draw, Pass
from ..techniques.variants import MAX_PROGRAMS

VARIANT_VIEW = "variant_view"
EMPTY = (120, 120, 120)          # grey: a tile of no lights (specular or not)
GENERAL = (245, 245, 245)        # white: a mask the general program shaded
ALPHA = 0.55                     # the tint over the shaded image


def _lab(rgb) -> np.ndarray:
    """CIELAB (D65) of sRGB colours 0..255, (..., 3)."""
    c = np.asarray(rgb, np.float64) / 255.0
    c = np.where(c > 0.04045, ((c + 0.055) / 1.055) ** 2.4, c / 12.92)
    xyz = c @ np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                        [0.0193, 0.1192, 0.9505]]).T / (0.95047, 1.0, 1.08883)
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], -1)


def palette(n: int) -> tuple[tuple[int, int, int], ...]:
    """`n` colours, each in turn the one of a 12-level sRGB grid farthest in CIELAB from
    those taken (grey, white and the dark tile borders first); light and saturated enough
    to read as a tint (L > 45, chroma > 30)."""
    levels = np.linspace(0, 255, 12).round()
    grid = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), -1).reshape(-1, 3)
    lab = _lab(grid)
    keep = (lab[:, 0] > 45) & (np.hypot(lab[:, 1], lab[:, 2]) > 30)
    grid, lab = grid[keep], lab[keep]
    near = np.linalg.norm(lab[:, None] - _lab([EMPTY, GENERAL, (0, 0, 0)])[None], axis=2).min(1)
    out = []
    for _ in range(n):
        i = int(np.argmax(near))
        out.append(tuple(int(v) for v in grid[i]))
        near = np.minimum(near, np.linalg.norm(lab - lab[i], axis=1))
    return tuple(out)


PALETTE = palette(MAX_PROGRAMS)        # a colour for every mask a frame can give a program


class Entry(NamedTuple):
    mask: int
    rgb: tuple[int, int, int]
    tiles: int
    shares: str          # "": its own colour; else why it shares one ("no lights", "general program")

    @property
    def label(self) -> str:
        return feat.mask_label(self.mask)


def legend(stats: dict) -> list[Entry]:
    """Each mask the frame shaded, in program order (the stats' variant_masks: own
    programs first, then the general program's): its colour, tiles, and what it shares."""
    masks = stats.get("variant_masks") or []
    own = int(stats.get("feature_variants", 0))
    tiles = dict(stats.get("variant_tiles") or {})
    out, k = [], 0
    for i, m in enumerate(masks):
        if i >= own:
            rgb, shares = GENERAL, "general program"
        elif not m & feat.SHAPE_MASK:
            rgb, shares = EMPTY, "no lights"
        else:
            rgb, shares = PALETTE[k], ""
            k += 1
        out.append(Entry(int(m), rgb, int(tiles.get(feat.mask_label(m), 0)), shares))
    return out


def legend_note(stats: dict) -> str:
    """The HUD's line: '8 px tiles, 26 masks (26 programs); the colours in the panel'."""
    if "variant_masks" not in stats:
        reason = stats.get("variant_fallback")
        return f"off ({reason})" if reason else "off: run with --feature-variants"
    masks, own = len(stats["variant_masks"]), int(stats.get("feature_variants", 0))
    general = f", {masks - own} by the general program (white)" if masks > own else ""
    return (f"{stats['variant_tile']} px tiles, {masks} masks ({own} programs{general}); "
            f"the colours are listed in the panel (F1)")


def tile_colors(stats: dict, tile_masks: np.ndarray) -> np.ndarray:
    """(T, 4) float32 RGBA of each variant tile (GL row order, as tile_masks)."""
    table = np.zeros((feat.MASKS, 4), np.float32)
    for e in legend(stats):
        table[e.mask] = (*(np.asarray(e.rgb, np.float32) / 255.0), ALPHA)
    return table[np.asarray(tile_masks, np.int64)]


def overlay_pass(target, size, viewport, stats: dict) -> Pass:
    """The tint and the tile borders over what the present pass drew into `target`."""
    vt = int(stats["variant_tile"])
    return Pass("variants view", ("present.vert", "variant_view.frag"), reads=(VARIANT_VIEW,),
                draw=Draw(count=4, mode="triangle_strip", target=target, blend=True,
                          viewport=(0, 0, *viewport)), timed=False,
                uniforms={"u_rect": (-1.0, -1.0, 1.0, 1.0), "u_size": tuple(size),
                          "u_viewport": tuple(viewport), "u_variant_tile": vt,
                          "u_variant_tiles_x": -(-size[0] // vt)})
