"""zbin (Drobot 2017, "Improved Culling for Tiled and Clustered Rendering"): Z-binning and
flat bit arrays, with the slides' scalarized loop (cpu_prep.zbin, glsl/shade_zbin.comp).

    lights[] sorted by view depth: light N = bit N = LUT id N
    zbins[int(depth * bins / max_depth)] = MIN_ID | MAX_ID << 16      (8096 x 4 B = 32,384 B)
    tile_bits[(ty * tiles_x + tx) * words + N / 32], bit N % 32       (tiles x words x 4 B)

        Z bins (uniform over [0, max depth])        screen tiles (8 px, doubled to the budget)
        +-----+-----------+                         +--------+--------+--------+
        | bin | min | max |  pixel depth -> bin     | tile 0 | tile 1 | ...    |
        |  5  |  3  |  5  |  -> lights 3..5         +--------+--------+--------+
        |  4  |  1  |  2  |                         tile 1: word 0 = 0b0010_1000 -> lights 3, 5
        |  2  | MAX |  0  |  empty: loop runs 0 x   words 1.. (one per 32 lights)
        +-----+-----+-----+
        wave: [min of mins, max of maxes] -> word range; per lane word & its z-bin mask
              -> waveAllBitOr -> one scalar loop over the merged bits -> evaluate_light

    1920x1080, 256 lights, 8 px tiles: 240 x 135 x 8 words x 4 B = 1,036,800 B of bit arrays
    (the slides' memory table: 1,036 KB + 32 KB of z-bins)

    tile_depth (GPU, timed): per tile its pixels' min / max depth; each set bit kept where
    light_depth[N] = (lo, hi) meets it -> zbin_bits, which shading reads instead

The four rows of the slides' "F+ Renderer: Optimization Performance" table are the option
`zbin_variant`: 0 base tile, 1 tile + zbin, 2 scalarized tile, 3 scalarized tile + zbin.
The CPU builds each tile's bits from the lights' conservative screen rectangles; the slides'
tiles were rasterized light proxies tested against the depth buffer, so by default
(`tile_depth`) a GPU pass culls them against each tile's min / max scene depth before
shading (app/techniques/zbin/zbin_tile_depth.comp -> zbin_bits), as tiled's tile_cull does: without it the
base tile holds every light in front of or behind the tile's surfaces, and "z-binning saves
44%" would measure the missing depth test, not the slides' 9-15%.  Where the project
departs from the slides, and why:
  * past 65,536 visible lights the 16-bit LUT ids cannot hold every light: the LUT takes
    2 x 32-bit entries instead (ZBIN_WIDE, twice the LUT bytes), never wrapped ids;
  * the bit arrays have a memory budget: their tile doubles until tiles x words fit it
    (Unity URP Forward+); the tile used is in the meta stats (`bit_tile_used`);
  * dispatch windows on a driver with a loop limit: window k takes lights [16384 k,
    16384 (k + 1)), i.e. words [512 k, 512 (k + 1)), so one dispatch loops at most 512 words
    and 16,384 bits;
  * the listing's per-lane Z-bin mask, as printed, clamps the start into the word but keeps
    the width of the whole range: it lets through bit 31 of every word before the bin's range,
    the tail of its last word and, once the range spans 32 ids or more, whole words (the first
    word's head too) (exact, but city at 8,192 lights evaluates 32 lights a pixel instead of
    5.3 in tile + zbin, on the CPU's tiles).  The default masks exactly the ids min..max with
    the same BitFieldMask and 32-wide wrap; `printed_mask` runs the listing as printed;
  * the emulated wave skips the listing's WaveReadFirstLane on reductions that are already
    group-uniform, and ORs up to 32 words per round of barriers (wave.glsl groupOrWords*):
    the same merged words, 1/32 of the barriers.  The native path runs the listing word by
    word.  A scalarized lane evaluates every light of its wave's merged words, so per-pixel
    `evaluated` depends on the wave width (native subgroup or 8x8 group); counts, hashes and
    images do not.

Counters (per 8x8 group, WAVE_STATS): `iterations` = the wave's light loop (scalarized: the
merged loop; per lane: the longest lane), `lane_loops[0]` = the sum over lanes of each lane's
own bits (what the per-lane loop iterates), `lane_loops[1]` = the longest lane's own bits (with
several dispatch windows: its longest window).  Their frame sums are in the meta stats
(wave_iterations, lane_iterations, lane_max_iterations, waves_active), read back by an
untimed host step after the shading pass.  The loop's options, its passes and its replay
are app/techniques/bit_arrays.py's, shared with raster's tile mode.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, limits, zbin as zb

from ...errors import UserError
from ...pipeline.passes import Buffer, HostStep, Pass
from ..base import TRANSPARENT_REBUILT, Technique, prepare
from ..bit_arrays import VARIANTS, ShadingOptions, attach_zbins, shading_steps, tile_bit_maps, variant_flags
from ..blocks import tile_boxes
from ..gpu_build import BuildOptions, build_bits, on_gpu
from ..options import CapOptions, FeatureVariantOptions, StochasticOptions, option
from .. import variants

DEPTH_GROUP = 64              # zbin_tile_depth.comp: one 8x8 group a tile


class ZBin(Technique, register_at=60):
    name = "zbin"
    transparent = TRANSPARENT_REBUILT.format(what="its tile bits (culled against each tile's depth with --tile-depth) are")
    summary = "flat bit arrays per tile + Z-bin LUT, scalarized loop (Drobot 2017)"
    # Scalarized variants evaluate the union of the wave's lights: per-pixel `evaluated`
    # depends on the wave width (native subgroup or emulated 64-lane group); counts, hashes
    # and images do not.
    evaluates_per_wave = True
    # the window's views (app.views): the common ones and the bit arrays' tile grid
    views = Technique.views + ("tiles", "maps", "variants")

    @dataclass(frozen=True)
    class Options(ShadingOptions, CapOptions, StochasticOptions, BuildOptions, FeatureVariantOptions):
        tile_depth: bool = option(True, "cull each tile's bits against its min / max scene depth on "
                                        "the GPU (the slides' tiles are depth tested); off: the "
                                        "CPU's screen rectangles alone", study=(True, False))

    def refusal(self, frame, opts, visible):
        """The light rows, the bit arrays' tile (zb.choose_tile refuses arrays past the
        storage block even in one screen-sized tile) and the tile depth test's loops, in the
        order either build meets them."""
        rows = super().refusal(frame, opts, visible)
        if rows:
            return rows
        try:
            tile = zb.choose_tile(*frame.size, visible, opts.bit_tile, opts.budget_bytes)
        except limits.LimitError as exc:
            return str(exc)
        return depth_loops_refusal(frame, tile, visible) if opts.tile_depth else None

    def build(self, frame, opts):
        opts = self.resolve_options(opts)
        if on_gpu(opts):
            return build_bits(frame, opts, lambda b: self.passes(b, opts), check_depth_loops)
        b = prepare(frame, opts=opts)
        masked, _ = variant_flags(opts.zbin_variant)
        n = len(b.lights)
        w, h = frame.size
        tile = zb.choose_tile(w, h, n, opts.bit_tile, opts.budget_bytes)
        b.grid = gridmod.make_grid(frame.camera, tile, 1, frame.max_depth,
                                   limits.DEFAULT_NEAR_SLICE_DEPTH)
        g = b.grid
        if masked:
            attach_zbins(b, opts.zbins, frame.max_depth)
        with b.times.stage("bin"):
            boxes = tile_boxes(b.lights, g, frame.arena)
        with b.times.stage("build"):
            bits = zb.tile_bits(boxes, g.tiles_x, g.tiles_y, n, frame.arena)
        cpuframe.check_buffer("zbin tile bit arrays", bits.nbytes)
        b.buffers["tile_bits"] = bits
        if opts.tile_depth:
            check_depth_loops(frame, tile, n)
            b.buffers["light_depth"] = np.column_stack([b.lights.depth_lo, b.lights.depth_hi]).astype(np.float32)
        wide = zb.is_wide(n)
        b.stats.update(
            variant=opts.choice_name("zbin_variant"), bit_tile_used=tile, tiles=g.tiles_x * g.tiles_y,
            words_per_tile=zb.words_for(n), bits_bytes=int(bits.nbytes),
            zbins=opts.zbins if masked else 0,
            zbin_bytes=int(b.buffers["zbins"].nbytes) if masked else 0,
            zbin_id_bits=32 if wide else zb.ZBIN_ID_BITS)
        return b

    # the variant study's rows of every technique (raster's rasterized tiles beside these)
    report_studies = ("zbin_variant",)

    def maps(self, result, read):
        """Lights in each tile's bit array (the CPU's, and after the depth test when it runs),
        and in each pixel's z-bin range (the slides' two culling structures, before their
        intersection)."""
        b = result.build
        out = tile_bit_maps(b.buffers["tile_bits"], b.grid, result.depth,
                            b.buffers.get("zbins"), b.bin_scale)
        if "light_depth" in b.buffers:
            m = tile_bit_maps(read("zbin_bits"), b.grid)["tile_lights"][0]
            out["tile_lights_depth"] = (m, "lights / tile after the depth test")
        return out

    def passes(self, build, opts):
        opts = self.resolve_options(opts)
        depth = []
        if opts.tile_depth:
            g, words = build.grid, zb.words_for(len(build.lights))
            depth = [Pass("zbin tile depth", "zbin_tile_depth.comp", reads=("tile_bits", "light_depth"),
                          writes={"zbin_bits": Buffer(max(g.tiles_x * g.tiles_y * words, 1) * 4)},
                          groups=(g.tiles_x, g.tiles_y, 1),
                          uniforms={"u_tile": g.tile, "u_words": words}),
                     HostStep("depth counts", ("tile_bits", "zbin_bits"),
                              lambda got: _depth_counts(build, got), figures=True)]
        bits = _shaded_bits(opts)
        cells = variants.CellSource(variants.CELL_BITS, ("tile_bits",), sources={"tile_bits": bits},
                                    uniforms={"u_words": zb.words_for(len(build.lights))})
        return variants.with_variants(build, opts, depth + shading_steps(build, opts, bits), cells)

    @staticmethod
    def _bit_scans(frame):
        """variant_cells.comp's scan of each tile's bits (the ones shading reads)."""
        bits = _shaded_bits(frame.opts)
        return variants.bit_scans(frame, bits, zb.words_for(len(frame.build.lights)))


def _shaded_bits(opts) -> str:
    """The bit arrays shading reads: the depth-tested ones, or the rectangles' own."""
    return "zbin_bits" if opts.tile_depth else "tile_bits"


