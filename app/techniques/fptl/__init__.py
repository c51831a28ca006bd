"""fptl (Mikkelsen, GPU Pro 7, "Fine Pruned Tiled Light Lists"): per 16x16 tile a coarse list
of the lights whose screen-space AABB meets the tile, fine-pruned on the GPU by testing every
pixel of the tile against each light's true shape, packed as R10G10B10A2 blocks.

    CPU    prepare (cull, depth sort, pack)  ->  fptl_order: the lights sorted by shape class
           (sphere/capsule, cone, box), as the chapter's step 1(b): point, capsule, spot, box,
           depth order within a shape
    light_aabb   fptl_aabb.comp   per light, in class order: the tight screen AABB + depth
                                  range (step 1(c)) -> fptl_aabbs[k]        (32 B a light)
    fptl_lists   fptl_lists.comp  per 16x16 tile one 64-invocation group (step 2):
                                  (a) min/max depth, (b-c) coarse AABB test in class order,
                                  64 lights at a time in shared memory, (d) fine pruning: each
                                  invocation tests its 2x2 pixels with evaluate_light's own
                                  decision, a 64-bit mask per invocation, (e) OR-reduced; the
                                  survivors appended in order
                                  -> fptl_lists[cell]  (8 blocks: 3 x 10-bit index + 2-bit
                                     count; the length, spill and pool-full state in band)
                                  -> fptl_cells[cell]  (coarse, pruned, flags: statistics)
                                  -> fptl_spill_heads / fptl_spill (lists past 24)
    shade        fptl_shade.comp  the pixel's cell list as stored: its eight words, the
                                  length from their 2-bit counts (+ the spill, where the
                                  counts flag one), the chapter's fixed sequence of per-type
                                  loops -> evaluate_light_as
    counts       (host step)      per-tile coarse / pruned counts, the bytes shading read
                                  -> meta stats, FptlData.tile_counts

Variants (`fptl_variant`, bit flags like zbin's): 0 fine-pruned per tile (the chapter),
1 coarse only (what pruning buys: the chapter's 5.4 ms -> 1.4 ms lighting), 2 fine-pruned
per 2.5D cell (16 depth slices, listing 4; the chapter's "negates the need for cells"),
3 coarse per cell (the cell's depth range instead of the pixels' shapes).  `type_loops`
(on by default) shades with the chapter's per-type loops; off, one loop whose light code
branches on each light's type: what the sort by shape buys.

Feature variants (`--feature-variants`, app/techniques/variants.py): the packed lists with
spill are no CSR scan for variant_cells.comp, so fptl_lists.comp writes each cell's shape
word itself (cell_features, CELL_PRECOMPUTED): the OR of 1 << type over the lights the cell
keeps, spilled ones included, a cap's dropped ones not, every visible light's for a
pool-full cell.  Classification, compaction and the per-mask programs are the shared ones,
on the 16 px tile (each 16x16 tile's pixels read its cells' lists); every fptl_variant, the
per-type loops either way and the per-tile caps take it.

Cap policies (`cap_policy`): the view caps every list technique takes (prepare: the lights
are dropped before any structure), and HDRP FPTL's per-tile caps, hdrp-fptl-24 / -63
(cpu_prep.caps per_tile), which only this build applies: with fine pruning per tile (the
variant HDRP runs), each tile keeps the lowest HDRP sort keys of each category (punctual:
point, spot, box; area: capsule) up to the budget, as lightlistbuild.compute's per-category
clamp.  For it the class order within a shape is the scene id (HDRP's key) instead of the
depth, so that scan order is key order; fptl_lists.comp drops a light past its category's
budget from the cell's mask before it gets a position
                                  -> fptl_category_seen[cell] (lights found per category)
                                  -> fptl_dropped (a bit per light dropped from some tile)
and the stats say capped_lights (lights dropped from some tile), capped_entries (tile list
entries dropped), capped_tiles; the exactness check holds the frame to brute less exactly
the entries the CPU's tile_keep drops (app/tile_caps.py).

Shading reads the lists as the chapter stores them: 32 B a tile at 10-bit indices, the
length the sum of the blocks' 2-bit counts; a list's two other states, spilled and pool
full, are count patterns no plain list has (an empty block 0 before full blocks:
app/techniques/fptl/fptl_common.glsl has the format), so no slot and no index value is given up, and only a
flagged cell reads its spill heads.  The cells' 16-byte records (coarse, pruned, flags) are
written for the statistics, the maps and the next scan window, never read by shading.  Stat
shade_bytes_per_tile: what shading reads per lit tile (list words, spill heads, spill).

Where the lab departs from the chapter, and why (nothing is ever dropped silently):
  * coarse lists past 64: the chapter keeps at most 64 coarse lights in LDS.  Here the
    shared batch holds 64; when it fills it is pruned and emptied and the scan goes on, so a
    tile of any coarse count is exact (flag FPTL_COARSE_OVER, stat coarse_overflow_tiles);
  * pruned lists past 24: the first 24 stay in the tile's 8 blocks, the rest spill to one
    pool (`fptl_spill`, contiguous per cell and scan window, heads in `fptl_spill_heads`).
    The pool is sized by an upper bound from the CPU's conservative rectangles (a pruned
    light affects a pixel of the tile, so its shape rectangle meets the tile; a coarse one
    has an AABB inside its sphere's rectangle); only past SPILL_MAX_ENTRIES can it run
    short, and then the cell is flagged (FPTL_POOL_FULL) and shades every visible light,
    still exact (stats spilled_lights, pool_full_cells, spill_capacity, spill_used).  The
    chapter's engine has no spill (24 is its limit); here a spilled tile reads 8 B of
    heads per scan window and 4 B a spilled light beyond its 32 B;
  * more than 1,024 visible lights (10-bit indices): the lists take a documented wider
    format for that frame: a count word (the length and the state) and 16-bit indices (two
    a word: 13 words = 52 B a cell) up to 65,536 lights, 32-bit (25 words = 100 B) beyond;
    stat index_bits.  Shading reads the count word and the index words the list fills
    (fptl_common.glsl says why a count word and not a sentinel);
  * the chapter's per-type loops run per shape, not per class: its sphere/capsule class is
    one execution path in its engine, here a point's test and a capsule's are different
    code, so the class is sorted point before capsule and each gets its own loop;
  * the AABB pass computes in double precision, with the float32 test's margins
    (cpu_prep.limits) on the convex bound and a pixel margin: conservative for all shapes;
  * on a driver with a loop limit (llvmpipe) list building runs as scan windows of
    SCAN_WINDOW lights carrying each cell's state over (through the records), and shading
    in dispatch windows;
  * the chapter's lighting pulls the tile's list and lights into scalar registers
    (__XB_MakeUniform over 8x8 pixel-shader waves); fptl_shade.comp, a compute pass, does
    not make them wave-uniform (an 8x8 group lies in one 16x16 tile, but nothing in the
    shader says so), so the replay counts the list's words and lights as vector loads.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from cpu_prep import caps, grid as gridmod, limits
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT, LIGHT_TYPES

from ...pipeline.passes import Buffer, HostStep, Pass
from ...errors import UserError
from .. import variants
from ..base import TRANSPARENT_REBUILT, Technique, prepare, shading_passes
# its GPU formats (lists.py), also read as fptl.NAME by its replay and the tests
from .lists import (TILE, COARSE_BATCH, LIST_CAP, INDEX10_MAX, INDEX16_MAX, FLAG_COARSE_OVER,
                    FLAG_SPILLED, FLAG_POOL_FULL, FLAG_COVERED, STATE, SPILLED_COUNTS,
                    POOL_FULL_COUNTS, INDEX_FORMATS, BLOCK_COUNT_SHIFT, COUNT_WORD_LISTED,
                    COUNT_WORD_STATE_SHIFT, format_glsl, index_bits, head_words, list_words,
                    decode_lists, decode_state, state_bytes, shade_bytes, FPTL_AABB, FPTL_CELL,
                    STRUCTS, SPILL_HEAD, CATEGORY_SEEN, structs_glsl)
from ..options import CapOptions, FeatureVariantOptions, StochasticOptions, cap_policy, choice, option

SPILL_MAX_ENTRIES = 8 << 20  # spill pool cap (32 MiB); past it cells shade every light
CELL_SLICES = limits.DEFAULT_SLICES

# fptl_variant's names (bit 0 coarse, bit 1 per cell: variant_flags)
VARIANTS = ("fine per tile", "coarse per tile", "fine per cell", "coarse per cell")

# Shape classes (chapter 2.4: sphere/capsule one execution path, cone/wedge one, box one),
# and the order of fptl_shade.comp's per-type loops, which keeps each class contiguous.
CLASS_OF_TYPE = {LIGHT_POINT: 0, LIGHT_CAPSULE: 0, LIGHT_SPOT: 1, LIGHT_BOX: 2}
LOOP_ORDER = (LIGHT_POINT, LIGHT_CAPSULE, LIGHT_SPOT, LIGHT_BOX)
assert set(CLASS_OF_TYPE) == set(LOOP_ORDER) == set(range(len(LIGHT_TYPES)))
assert [CLASS_OF_TYPE[t] for t in LOOP_ORDER] == sorted(CLASS_OF_TYPE.values())
_CLASS_LUT = np.array([CLASS_OF_TYPE[t] for t in range(len(LIGHT_TYPES))], np.uint8)
_LOOP_RANK = np.array([LOOP_ORDER.index(t) for t in range(len(LIGHT_TYPES))], np.uint8)

# A per-tile cap's scan order must be HDRP's key order within each category: the loop order
# restricted to a category's shapes ascends in HDRP's GPU light type (point, spot, box)
for _group in (caps.HDRP_PUNCTUAL, caps.HDRP_AREA):
    _gpu = [caps.HDRP_CLASS[t][1] for t in LOOP_ORDER if t in _group]
    assert _gpu == sorted(_gpu), "fptl's loop order is not HDRP's key order in a category"


def variant_flags(variant: int) -> tuple[bool, bool]:
    """(fine pruning, per 2.5D cell) of an `fptl_variant`."""
    return not variant & 1, bool(variant & 2)


def class_order(types: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
    """Positions of the (depth-sorted) lights sorted by shape class (step 1(b)), and within
    the sphere/capsule class points first: the shading's loop order; stable.  With `ids`
    (a per-tile cap), by scene id within a shape: HDRP's sort-key order."""
    rank = _LOOP_RANK[np.asarray(types, np.intp)]
    if ids is not None:
        return np.lexsort((np.asarray(ids), rank)).astype(np.uint32)
    return np.argsort(rank, kind="stable").astype(np.uint32)


