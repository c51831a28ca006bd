"""raster: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts, raster_proxies as rp

from ...pipeline.passes import image_groups
from ..bit_arrays import add_bit_words, variant_flags
from . import CLUSTER_BOUNDED


def cull_figures(technique, frame, width):
    """The depth fill (a fragment a pixel; tile mode), the tile depth pass (cluster
    mode with its depth bound: an 8x8 group of lanes a block, a texel each, reduced in
    shared memory when the tile is a multiple of 8) and the proxy draws: their
    vertices, and the fragments and atomics the untimed stats twin counted."""
    from ...model import waves
    b = frame.build
    w, h = frame.size
    frags = int(b.stats.get("raster_fragments", 0))
    atomics = int(b.stats.get("raster_atomics", 0))
    verts = 3 * int(b.stats.get("proxy_triangles", 0))
    up = lambda k: -(-k // width)
    out = {}
    tiles_bytes = b.grid.tiles_x * b.grid.tiles_y * 8
    if not frame.opts.cluster:
        out["raster fill"] = waves.analytic(
            width, up(w * h), {"fragment": (up(w * h), w * h, up(w * h), up(w * h) * 4)},
            {"g_position": w * h * 16}, graphics=True, fragments=w * h)
    elif frame.opts.cluster == CLUSTER_BOUNDED:
        gx, gy, _ = image_groups(w, h)
        per = 64 // width
        launched = gx * gy * per
        covered = int(frame.shading.sum())
        grouped = b.grid.tile % 8 == 0
        x, y = frame.pixel_xy
        sel = frame.shading
        busy = len(np.unique((y[sel] // 8) * gx + x[sel] // 8))    # groups with geometry
        out["raster tile depth"] = waves.analytic(
            width, launched, {"depth": (launched, w * h, launched, launched * width * 16 // waves.LINE)},
            {"g_position": w * h * 16, "raster_depth_bounds": tiles_bytes},
            barriers=2 * gx * gy if grouped else 0,
            shared_atomics=2 * covered if grouped else 0,
            atomics=2 * busy if grouped else 2 * covered)
    bounds = {"raster_depth_bounds": tiles_bytes} if frame.opts.cluster == CLUSTER_BOUNDED else {}
    out["raster proxies"] = waves.analytic(
        width, up(verts) + up(frags),
        {"vertex": (up(verts), verts, 2 * up(verts), 2 * up(verts) * 2),
         "fragment": (up(frags), frags, up(frags), atomics)},
        {"lights": len(b.lights) * layouts.GPU_LIGHT.itemsize, "raster_proxies": len(b.lights) * rp.RASTER_PROXY.itemsize,
         "raster_bits": int(b.stats.get("bits_bytes", 0)), **bounds},
        graphics=True, fragments=frags, atomics=atomics,
        stands_for=r"raster \w+ (front|back|mark|walk|inside)")
    return out


def wave_program(technique, frame, width):
    """zbin's loop over the rasterized bits, or the per-cluster loop (cluster mode)."""
    from ...model import waves
    opts = frame.opts
    masked, scalarized = variant_flags(opts.zbin_variant)
    prog = waves.Program(frame, width)
    if opts.cluster:
        add_bit_words(prog, "raster_bits", frame.build.grid, False, False, False, cluster=True)
    else:
        add_bit_words(prog, "raster_bits", frame.build.grid, masked, scalarized, opts.printed_mask)
    return prog
