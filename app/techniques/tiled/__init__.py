"""tiled (Andersson 2009, Harada 2012): 2D screen tiles whose min/max depth is reduced on the
GPU from the G-buffer; lights culled per tile on the GPU (glsl/tile_cull.comp).

    tile_cull:  G-buffer depth + bounds[] -> ranges[tile] = (pool offset, count) -> entries[]
    shade:      entries -> lights[];  count 0xFFFFFFFF = pool overflow, shade every light
    pool: min(tiles x lights, 8M) entries (32 MiB at most)
"""
from dataclasses import dataclass

import numpy as np

from cpu_prep import layouts

from ...model import waves
from ...pipeline.passes import Buffer, Pass
from ..base import (Technique, add_all_lights, add_cell_lists, cell_head, grid_uniforms, make_grid,
                   prepare, refuse, shading_passes)
from ..options import CapOptions, FeatureVariantOptions, StochasticOptions, TileOptions
from .. import variants

OVERFLOW = 0xFFFFFFFF          # a tile's count when its list did not fit the pool

POOL_MAX_ENTRIES = 8 << 20


def pool_entries(b) -> int:
    return max(1, min(b.grid.cells * max(len(b.lights.gpu), 1), POOL_MAX_ENTRIES))


class Tiled(Technique, register_at=20):
    name = "tiled"
    summary = "2D tiles, min/max depth and light lists on the GPU (Andersson, Harada)"
    views = Technique.views + ("tiles", "variants")
    glsl = {"tiled_lists.glsl": layouts.glsl_defines({"TILE_OVERFLOW": OVERFLOW})}

    @dataclass(frozen=True)
    class Options(TileOptions, CapOptions, StochasticOptions, FeatureVariantOptions):
        pass

    def refusal(self, frame, opts, visible):
        """The light rows, and tile_cull.comp's loops: each invocation loops over n / 256
        lights twice, 9 iterations a chunk in the second loop."""
        rows = super().refusal(frame, opts, visible)
        if rows or not (frame.loop_budget and (visible + 255) // 256 * 10 > frame.loop_budget):
            return rows
        return (f"tiled: culling {visible} visible lights needs more loop iterations per "
                f"invocation than this driver runs ({frame.loop_budget}); its lists would "
                f"be truncated: use fewer lights or a GPU driver")

    def build(self, frame, opts):
        b = prepare(frame, opts=opts)
        b.buffers["bounds"] = b.lights.bounds
        b.grid = make_grid(frame, opts, 1)
        b.stats["cells"] = b.grid.cells
        return b

    def passes(self, build, opts):
        g, cam = build.grid, build.frame.camera
        n = len(build.lights)
        refuse(self, build.frame, opts, n)
        cull = Pass(
            "tile_cull", "tile_cull.comp", reads=("bounds",),
            writes={"ranges": Buffer(g.cells * layouts.CELL_RANGE.itemsize, layouts.CELL_RANGE),
                    "entries": Buffer(pool_entries(build) * 4),
                    "counter": Buffer(4, cleared=True)},
            groups=(g.tiles_x, g.tiles_y, 1),
            uniforms={"u_tile": g.tile, "u_capacity": pool_entries(build),
                      "u_tan_half": (cam.tan_half_x, cam.tan_half_y)})
        # a tile's list holds at most every light (an overflowed tile shades every light)
        shade = shading_passes(build, "shade_tiled.comp", ("ranges", "entries"), n,
                               defines={"LIGHTS_DUPLICATED": 0}, uniforms=grid_uniforms(g))
        return variants.with_variants(build, opts, [cull] + shade,
                                      variants.CellSource(variants.CELL_LISTS, ("ranges", "entries")))

    def cull_figures(self, frame, width):
        """tile_cull.comp: per tile one 16x16 group; the depth reduction, then every light's
        sphere test twice (count, then the ordered fill), 256 lights a round."""
        g, n = frame.build.grid, len(frame.build.lights)
        pixels, covered, *_ = waves.per_tile(frame, g.tile)
        ranges = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
        busy = covered > 0
        filled = busy & (ranges[:, 1] != OVERFLOW)
        hits = int(ranges[filled, 1].sum())
        per = 256 // width                           # waves of a 16x16 group
        texels = (-(-g.tile // 16)) ** 2             # a lane's share of the tile's pixels
        rounds = -(-n // 256)
        line = lambda issued, nbytes: issued * width * nbytes // waves.LINE
        depth = (g.cells * per * texels, pixels.sum(), g.cells * per * texels,
                 line(g.cells * per * texels, 16))
        tests = int(busy.sum() + filled.sum()) * per * rounds
        cull = (tests, int(busy.sum() + filled.sum()) * n, tests, line(tests, 16))
        return variants.figures_if_on(frame, width, variants.list_scans, {"tile_cull": waves.analytic(
            width, g.cells * per, {"depth": depth, "cull_test": cull},
            {"g_position": int(pixels.sum()) * 16, "bounds": n * 16, "entries": hits * 4,
             "ranges": g.cells * 8},
            barriers=g.cells * (3 + 3 * rounds), atomics=int(busy.sum()),
            shared_atomics=2 * int(covered.sum()) + hits)})

    def wave_program(self, frame, width):
        prog = waves.Program(frame, width)
        lanes = np.nonzero(frame.shading)[0]
        ranges = frame.read("ranges").view(layouts.CELL_RANGE)["offset_count"].astype(np.int64)
        over = ranges[frame.cell[lanes], 1] == OVERFLOW
        listed = np.where(ranges[:, 1] == OVERFLOW, 0, ranges.sum(1))
        entries = frame.read("entries")[:int(listed.max(initial=0))]   # the pool's used part
        prog.add(lanes, head=cell_head(prog, lanes))
        add_cell_lists(prog, lanes[~over], ranges, entries, step=1, head=False)
        add_all_lights(prog, lanes[over], step=1, branch=1)     # an overflowed tile's branch
        return prog