def tile_cap_uniforms(policy: str) -> dict:
    """fptl_lists.comp's per-tile cap: the budgets of categories 0 and 1 and the light types
    of category 1 (bit t), from the policy's two budget groups."""
    budgets = caps.POLICIES[policy].budgets
    assert len(budgets) == 2 and sorted(t for g, _ in budgets for t in g) == sorted(caps.ALL_TYPES)
    return {"u_tile_cap": (budgets[0][1], budgets[1][1]),
            "u_cap_group_types": sum(1 << int(t) for t in budgets[1][0])}


def spill_bound(counts: np.ndarray) -> int:
    """An upper bound on a frame's spilled entries from the counts per cell (list_bounds)
    of rectangles and depth ranges that hold every light a cell's list can keep: a
    fine-pruned light affects some pixel of the cell, so its conservative shape rectangle
    and depth range meet it; a coarse one's AABB lies in its bounding sphere's rectangle
    and depth range."""
    return int(np.maximum(counts - LIST_CAP, 0).sum())


def sphere_rects(pl, cam) -> np.ndarray:
    """(N, 4) pixel rectangles holding the GPU AABBs (a coarse light's AABB lies in its
    bounding sphere's rectangle, fptl_aabb.comp): the same Mara & McGuire rectangle, at the
    AABB pass's near plane, a pixel wider for the GPU's rounding and its inclusive tile
    edges."""
    from cpu_prep.bounds import screen_rects
    x0, x1, y0, y1 = screen_rects(pl.center, pl.bound_radius, replace(cam, near=cam.near * (1 - 1e-3)))
    return np.column_stack([x0 - 1.0, x1 + 1.0, y0 - 1.0, y1 + 1.0])


