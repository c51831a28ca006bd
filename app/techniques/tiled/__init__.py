"""tiled (Andersson 2009, Harada 2012): 2D screen tiles whose min/max depth is reduced on the
GPU from the G-buffer; lights culled per tile on the GPU (app/techniques/tiled/tile_cull.comp).

    tile_cull:  G-buffer depth + bounds[] -> ranges[tile] = (pool offset, count) -> entries[]
    shade:      entries -> lights[];  count 0xFFFFFFFF = pool overflow, shade every light
    pool: min(tiles x lights, 8M) entries (32 MiB at most)
"""
from dataclasses import dataclass


from cpu_prep import layouts

from ...pipeline.passes import Buffer, Pass
from ..base import TRANSPARENT_REBUILT, Technique, grid_uniforms, make_grid, prepare, refuse, shading_passes
from ..options import CapOptions, FeatureVariantOptions, StochasticOptions, TileOptions
from .. import variants

OVERFLOW = 0xFFFFFFFF          # a tile's count when its list did not fit the pool

POOL_MAX_ENTRIES = 8 << 20


def pool_entries(b) -> int:
    return max(1, min(b.grid.cells * max(len(b.lights.gpu), 1), POOL_MAX_ENTRIES))


class Tiled(Technique, register_at=20):
    name = "tiled"
    transparent = TRANSPARENT_REBUILT.format(what="its tiles' light lists are")
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


