"""Per-tile feature variants with indirect dispatch (`--feature-variants`), after HDRP's
deferred lighting (Unity-Technologies/Graphics, com.unity.render-pipelines.high-definition:
LightDefinitions.cs / LightLoop.cs FeatureFlags, LightFeatureFlags, MaterialFeatureFlags;
Lit.hlsl kFeatureVariantFlags and FeatureFlagsToTileVariant; builddispatchindirect.compute;
Deferred.compute's Deferred_Indirect_Fptl_Variant<N> kernels).

    culling (the technique's own passes)
      -> variant_cells     per cell: the shapes its lights have (+ hybrid: list or tree);
                           fptl's list pass writes these words itself (CELL_PRECOMPUTED)
      -> variant_classify  per variant tile: OR of its shading pixels' cell bits, + specular
      -> variant_compact   per tile: appended to its mask's list, that mask's indirect
                           arguments counted up (HDRP's BuildIndirect)
      -> host step         which masks occur (the arguments' x, 128 x 12 B read back):
                           one program per mask, compiled on demand and cached
      -> shade             per mask: its program, glDispatchComputeIndirect over its tiles

    tile_masks[T]            uint mask per variant tile        (T = 510 at 960x540, 32 px)
    variant_args[128]        uvec3 (tiles, 8x8 groups a tile, 1) per mask        (1.5 KiB)
    variant_tiles[128 x T]   tx | ty << 16, mask m's k-th tile at m * T + k
                             (HDRP's g_TileList: tiles x variants; 255 KiB at 960x540, 32 px)

A mask (app.pipeline.features.FEATURE_BITS) is the light shapes the tile's lists hold, a
specular bit when a pixel of it has a GGX material, and hybrid's cell kinds; a tile whose
lists are empty (sky included) has no shape bit and compiles no light code.  Its program is
the technique's own shading pass with that mask's features.glsl (and hybrid's CELL_KINDS):
the same loops over the same lists, so the same lights at every pixel, only the code for
what the tile lacks left out.

Where this departs from HDRP, and why:
  * HDRP maps a tile to the first of its 29 precompiled variants that covers its flags;
    here each mask that occurs is its own program, compiled when first met (the program
    cache keys on defines and generated files), so the frame reads back which masks occur
    (variant_args, before the shading dispatches: a sync an engine with a fixed table
    avoids; it is untimed set-up, and the timed samples re-run only the GPU passes).  The
    MAX_PROGRAMS masks with the most tiles get programs (HDRP's 29 variants, the last its
    catch-all), the rest run the general program over their lists, and the stats say so.
  * HDRP does not dispatch sky tiles; here every tile is dispatched (the empty program
    writes its pixels' outputs), so no tile is ever skipped.
  * Classification tile: the technique's own shading tile (a tile's list is one list, as
    HDRP's 16x16 FPTL tile is its classification tile), or HDRP's 16 where that tile is not
    a multiple of the 8x8 group (a group must lie in one tile).
A frame whose tiles all have one mask runs one direct dispatch of its program, as without
variants; a driver without indirect dispatch runs the general program alone.  Either
fallback is named in the meta (stats.variant_fallback).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from cpu_prep import layouts, limits

from ..model import waves
from ..pipeline import features as feat
from ..pipeline.passes import OUT_STATS, WAVE_DIM, WAVE_STATS, Buffer, HostStep, Pass, image_groups
from .base import grid_uniforms

CELL_LISTS, CELL_NODES, CELL_BITS = 1, 2, 3       # variant_cells.comp CELL_SOURCE
# ... or the technique's own pass writes cell_features, and variant_cells does not run (fptl:
# its packed lists with spill are no CSR scan; fptl_lists.comp ORs each kept light's shape)
CELL_PRECOMPUTED = 4
# A cell scan longer than this takes every shape of the frame unscanned: 8 llvmpipe lanes in
# lockstep x 4,096 stay within its 65,535-iteration loop limit (docs/platform.md "Platform facts").
SCAN_BUDGET = 4096
MAX_PROGRAMS = 28        # specialised programs a frame; with the general one HDRP's 29 variants
HDRP_TILE = 16           # HDRP's classification tile (TILE_SIZE_FPTL)
ARGS = 12                # bytes of one DispatchIndirectCommand
PIXEL_SHADES = np.uint32(1 << 31)    # variant_classify.comp PIXEL_FEATURES: the pixel shades
_SHADES_GLSL = f"{int(PIXEL_SHADES):#x}u"   # its define there (one source)


@dataclass(frozen=True)
class CellSource:
    """Where a technique's pixels find their lights, for variant_cells.comp: its kind
    (CELL_LISTS, CELL_NODES, CELL_BITS; CELL_PRECOMPUTED: the technique's pass wrote
    cell_features), the slots it reads and their frame buffers, its uniforms, and the
    defines a mask adds to the technique's program (hybrid's CELL_KINDS)."""
    kind: int
    reads: tuple[str, ...]
    sources: dict = field(default_factory=dict)
    uniforms: dict = field(default_factory=dict)
    count_mask: int = 0xFFFFFFFF
    mask_defines: Callable[[int], dict] = lambda mask: {}


def variant_tile(tile: int) -> int:
    """The classification tile: the technique's tile when the 8x8 groups tile it, else HDRP's."""
    return tile if tile % WAVE_DIM == 0 else HDRP_TILE


def tile_grid(build) -> tuple[int, int, int]:
    """(variant tile px, tiles x, tiles y) of a frame."""
    vt = variant_tile(build.grid.tile)
    w, h = build.frame.size
    return vt, -(-w // vt), -(-h // vt)


def frame_shape_mask(build) -> int:
    """The shape bits of the frame's visible lights (the general program's shapes)."""
    names = feat.feature_set(build.lights.type)
    return feat.mask_of(tuple(n for n in names if n in feat.LIGHT_TYPES))


def general_mask(build) -> int:
    """The mask the general program compiles: the frame's shapes, specular if any surface."""
    spec = feat.FEATURE_BITS[feat.SPECULAR] if build.frame.specular else 0
    return frame_shape_mask(build) | spec