def list_bounds(pl, cam, grid: gridmod.Grid, fine: bool) -> np.ndarray:
    """Per cell the lights whose rectangle and depth range, holding a variant's list entries,
    meet it (cpu_prep.grid's rules: pixel p in tile p // tile, depth ranges widened by
    SLICE_DEPTH_REL_MARGIN)."""
    if fine:
        return gridmod.rect_counts(grid, pl.rect, pl.depth_lo, pl.depth_hi)
    depth, r = -pl.center[:, 2], pl.bound_radius
    return gridmod.rect_counts(grid, sphere_rects(pl, cam), (depth - r) * (1 - 1e-5),
                               (depth + r) * (1 + 1e-5))


def scan_windows(frame, n: int) -> list[tuple[int, int]]:
    """Class positions [lo, hi) each list-building dispatch scans: all at once on a driver
    without a loop limit; else SCAN_WINDOW lights a dispatch, so that one invocation's loops
    (two scans of n/64 AABB tests, the pruning of every coarse light and the cells'
    emission per batch) stay far inside the limit."""
    size = limits.DISPATCH_WINDOW // 2
    if frame.loop_budget is None or n <= size:
        return [(0, n)]
    return [(lo, min(lo + size, n)) for lo in range(0, n, size)]


@dataclass(frozen=True)
class FptlData:
    """fptl's own build state (Build.own): the spill pool's entries, the list passes' scan
    windows, whether a per-tile cap applies; tile_counts (read_counts) is set, as a new
    value, by the frame's counts step, which reads the cells after the frame (None: a frame
    rendered without its figures)."""
    spill_capacity: int
    scans: list[tuple[int, int]]
    tile_cap: bool
    tile_counts: dict[str, np.ndarray] | None = None


