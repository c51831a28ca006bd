"""tiled (Andersson 2009, Harada 2012): 2D screen tiles whose min/max depth is reduced on the
GPU from the G-buffer; lights culled per tile on the GPU (glsl/tile_cull.comp).

    tile_cull:  G-buffer depth + bounds[] -> ranges[tile] = (pool offset, count) -> entries[]
    shade:      entries -> lights[];  count 0xFFFFFFFF = pool overflow, shade every light
    pool: min(tiles x lights, 8M) entries (32 MiB at most)
"""
from cpu_prep import grid as gridmod

from .base import PrePass, Technique, grid_uniforms, prepare

CULL_TILE = 16
POOL_MAX_ENTRIES = 8 << 20


def _pool_entries(b) -> int:
    return max(1, min(b.grid.cells * max(len(b.lights.gpu), 1), POOL_MAX_ENTRIES))


class Tiled(Technique):
    name = "tiled"
    summary = "2D tiles, min/max depth and light lists on the GPU (Andersson, Harada)"
    shader = "shade_tiled.comp"
    prepasses = (PrePass(
        name="tile_cull", shader="tile_cull.comp",
        groups=lambda b: (b.grid.tiles_x, b.grid.tiles_y, 1),
        outputs=lambda b: {"ranges": b.grid.cells * 8, "entries": _pool_entries(b) * 4, "counter": 4},
        zeroed=("counter",)),)

    def build(self, frame, opts):
        b = prepare(frame, opts)
        cam = frame.camera
        b.grid = gridmod.make_grid(cam, opts.tile, 1, frame.max_depth, opts.near_slice_depth)
        b.uniforms.update(grid_uniforms(b.grid))
        b.uniforms.update(u_capacity=_pool_entries(b), u_tan_half=(cam.tan_half_x, cam.tan_half_y))
        b.defines["LIGHTS_DUPLICATED"] = 0
        b.stats["cells"] = b.grid.cells
        return b