def on(build, opts) -> bool:
    """Whether the frame classifies its tiles: the option on and a driver that dispatches
    indirectly (a CELL_PRECOMPUTED technique writes its cell words only then)."""
    return bool(getattr(opts, "feature_variants", False)) and build.frame.limits.indirect_dispatch


def with_variants(build, opts, steps: list, cells: CellSource) -> list:
    """The technique's steps with its shading passes run per feature variant (module doc);
    unchanged with the option off, and the general program alone (the meta saying why)
    where the driver cannot dispatch indirectly."""
    if not getattr(opts, "feature_variants", False):
        return steps
    shade = [k for k, s in enumerate(steps) if isinstance(s, Pass) and OUT_STATS in s.writes]
    if not build.frame.limits.indirect_dispatch:
        build.stats["variant_fallback"] = "no indirect dispatch (glDispatchComputeIndirect) in " \
                                          "this driver: the general program shades every tile"
        return steps
    general, after = steps[shade[0]:shade[-1] + 1], steps[shade[-1] + 1:]
    # the steps after shading (its counters) come with the dispatches: the frame graph checks
    # what a host step returns once it has run, and they read what those dispatches write
    decide = HostStep("feature variants", ("variant_args",), lambda got: (
        {}, variant_steps(build, general, cells, got["variant_args"]) + after))
    return steps[:shade[0]] + classify_passes(build, cells) + [decide]