class Fptl(Technique, register_at=70):
    name = "fptl"
    transparent = TRANSPARENT_REBUILT.format(what="its coarse and fine-pruned tile lists are")
    summary = "16x16 tiles, GPU screen-AABB coarse lists fine-pruned per pixel (Mikkelsen)"
    views = Technique.views + ("tiles", "slices", "maps", "variants")
    glsl = {"fptl_structs.glsl": structs_glsl(), "fptl_format.glsl": format_glsl()}

    @dataclass(frozen=True)
    class Options(CapOptions, StochasticOptions, FeatureVariantOptions):
        fptl_variant: int = choice("fine per tile", VARIANTS, "the lists: fine-pruned or coarse "
                                   "(AABBs only), per 16x16 tile (the chapter) or per 2.5D cell "
                                   "(16 depth slices)", study=True)
        type_loops: bool = option(True, "fptl shading: the chapter's fixed sequence of per-type "
                                        "loops, each compiled for one light shape; off: one loop "
                                        "whose light code branches on the type", study=(True, False),
                                  study_scene="corridor")     # all four shapes mixed
        tile_caps: ClassVar[bool] = True       # the hdrp-fptl-* policies act in this build

        def check_modes(self) -> None:
            super().check_modes()
            policy = cap_policy(self)
            if caps.per_tile(policy) and self.fptl_variant != 0:
                raise UserError(f"--cap-policy {policy} caps the fine-pruned per-tile lists (HDRP "
                                f"FPTL): it takes --fptl-variant \"{VARIANTS[0]}\", not "
                                f"\"{VARIANTS[self.fptl_variant]}\"")

    def build(self, frame, opts):
        opts = self.resolve_options(opts)
        fine, cells = variant_flags(opts.fptl_variant)
        b = prepare(frame, opts=opts)
        b.buffers["bounds"] = b.lights.bounds
        n = len(b.lights)
        b.grid = gridmod.make_grid(frame.camera, TILE, CELL_SLICES if cells else 1,
                                   frame.max_depth, limits.DEFAULT_NEAR_SLICE_DEPTH)
        g = b.grid
        tile_cap = caps.per_tile(cap_policy(opts))
        with b.times.stage("sort"):
            b.buffers["fptl_order"] = class_order(b.lights.type, b.lights.ids if tile_cap else None)
        # spill pool: an upper bound from the CPU's conservative rectangles
        with b.times.stage("bin"):
            need = spill_bound(list_bounds(b.lights, frame.camera, g, fine))
        capacity = int(min(need, SPILL_MAX_ENTRIES))
        bits = index_bits(n)
        classes = np.bincount(_CLASS_LUT[b.lights.type.astype(np.intp)], minlength=3)
        b.own = FptlData(capacity, scan_windows(frame, n), tile_cap)
        b.stats.update(variant=opts.choice_name("fptl_variant"), tile=TILE, slices=g.slices,
                       tiles=g.tiles_x * g.tiles_y, cells=g.cells, index_bits=bits,
                       list_bytes_per_cell=list_words(bits) * 4, spill_capacity=capacity,
                       class_sphere_capsule=int(classes[0]), class_cone=int(classes[1]),
                       class_box=int(classes[2]))
        return b

    def passes(self, build, opts):
        opts = self.resolve_options(opts)
        fine, _ = variant_flags(opts.fptl_variant)
        g, cam, n = build.grid, build.frame.camera, len(build.lights)
        bits = index_bits(n)
        words = list_words(bits)
        scans, capacity, tile_cap = build.own.scans, build.own.spill_capacity, build.own.tile_cap
        common = {"FPTL_SLICES": g.slices, "FPTL_INDEX_BITS": bits}
        cap_writes = {"fptl_category_seen": Buffer(g.cells * CATEGORY_SEEN.itemsize, CATEGORY_SEEN),
                      "fptl_dropped": Buffer(4 * max(1, -(-n // 32)), cleared=True)} if tile_cap else {}
        cap_u = tile_cap_uniforms(cap_policy(opts)) if tile_cap else {}
        # --feature-variants: the list pass writes each cell's shape word (CELL_PRECOMPUTED)
        shapes_on = variants.on(build, opts)
        shape_writes = {"cell_features": Buffer(4 * g.cells)} if shapes_on else {}
        shape_u = {"u_frame_shapes": variants.frame_shape_mask(build)} if shapes_on else {}
        grid_u = {"u_fptl_tiles_x": g.tiles_x, "u_slice_scale": float(g.slice_scale),
                  "u_slice_bias": float(g.slice_bias), "u_cells": g.cells, "u_scans": len(scans)}
        aabb = Pass("light_aabb", "fptl_aabb.comp", reads=("lights", "bounds", "fptl_order"),
                    writes={"fptl_aabbs": Buffer(max(n, 1) * FPTL_AABB.itemsize, FPTL_AABB)},
                    groups=(max(1, -(-n // 64)), 1, 1),
                    defines={"FPTL_REL_MARGIN": repr(float(limits.RADIUS_REL_MARGIN)),
                             "FPTL_PIXEL_MARGIN": repr(float(limits.PIXEL_MARGIN))},
                    uniforms={"u_tan_half": (cam.tan_half_x, cam.tan_half_y),
                              "u_near_far": (cam.near, cam.far)})
        lists = [Pass("fptl_lists", "fptl_lists.comp", reads=("lights", "fptl_aabbs"),
                      writes={"fptl_lists": Buffer(g.cells * words * 4),
                              "fptl_cells": Buffer(g.cells * FPTL_CELL.itemsize, FPTL_CELL),
                              "fptl_spill_heads": Buffer(len(scans) * g.cells * SPILL_HEAD.itemsize,
                                                         SPILL_HEAD),
                              "fptl_spill": Buffer(capacity * 4),
                              "fptl_counter": Buffer(16, cleared=k == 0),
                              **{name: Buffer(buf.nbytes, buf.struct, cleared=buf.cleared and k == 0)
                                 for name, buf in cap_writes.items()}, **shape_writes},
                      groups=(g.tiles_x, g.tiles_y, 1),
                      defines=dict(common, FPTL_PRUNE=int(fine), FPTL_TILE_CAP=int(tile_cap),
                                   FPTL_CELL_SHAPES=int(shapes_on)),
                      uniforms=dict(grid_u, u_scan=(lo, hi), u_scan_index=k,
                                    u_spill_capacity=capacity, u_slices=g.slices, u_two=2,
                                    **cap_u, **shape_u))
                 for k, (lo, hi) in enumerate(scans)]
        if tile_cap:     # not figures only: the frame's cap stats are what the HUD and check read
            lists.append(HostStep("fptl tile cap", tuple(cap_writes),
                                  lambda got: _tile_cap_stats(build, cap_u["u_tile_cap"],
                                                              got["fptl_category_seen"],
                                                              got["fptl_dropped"])))
        # a pixel meets at most every visible light (its list, or every light when flagged);
        # shading reads the lists' words (their state in band), never the cells' records
        # per 2.5D cell, lanes of one vector walk different lists, in one loop per shape and
        # run: their parts add up in the driver's loop budget (base.windows' steps)
        _, per_cell = variant_flags(opts.fptl_variant)
        steps = len(LOOP_ORDER) * (1 + len(scans)) if per_cell else 1
        shade = shading_passes(build, "fptl_shade.comp",
                               ("fptl_lists", "fptl_spill_heads", "fptl_spill"),
                               longest=n, defines=dict(common, FPTL_TYPE_LOOPS=int(opts.type_loops)),
                               uniforms=grid_u, steps=steps)
        counts = HostStep("fptl counts", ("fptl_cells", "fptl_counter", "fptl_lists", "fptl_spill_heads"),
                          lambda got: _counts(build, got["fptl_cells"], got["fptl_counter"],
                                              got["fptl_lists"], got["fptl_spill_heads"]),
                          figures=True)
        return variants.with_variants(build, opts, [aabb] + lists + shade + [counts],
                                      variants.CellSource(variants.CELL_PRECOMPUTED, ()))

    def maps(self, result, read):
        """The chapter's figures 2.4-2.6: lights per tile in the coarse list and after fine
        pruning (per tile: its longest cell's list)."""
        t = result.build.own.tile_counts
        if t is None:                    # a frame rendered without its figures (the window)
            t = read_counts(result.build, read("fptl_cells"))
        return {"coarse": (t["coarse"], "coarse lights / tile"),
                "pruned": (t["pruned"], "pruned lights / tile")}


def _tile_cap_stats(build, tile_cap, seen: np.ndarray, dropped: np.ndarray):
    """A per-tile cap's stats from what fptl_lists.comp counted: capped_lights (lights dropped
    from some tile; their scene ids in Build.capped_ids), capped_entries (tile list entries
    dropped), capped_tiles (tiles that dropped one)."""
    cap = np.array(tile_cap, np.int64)          # (punctual, area): the lists' u_tile_cap
    over = np.maximum(np.asarray(seen).reshape(-1, 2).astype(np.int64) - cap, 0)
    bits = np.unpackbits(np.asarray(dropped, np.uint32).view(np.uint8), bitorder="little")
    ids = np.sort(build.lights.ids[np.nonzero(bits[:len(build.lights)])[0]]).astype(np.uint32)
    build.capped_ids = ids
    build.stats.update(capped_lights=len(ids), capped_entries=int(over.sum()),
                       capped_tiles=int((over.sum(1) > 0).sum()))
    return {}, []


def read_counts(build, cells: np.ndarray) -> dict[str, np.ndarray]:
    """Per-tile figures in image order (row 0 = top), for heat maps (figures 2.4-2.6):
    coarse (tiles_y, tiles_x), pruned per cell (tiles_y, tiles_x, slices), pruned per tile
    (the longest list of its cells: what a pixel there may loop over), flags per cell."""
    g = build.grid
    c = np.asarray(cells).view(FPTL_CELL).reshape(g.tiles_y, g.tiles_x, g.slices)[::-1]
    return {"coarse": c["coarse"][..., 0].astype(np.int64),
            "pruned_cells": c["pruned"].astype(np.int64),
            "pruned": c["pruned"].max(2).astype(np.int64),
            "flags": c["flags"].copy()}


def _counts(build, cells: np.ndarray, counter: np.ndarray, words: np.ndarray, heads: np.ndarray):
    """Meta stats from the cells' records and, for the bytes shading reads, from what
    shading reads: the lists' words and spill heads (untimed, after the frame)."""
    t = read_counts(build, cells)
    build.own = replace(build.own, tile_counts=t)
    pruned, flags, coarse = t["pruned_cells"], t["flags"], t["coarse"]
    full = (flags & FLAG_POOL_FULL) != 0
    lit = coarse > 0
    build.stats.update(
        coarse_entries=int(coarse.sum()), pruned_entries=int(pruned.sum()),
        listed_entries=int(np.minimum(pruned, LIST_CAP).sum()),
        spilled_lights=int(np.maximum(pruned - LIST_CAP, 0)[~full].sum()),
        max_coarse=int(coarse.max(initial=0)), max_pruned=int(pruned.max(initial=0)),
        coarse_per_tile=float(coarse[lit].mean()) if lit.any() else 0.0,
        pruned_per_tile=float(t["pruned"][lit].mean()) if lit.any() else 0.0,
        coarse_overflow_tiles=int((coarse > COARSE_BATCH).sum()),
        pruned_overflow_cells=int((pruned > LIST_CAP).sum()),
        pool_full_cells=int(full.sum()),
        spill_used=int(min(int(counter[0]), build.own.spill_capacity)))
    # bytes shading reads per tile: every cell some pixel reads (each pixel of a cell reads
    # the same), summed per tile, over the lit tiles (coarse > 0, as the per-tile counts)
    g = build.grid
    lst, spill = shade_bytes(words, heads, build.stats["index_bits"])
    covered = (np.asarray(cells).view(FPTL_CELL)["flags"] & FLAG_COVERED) != 0
    per_tile = lambda v: np.where(covered, v, 0).reshape(g.tiles_y, g.tiles_x, g.slices).sum(2)[::-1]
    lst_t, spill_t = per_tile(lst), per_tile(spill)
    mean = lambda v: float(v[lit].mean()) if lit.any() else 0.0
    build.stats.update(shade_bytes_per_tile=mean(lst_t + spill_t), shade_list_bytes_per_tile=mean(lst_t),
                       shade_spill_bytes_per_tile=mean(spill_t),
                       shade_bytes_max_tile=int((lst_t + spill_t).max(initial=0)))
    return {}, []