def depth_loops_refusal(frame, tile: int, lights: int) -> str | None:
    """zbin_tile_depth.comp's loops on a driver with a loop limit: a lane's pixels of the
    tile and its words' bits must stay under the budget (refused in one line, never cut)."""
    iters = (-(-tile // 8)) ** 2 + -(-zb.words_for(lights) // DEPTH_GROUP) * 33
    if frame.loop_budget and iters > frame.loop_budget:
        return (f"zbin: the tile depth test of {lights} lights on {tile}-px tiles needs "
                f"{iters} loop iterations a lane, over this driver's {frame.loop_budget}; "
                f"use --no-tile-depth or fewer lights")
    return None


def check_depth_loops(frame, tile: int, lights: int) -> None:
    why = depth_loops_refusal(frame, tile, lights)
    if why:
        raise UserError(why)


def _depth_counts(build, got):
    """Meta stats of the depth test (untimed): bits before and after it."""
    count = lambda a: int(np.unpackbits(np.ascontiguousarray(a).view(np.uint8)).sum())
    rect, kept = count(got["tile_bits"]), count(got["zbin_bits"])
    build.stats.update(rect_bits=rect, depth_bits=kept,
                       depth_kept_share=round(kept / rect, 4) if rect else 1.0)
    return {}, []


# ---- the slides' figures beside this run's (app/report/notes.py) ------------------------


