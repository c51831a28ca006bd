"""The window's feature-variant view (`--feature-variants`, app/techniques/variants.py):
each variant tile tinted by the program that shaded it, its borders dark, with the legend
in the HUD (colour name: mask, tiles), as HDRP's "show feature variants" tile debug view.

    legend(meta)             the masks in program order (most tiles first): their colours
    tile_colors(...)         RGBA per variant tile, uploaded as VARIANT_VIEW
    overlay_pass(...)        glsl/variant_view.frag over the present pass's shaded image

Colours are named so that the HUD's legend can say them: the programs take PALETTE in turn
(past its 12 colours they repeat, the legend says which); a tile of no lights is grey, a
mask that ran the general program (past the program cap) white.
"""
from __future__ import annotations

import numpy as np

from ..pipeline import features as feat
from ..pipeline.passes import Buffer, Draw, Pass

VARIANT_VIEW = "variant_view"
PALETTE = (("red", (230, 60, 60)), ("green", (60, 200, 90)), ("blue", (60, 110, 230)),
           ("yellow", (240, 220, 60)), ("magenta", (220, 80, 220)), ("cyan", (70, 220, 230)),
           ("orange", (250, 150, 40)), ("purple", (140, 80, 200)), ("lime", (170, 240, 90)),
           ("pink", (250, 170, 200)), ("teal", (40, 150, 140)), ("brown", (150, 100, 60)))
EMPTY = ("grey", (120, 120, 120))
GENERAL = ("white", (245, 245, 245))
ALPHA = 0.55                     # the tint over the shaded image


def legend(stats: dict) -> list[tuple[int, str, tuple, int]]:
    """(mask, colour name, rgb, tiles) of each mask the frame shaded, in program order
    (the stats' variant_masks: own programs first, then the general program's)."""
    masks = stats.get("variant_masks") or []
    own = int(stats.get("feature_variants", 0))
    tiles = dict(stats.get("variant_tiles") or {})
    out, k = [], 0
    for i, m in enumerate(masks):
        if i >= own:
            name, rgb = GENERAL
        elif not m & feat.SHAPE_MASK:
            name, rgb = EMPTY
        else:
            name, rgb = PALETTE[k % len(PALETTE)]
            k += 1
        out.append((int(m), name, rgb, int(tiles.get(feat.mask_label(m), 0))))
    return out


def legend_text(stats: dict) -> str:
    """The HUD's legend: 'red point+spot, specular (12) | ... | white: general program'."""
    if "variant_masks" not in stats:
        reason = stats.get("variant_fallback")
        return f"off ({reason})" if reason else "off: run with --feature-variants"
    entries = legend(stats)
    parts = [f"{name} {feat.mask_label(m)} ({t})" for m, name, _, t in entries]
    coloured = sum(1 for _, name, *_ in entries if name in dict(PALETTE))
    more = f"; colours repeat past {len(PALETTE)}" if coloured > len(PALETTE) else ""
    return f"{stats['variant_tile']} px tiles: " + " | ".join(parts) + more


def tile_colors(stats: dict, tile_masks: np.ndarray) -> np.ndarray:
    """(T, 4) float32 RGBA of each variant tile (GL row order, as tile_masks)."""
    table = np.zeros((feat.MASKS, 4), np.float32)
    for m, _, rgb, _ in legend(stats):
        table[m] = (*(np.asarray(rgb, np.float32) / 255.0), ALPHA)
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