def classify_passes(build, cells: CellSource) -> list[Pass]:
    """variant_cells (unless CELL_PRECOMPUTED), variant_classify, variant_compact (timed: the
    variants' own cost)."""
    g = build.grid
    vt, tx, ty = tile_grid(build)
    tiles = tx * ty
    w, h = build.frame.size
    shapes = frame_shape_mask(build)
    scan = [] if cells.kind == CELL_PRECOMPUTED else [
        Pass("variant_cells", "variant_cells.comp", reads=("lights",) + cells.reads,
             writes={"cell_features": Buffer(4 * g.cells)}, groups=(-(-g.cells // 64), 1, 1),
             defines={"CELL_SOURCE": cells.kind, "SCAN_BUDGET": SCAN_BUDGET,
                      "CELL_COUNT_MASK": f"{cells.count_mask:#x}u"},
             uniforms=dict(cells.uniforms, u_cells=g.cells, u_frame_shapes=shapes),
             sources=dict(cells.sources))]
    return scan + [
        Pass("variant_classify", "variant_classify.comp", reads=("lights", "cell_features"),
             writes={"tile_masks": Buffer(4 * tiles, cleared=True)}, groups=image_groups(w, h),
             defines={"VARIANT_TILE": vt, "PIXEL_FEATURES": 0, "PIXEL_SHADES": _SHADES_GLSL},
             uniforms=dict(grid_uniforms(g), u_variant_tiles_x=tx)),
        Pass("variant_compact", "variant_compact.comp", reads=("tile_masks",),
             writes={"variant_args": Buffer(ARGS * feat.MASKS, cleared=True),
                     "variant_tiles": Buffer(4 * feat.MASKS * tiles)},
             groups=(-(-tiles // 64), 1, 1), defines={"VARIANT_TILE": vt},
             uniforms={"u_variant_tiles": tiles, "u_variant_tiles_x": tx}),
    ]


def programs_for(tiles_per_mask: np.ndarray) -> tuple[list[int], list[int]]:
    """(masks with their own program, masks run by the general program): the masks that
    occur, the MAX_PROGRAMS with the most tiles first (ties: the lower mask)."""
    present = np.nonzero(tiles_per_mask)[0]
    order = present[np.lexsort((present, -tiles_per_mask[present]))]
    return [int(m) for m in order[:MAX_PROGRAMS]], [int(m) for m in order[MAX_PROGRAMS:]]


def mask_program(p: Pass, mask: int, cells: CellSource) -> dict:
    """The replace() fields that make the general pass `p` the program of `mask`."""
    files = {"features.glsl": feat.features_glsl(feat.mask_features(mask))}
    return {"virtual": files, "defines": dict(p.defines, **cells.mask_defines(mask))}


def variant_steps(build, general: list[Pass], cells: CellSource, args: np.ndarray) -> list:
    """The shading dispatches for the masks the frame's tiles have (variant_args' counts)."""
    vt, tx, ty = tile_grid(build)
    tiles = tx * ty
    per_mask = np.asarray(args, np.uint32).reshape(feat.MASKS, 3)[:, 0].astype(np.int64)
    own, rest = programs_for(per_mask)
    record_stats(build, per_mask, own, rest)
    figures = figure_steps(build, cells, own)
    single = len(own) == 1 and not rest
    build.stats["variant_dispatches"] = 1 if single else len(own) + len(rest)
    if single:                            # one mask: one dispatch over the image, as ever
        return figures + [replace(p, **mask_program(p, own[0], cells)) for p in general]
    out = []
    for mask in own + rest:
        for p in general:
            fields = mask_program(p, mask, cells) if mask in own else {}
            defines = dict(fields.pop("defines", p.defines), VARIANT_TILE=vt)
            writes = dict(p.writes)
            if out:           # the first dispatch zeroes the wave statistics, no later one
                writes[WAVE_STATS] = replace(writes[WAVE_STATS], cleared=False)
            out.append(replace(p, **fields, defines=defines, writes=writes,
                               reads=tuple(p.reads) + ("variant_tiles",),
                               groups=(tiles, (vt // WAVE_DIM) ** 2, 1),
                               indirect=("variant_args", ARGS * mask),
                               uniforms=dict(p.uniforms, u_variant_base=mask * tiles)))
    return figures + out


def record_stats(build, per_mask: np.ndarray, own: list[int], rest: list[int]) -> None:
    """Meta stats: programs, tiles per mask (by name), dispatches, the fallback if any."""
    vt, *_ = tile_grid(build)
    build.stats.update(
        feature_variants=len(own), variant_tile=vt,
        variant_tiles={feat.mask_label(m): int(per_mask[m]) for m in own + rest},
        variant_masks=[int(m) for m in own + rest],
        # numeric, for results.csv's stats column (the report's study of the option)
        variant_tiles_total=int(per_mask.sum()), variant_masks_seen=len(own) + len(rest),
        variant_tiles_most=int(per_mask.max()), variant_tiles_fewest=int(per_mask[own + rest].min()))
    if rest:
        build.stats["variant_fallback"] = (
            f"{len(rest)} masks past the {MAX_PROGRAMS} programs ({int(per_mask[rest].sum())} "
            f"tiles) ran the general program")
    else:
        build.stats.pop("variant_fallback", None)


def figure_steps(build, cells: CellSource, own: list[int]) -> list:
    """Figures only (untimed): each pixel's own bits, then the shares of shading pixels whose
    program compiled specular code or a shape test they did not need, with variants and
    with the general program alone (stats variant_*_waste, *_waste_off)."""
    vt, tx, _ = tile_grid(build)
    w, h = build.frame.size
    pixels = Pass("variant pixels", "variant_classify.comp", reads=("lights", "cell_features"),
                  writes={"pixel_features": Buffer(4 * w * h)}, groups=image_groups(w, h),
                  defines={"VARIANT_TILE": vt, "PIXEL_FEATURES": 1, "PIXEL_SHADES": _SHADES_GLSL},
                  uniforms=grid_uniforms(build.grid), timed=False, figures=True)
    step = HostStep("variant figures", ("pixel_features", "tile_masks"),
                    lambda got: waste_stats(build, got["pixel_features"], got["tile_masks"], own),
                    figures=True)
    return [pixels, step]


def pixel_tiles(size: tuple[int, int], vt: int) -> np.ndarray:
    """(H, W) the variant tile of each pixel, GL row order."""
    w, h = size
    y, x = np.divmod(np.arange(w * h, dtype=np.int64), w)
    return ((y // vt) * -(-w // vt) + x // vt).reshape(h, w)


def program_masks(tile_masks: np.ndarray, own: list[int], general: int) -> np.ndarray:
    """Per tile the mask its program compiled: its own, or the general program's."""
    table = np.full(feat.MASKS, general, np.int64)
    table[np.asarray(own, np.int64)] = own
    return table[np.asarray(tile_masks, np.int64)]


def waste_stats(build, pixel_bits, tile_masks, own: list[int]):
    """variant_specular_waste(_off), variant_shape_waste(_off): shares of shading pixels."""
    vt, *_ = tile_grid(build)
    bits = np.asarray(pixel_bits, np.uint32).reshape(build.frame.size[1], -1).astype(np.int64)
    shades = (bits & int(PIXEL_SHADES)) != 0
    general = general_mask(build)
    prog = program_masks(tile_masks, own, general)[pixel_tiles(build.frame.size, vt)]
    n = max(int(shades.sum()), 1)
    spec = feat.FEATURE_BITS[feat.SPECULAR]
    for suffix, p in (("", prog), ("_off", np.full_like(prog, general))):
        extra = p & ~bits
        build.stats[f"variant_specular_waste{suffix}"] = float((shades & (extra & spec != 0)).sum() / n)
        build.stats[f"variant_shape_waste{suffix}"] = float(
            (shades & (extra & feat.SHAPE_MASK != 0)).sum() / n)
    return {}, []


# ---- the wave model's figures of the variant passes (app.model.predict) -------------------

def cull_figures(frame, width: int, scans: np.ndarray | None) -> dict:
    """{pass: waves.Figures} of the classification passes, counted from the frame: `scans`
    the iterations of each cell's scan (variant_cells.comp, SCAN_BUDGET-clipped); None: a
    CELL_PRECOMPUTED technique, no variant_cells pass (its own pass counts the words)."""
    b = frame.build
    vt, tx, ty = tile_grid(b)
    tiles, cells = tx * ty, b.grid.cells
    line = lambda issued, nbytes: issued * width * nbytes // waves.LINE
    w, h = frame.size
    pix_waves = -(-w // WAVE_DIM) * -(-h // WAVE_DIM) * (64 // width)
    px = int(frame.shading.sum())
    classify = (pix_waves, px, 2 * pix_waves, line(pix_waves, 20))
    compact = (-(-tiles // width), tiles, -(-tiles // width), line(-(-tiles // width), 4))
    out = {
        "variant_classify": waves.analytic(width, pix_waves, {"depth": classify},
                                           {"g_position": px * 16, "cell_features": cells * 4},
                                           barriers=2 * pix_waves, shared_atomics=px,
                                           atomics=-(-w // WAVE_DIM) * -(-h // WAVE_DIM)),
        "variant_compact": waves.analytic(width, -(-tiles // width), {"load": compact},
                                          {"tile_masks": tiles * 4}, atomics=tiles),
    }
    if scans is not None:
        scans = np.minimum(np.asarray(scans, np.int64), SCAN_BUDGET)
        # a wave of `width` cells issues its longest scan; its lanes run their own
        issued = int(np.maximum.reduceat(scans, np.arange(0, cells, width)).sum()) if cells else 0
        scan = (issued, int(scans.sum()), issued, line(issued, 8))
        out["variant_cells"] = waves.analytic(width, -(-cells // width), {"load": scan},
                                              {"ranges": cells * 8, "cell_features": cells * 4})
    return out


def figures_if_on(frame, width: int, scans: Callable | None, passes: dict) -> dict:
    """A technique's cull figures `passes`, plus the variant passes' when its option is on
    (`scans(frame)`: each cell's scan length; None: CELL_PRECOMPUTED)."""
    if on(frame.build, frame.opts):
        passes = dict(passes, **cull_figures(frame, width, scans and scans(frame)))
    return passes


def list_scans(frame, count_mask: int = 0xFFFFFFFF) -> np.ndarray:
    """Each cell's scan length over CSR lists (ranges' counts; overflow: none scanned)."""
    rng = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
    count = rng[:, 1] & count_mask
    return np.where(count > SCAN_BUDGET, 0, count)


def node_scans(frame, count_mask: int = 0x7FFFFFFF) -> np.ndarray:
    """Each hybrid cell's scan: its nodes, then each leaf's entries (a scan past the budget
    stops at its nodes)."""
    rng = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
    first, count = rng[:, 0], rng[:, 1] & count_mask
    nodes = np.ascontiguousarray(frame.read("nodes")).view(layouts.TREE_NODE)   # the frame's, CPU- or GPU-built
    bits = nodes["bits"].astype(np.int64)
    leaf = np.where(bits & 1, (bits >> 1) & ((1 << limits.NODE_COUNT_BITS) - 1), 0)
    csum = np.concatenate([[0], np.cumsum(leaf)])
    entries = csum[np.minimum(first + count, len(leaf))] - csum[np.minimum(first, len(leaf))]
    return np.where(count > SCAN_BUDGET, count, count + entries)


def bit_scans(frame, buffer: str, words: int) -> np.ndarray:
    """Each tile's scan over its bit-array words: the words and their set bits."""
    bits = np.asarray(frame.read(buffer), np.uint32)[:frame.build.grid.cells * words]
    set_bits = np.unpackbits(bits.view(np.uint8)).reshape(-1, words * 32).sum(1)
    return words + set_bits
