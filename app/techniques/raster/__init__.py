"""raster (Drobot 2017, "Improved Culling for Tiled and Clustered Rendering", rasterization
based culling): every visible light is a proxy mesh (cpu_prep/raster_proxies.py), drawn
instanced against the scene's depth; each fragment that survives the early depth test and
the shader's depth-bounds test ORs its light's bit into the flat bit array of its 8x8 tile
(zbin's layout), and the frame is shaded by zbin's loop (bit_arrays.shading_steps,
any zbin_variant) over those bits.  With `cluster`, the slides' cluster rasterizer marks
clusters instead (MARK / WALK) and a per-cluster loop shades them.  The design, the
slides' variants and why every mode is exact: docs/raster.md.

    raster_proxies[i]   RasterProxy of sorted light i (shape, side, margin, depth span)
    raster_order[]      the lights by (proxy shape, side): one instanced draw a group
    raster_bits         tiles:    [(ty * tiles_x + tx) * words + N / 32] |= 1 << N % 32
                        clusters: [((ty * tiles_x + tx) * slices + s) * words + N / 32]

    tile mode     [stats twin, untimed] fill -> mark (per proxy mesh and side) -> shade_zbin
    cluster mode  [stats twin, untimed] tile depth (cluster 1) -> mark -> walk -> inside
                  -> raster_shade_cluster
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, layouts, limits, raster_proxies as rp, zbin as zb

from ...pipeline.gbuffer import column_major
from ...pipeline.passes import Buffer, Draw, HostStep, Pass, StencilStep, Target, image_groups
from ..base import Technique, grid_uniforms, prepare, shading_passes
from ..options import StochasticOptions, choice, option
from ..bit_arrays import (ShadingOptions, add_bit_words, attach_zbins, shading_steps, tile_bit_maps,
                         tile_uniforms, variant_flags)
from ..blocks import tile_boxes

VARIANTS = ("atomic", "atomic + 4xMSAA", "atomic + compaction", "atomic + compaction + 4xMSAA")
MSAA_SAMPLES = 4
CONTENTION_SCENE = "contention"      # scenes/builtin.py: the slides' "3 x full screen lights"

# ---- the GPU side of the depth tests (docs/raster.md, "Depth") ---------------------------
DEPTH_BIAS_REL = 2.0 ** -16  # proxy window depth n / d moved towards passing the hardware
DEPTH_BIAS_ABS = 2.0 ** -20  #   test by this relative and absolute amount
FRONT_TEST, BACK_TEST = "greater_equal", "less_equal"   # reversed depth: window depth n / d
SHADER_SLACK = 1e-5          # relative slack of the shader's depth comparisons

# u_mode of the proxy draws (RASTER_MODE_* in raster_structs.glsl): the tile rasterizer's
# front faces, back faces, stencil sequence; the cluster rasterizer's MARK, WALK, eye inside
MODES = ("front", "back", "stencil", "mark", "walk", "inside")
MODE = {name: i for i, name in enumerate(MODES)}
CLUSTER_BOUNDED = 1             # `cluster`: 1 MARK / WALK within each tile's scene depth, 2 not
CLUSTER_NAMES = ("tiles", "clusters", "clusters, no depth bound")
# the options cluster mode does not read: zbin's shading loop's, the tile rasterizer's own
CLUSTER_IGNORES = ("zbin_variant", "zbins", "printed_mask", "native_wave", "bit_tile", "stencil",
                   "early_depth")


def _defines(prefix: str, names) -> list[str]:
    return [f"#define {prefix}{n.upper()} {i}" for i, n in enumerate(names)]


STRUCTS_GLSL = "\n".join(
    [layouts.glsl_struct("RasterProxy", rp.RASTER_PROXY)] + _defines("PROXY_", rp.PROXY_NAMES)
    + _defines("RASTER_MODE_", MODES)
    + [f"#define DEPTH_BIAS_REL {DEPTH_BIAS_REL!r}", f"#define DEPTH_BIAS_ABS {DEPTH_BIAS_ABS!r}",
       f"#define SHADER_SLACK {SHADER_SLACK!r}"]) + "\n"


class Raster(Technique, register_at=80):
    name = "raster"
    summary = "light proxy meshes rasterized into tile bit arrays with atomics (Drobot 2017)"
    evaluates_per_wave = True          # the zbin loop's scalarized variants (zbin.py)
    views = Technique.views + ("tiles", "slices", "maps")   # slices: --cluster
    glsl = {"raster_structs.glsl": STRUCTS_GLSL}

    @dataclass(frozen=True)
    class Options(ShadingOptions, StochasticOptions):          # zbin's shading loop's options (not its tile_depth)
        raster_variant: int = choice("atomic", VARIANTS, "the slides' tile rasterizer table "
                                     "(MSAA at half resolution, compaction over the wave)",
                                     study=True, also_study=(CONTENTION_SCENE,))
        stencil: bool = option(False, "tile rasterizer: two-pass stencil test (front faces, then "
                                      "back faces; pixel-perfect) for proxies the eye is outside of",
                               study=(False, True))
        cluster: int = option(0, "0 tiles + zbin's loop; 1 the slides' cluster rasterizer: back "
                                 "faces MARK, front faces WALK clusters of cluster_tile px x "
                                 "cluster_slices depth slices within each tile's scene depth "
                                 "(the depth prepass), shaded by a per-cluster loop; 2 the same "
                                 "without the depth prepass", lo=0, hi=2, study=(0, 1, 2))
        cluster_tile: int = option(32, "cluster rasterizer: tile in pixels, before the memory "
                                       "budget (bit_budget_mib) doubles it", lo=1, hi=4096)
        cluster_slices: int = option(limits.DEFAULT_SLICES, "cluster rasterizer: depth slices "
                                     "(listing 4, near slice to 5 m)", lo=2, hi=64)
        early_depth: bool = option(True, "the hardware depth test before the shader (off: the "
                                         "shader's exact depth tests alone; same bits, slower)")
        raster_stats: bool = option(True, "count fragments, atomics and per-light marks in an "
                                          "untimed twin of the culling passes (meta stats)")

        def ignored(self) -> dict[str, str]:
            """What the mode does not read (options.py's rule): cluster mode shades with its
            own loop (none of zbin's shading options) and has no depth test, stencil or
            tiles of bit_tile; tile mode has no clusters, and its zbin loop ignores what
            zbin.ShadingOptions.ignored says (the z-bins' count and mask without z-bins, the
            wave ops in the base tile; compaction's wave ops follow raster_variant)."""
            out = dict(super().ignored())          # zbin's shading loop's, the draw's
            if self.cluster:
                mode = f"in cluster mode (--cluster {self.cluster})"
                return dict(out, **dict.fromkeys(CLUSTER_IGNORES, mode))
            out.update(dict.fromkeys(("cluster_tile", "cluster_slices"), "in tile mode (--cluster 0)"))
            return out

    # ---- CPU stage ---------------------------------------------------------------------

    def build(self, frame, opts):
        opts = self.resolve_options(opts)
        b = prepare(frame, opts=opts)
        n = len(b.lights)
        w, h = frame.size
        slices = opts.cluster_slices if opts.cluster else 1
        tile = zb.choose_tile(w, h, n, opts.cluster_tile if opts.cluster else opts.bit_tile,
                              opts.budget_bytes, slices)
        b.grid = gridmod.make_grid(frame.camera, tile, slices, frame.max_depth,
                                   limits.DEFAULT_NEAR_SLICE_DEPTH)
        masked = variant_flags(opts.zbin_variant)[0] and not opts.cluster
        if masked:
            attach_zbins(b, opts.zbins, frame.max_depth)
        positions, quad, dilation = _msaa_samples(frame, bool(opts.raster_variant & 1))
        with b.times.stage("build"):
            proxies = rp.proxy_params(b.lights, frame.camera, dilation)
            key = proxies["shape"].astype(np.int64) * 2 + proxies["back"]
            order = np.argsort(key, kind="stable").astype(np.uint32)
            groups = np.bincount(key, minlength=8)
        bits_bytes = b.grid.cells * zb.words_for(n) * 4
        cpuframe.check_buffer("raster bit arrays", bits_bytes)
        b.buffers["raster_proxies"] = proxies
        b.buffers["raster_order"] = order if n else np.zeros(1, np.uint32)
        b.data.update(groups=groups, quad=quad, sample_pos=positions)
        b.stats.update(_build_stats(b, opts, masked, bits_bytes, dilation, frame.limits))
        return b

    def report_notes(self, rows):
        return _notes(self, rows)

    def maps(self, result, read):
        """Lights whose proxy marked each tile (the rasterized bit arrays; tile mode)."""
        b = result.build
        if b.grid.slices > 1:
            return {}
        m = tile_bit_maps(read("raster_bits"), b.grid)
        return {"raster_lights": (m["tile_lights"][0], "marked lights / tile")}

    # ---- GPU passes ----------------------------------------------------------------------

    def passes(self, build, opts):
        opts = self.resolve_options(opts)
        out = []
        if opts.raster_stats:
            out += [replace(p, figures=True) for p in self._cull_passes(build, opts, stats=True)]
            out.append(HostStep("raster counters", ("raster_counters", "raster_light_tiles",
                                                    "raster_tile_depth"),
                                lambda got: _raster_counters(build, got), figures=True))
        out += self._cull_passes(build, opts, stats=False)
        if opts.cluster:
            g = build.grid
            return out + shading_passes(
                build, "raster_shade_cluster.comp", ("cluster_bits",), longest=len(build.lights),
                uniforms=dict(grid_uniforms(g), u_words=zb.words_for(len(build.lights))),
                sources={"cluster_bits": "raster_bits"})
        return out + shading_steps(build, opts, "raster_bits")

    def cull_figures(self, frame, width):
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

    def wave_program(self, frame, width):
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

    def _cull_passes(self, build, opts, stats: bool) -> list:
        """The fill pass (own depth target) and one mark pass per non-empty (proxy, side)
        group (the cluster rasterizer: MARK passes, then WALK passes); `stats`: the untimed
        twin that counts into its own buffers."""
        g, n = build.grid, len(build.lights)
        w, h = build.frame.size
        cam = build.frame.camera
        msaa = bool(opts.raster_variant & 1)
        compact = bool(opts.raster_variant & 2)
        words = zb.words_for(n)
        bits_name = "raster_stats_bits" if stats else "raster_bits"
        tiles = g.tiles_x * g.tiles_y
        target = Target("raster_depth", scale=2 if msaa else 1, samples=MSAA_SAMPLES if msaa else 0,
                        stencil=opts.stencil)
        suffix = " (stats)" if stats else ""
        lw = -(-w // 2) if msaa else w
        lh = -(-h // 2) if msaa else h
        sx, sy = (w / (2.0 * lw), h / (2.0 * lh)) if msaa else (1.0, 1.0)
        clip = column_major(cam.clip_from_view)
        quad = np.ascontiguousarray(build.data["quad"], np.int32)
        writes = {bits_name: Buffer(max(g.cells * words, 1) * 4, cleared=True)}
        if stats:
            writes["raster_counters"] = Buffer(16, cleared=True)
            writes["raster_light_tiles"] = Buffer(max(n, 1) * 4, cleared=True)
        # raster_proxy.vert's and raster_common.glsl's (the cluster passes add the slices)
        uniforms = dict(tile_uniforms(g), u_clip_from_view=clip, u_near=float(cam.near),
                        u_instance=0, u_step=0, u_ndc=(sx, sy, sx - 1.0, sy - 1.0), u_words=words,
                        u_sample_pixel=quad, u_sample_pos=build.data["sample_pos"])
        # each tile's min / max scene depth: the stats' (tile mode: which unmarked lights a
        # depth-bounds test would keep), the cluster MARK / WALK's bounds (the depth prepass)
        bounded = opts.cluster == CLUSTER_BOUNDED
        depth = "raster_tile_depth" if stats else "raster_depth_bounds"
        out = []
        if stats or bounded:
            out.append(Pass("raster tile depth" + suffix, "raster_tile_depth.comp",
                            writes={"raster_tile_depth": Buffer(max(tiles, 1) * 8, cleared=True)},
                            groups=image_groups(w, h), timed=not stats,
                            defines={"TILE_DEPTH_GROUP": int(g.tile % 8 == 0)},
                            uniforms=tile_uniforms(g), sources={"raster_tile_depth": depth}))
        if opts.cluster:
            out += self._cluster_passes(build, msaa, compact, stats, bounded, depth, writes,
                                        uniforms, suffix)
        else:
            out += self._tile_passes(build, opts, target, msaa, compact, stats, writes, uniforms, suffix)
        return out

    @staticmethod
    def _written(writes: dict, first: bool) -> dict:
        """The bit arrays (and counters) a pass writes: cleared by the first pass only."""
        return dict(writes) if first else {k: Buffer(v.nbytes) for k, v in writes.items()}

    def _cluster_passes(self, build, msaa, compact, stats, bounded, depth, writes, uniforms,
                        suffix) -> list:
        """MARK (back faces of the proxies the eye is outside of), then WALK (their front
        faces) and the eye-inside proxies' back faces (raster_cluster.frag); `bounded`:
        within each tile's scene depth (buffer `depth`, the tile depth pass's)."""
        # A target with no colour attachment (the technique's own depth target, untested):
        # with "none"'s colour renderbuffer and no depth test, llvmpipe (Mesa 22.3) takes a
        # triangle that covers a whole 64x64 bin as opaque and drops the bin's earlier
        # commands, side effects (our atomics) and all: on hangar at 480x270 an eye-inside
        # proxy drawn later erased other lights' marks in whole 2x2-tile blocks.
        target = Target("raster_cluster", scale=2 if msaa else 1, samples=MSAA_SAMPLES if msaa else 0)
        groups, out = build.data["groups"], []
        starts = np.concatenate([[0], np.cumsum(groups)])      # order[] is sorted by (shape, side)
        uniforms = dict(uniforms, **grid_uniforms(build.grid))
        for mode, back, cull in (("mark", 0, "front"), ("walk", 0, "back"), ("inside", 1, "front")):
            for shape in range(4):
                count = int(groups[2 * shape + back])
                if count:
                    out.append(Pass(
                        f"raster {rp.PROXY_NAMES[shape]} {mode}" + suffix,
                        ("raster_proxy.vert", "raster_cluster.frag"),
                        reads=("lights", "raster_proxies", "raster_order")
                        + (("raster_tile_depth",) if bounded else ()),
                        writes=self._written(writes, not out),
                        draw=Draw(vertices=rp.MESHES_CORNERS[shape], format="4f 4f 4f",
                                  attributes=("in_vertex", "in_vertex1", "in_vertex2"),
                                  instances=count, target=target, cull=cull),
                        timed=not stats, native_wave=compact,
                        defines={"RASTER_MSAA": int(msaa), "RASTER_COMPACT": int(compact),
                                 "RASTER_STATS": int(stats), "RASTER_TRI_BOUNDS": 1,
                                 "RASTER_DEPTH_BOUND": int(bounded)},
                        uniforms=dict(uniforms, u_shape=shape, u_first=int(starts[2 * shape + back]),
                                      u_mode=MODE[mode]),
                        sources={"raster_tile_depth": depth} if bounded else {}))
        return out or [self._no_lights(writes, stats, suffix)]

    @staticmethod
    def _no_lights(writes, stats, suffix) -> Pass:
        """No light: the (empty) bit arrays still come from a pass."""
        return Pass("raster none" + suffix, ("raster_proxy.vert", "raster_mark.frag"),
                    reads=("lights", "raster_proxies", "raster_order"), writes=writes,
                    draw=Draw(count=0, target="none"), timed=not stats,
                    defines={"RASTER_MSAA": 0, "RASTER_COMPACT": 0, "RASTER_STATS": int(stats),
                             "RASTER_TRI_BOUNDS": 0})

    def _tile_passes(self, build, opts, target, msaa, compact, stats, writes, uniforms, suffix):
        cam = build.frame.camera
        quad = uniforms["u_sample_pixel"]
        out = [Pass("raster fill" + suffix, ("raster_fill.vert", "raster_fill.frag"),
                    draw=Draw(count=3, target=target, depth_test="always", depth_write=True, clear=True),
                    defines={"RASTER_MSAA": int(msaa)}, timed=not stats,
                    uniforms={"u_near": float(cam.near), "u_sample_pixel": quad})]
        groups = build.data["groups"]
        first = 0
        drawn = False
        for shape in range(4):
            for back in (0, 1):
                count = int(groups[2 * shape + back])
                if count == 0:
                    first += count
                    continue
                stencil = ()
                mode = MODE["back" if back else "front"]
                if opts.stencil and not back:
                    mode = MODE["stencil"]
                    stencil = (StencilStep(cull="back", depth_test=FRONT_TEST, func="always",
                                           ops=("keep", "keep", "replace")),
                               StencilStep(cull="front", depth_test=BACK_TEST, func="equal",
                                           ops=("keep", "keep", "zero")))
                draw = Draw(vertices=rp.MESHES[shape], format="4f", attributes=("in_vertex",),
                            instances=count, target=target,
                            depth_test=(BACK_TEST if back else FRONT_TEST) if opts.early_depth else "always",
                            cull="front" if back else "back", stencil=stencil)
                out.append(Pass(
                    f"raster {rp.PROXY_NAMES[shape]} {'back' if back else 'front'}" + suffix,
                    ("raster_proxy.vert", "raster_mark.frag"),
                    reads=("lights", "raster_proxies", "raster_order"),
                    writes=self._written(writes, not drawn),
                    draw=draw, timed=not stats, native_wave=compact,
                    defines={"RASTER_MSAA": int(msaa), "RASTER_COMPACT": int(compact),
                             "RASTER_STATS": int(stats), "RASTER_TRI_BOUNDS": 0},
                    uniforms=dict(uniforms, u_shape=shape, u_first=first, u_mode=mode)))
                drawn = True
                first += count
        if not drawn:
            out.append(self._no_lights(writes, stats, suffix))
        return out


def _msaa_samples(frame, msaa: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """(sample positions, each sample's full-res pixel in its 2x2 block, dilation in full-res
    pixels) of the MSAA variants, from the frame's GL limits; pixel centres without MSAA."""
    positions = np.full((MSAA_SAMPLES, 2), 0.5, np.float32)
    if not msaa:
        return positions, np.zeros((MSAA_SAMPLES, 2), np.int32), 0.0
    positions = np.asarray(frame.limits.sample_positions(MSAA_SAMPLES), np.float32)
    quad, dilation = rp.msaa_dilation(positions)
    return positions, quad, dilation


def _build_stats(b, opts, masked: bool, bits_bytes: int, dilation: float, gl_limits) -> dict:
    """The build's meta stats: the variant, the grid, the bit arrays and the proxies drawn."""
    g, n, groups = b.grid, len(b.lights), b.data["groups"]
    tris = sum(int(groups[2 * s + k]) * len(rp.MESHES[s]) // 3 for s in range(4) for k in range(2))
    cluster = f" ({CLUSTER_NAMES[opts.cluster]})" if opts.cluster else ""
    return dict(
        variant=opts.choice_name("raster_variant") + cluster,
        shade_variant="cluster loop" if opts.cluster else opts.choice_name("zbin_variant"),
        stencil=int(opts.stencil), bit_tile_used=g.tile,
        tiles=g.tiles_x * g.tiles_y, cells=g.cells, words_per_tile=zb.words_for(n),
        bits_bytes=bits_bytes,
        zbins=opts.zbins if masked else 0,
        zbin_bytes=int(b.buffers["zbins"].nbytes) if masked else 0,
        zbin_id_bits=32 if zb.is_wide(n) else zb.ZBIN_ID_BITS,
        proxies_front=int(groups[0::2].sum()), proxies_back=int(groups[1::2].sum()),
        proxy_triangles=tris, msaa_dilation_px=round(dilation, 4),
        compaction=_compaction(opts.raster_variant, gl_limits),
        **{f"proxies_{rp.PROXY_NAMES[s]}": int(groups[2 * s] + groups[2 * s + 1]) for s in range(4)})


def _compaction(variant: int, gl_limits) -> str:
    """How the compaction variants run here (meta stats)."""
    if not variant & 2:
        return "off"
    if gl_limits.native_wave:
        return "native subgroup"
    return "unavailable (neither GL_KHR_shader_subgroup nor GL_ARB_shader_ballot): plain atomics"


def _raster_counters(build, got):
    """Meta stats of the untimed twin (module doc): fragments, atomics, marks, and the
    lights occlusion removed."""
    c = got["raster_counters"].view(np.uint32)
    per_light = got["raster_light_tiles"].view(np.uint32)[:len(build.lights)].astype(np.int64)
    g, pl = build.grid, build.lights
    boxes = tile_boxes(pl, g)
    nx = (boxes[:, 1] - boxes[:, 0] + 1).clip(0)
    ny = (boxes[:, 3] - boxes[:, 2] + 1).clip(0)
    ns = (boxes[:, 5] - boxes[:, 4] + 1).clip(0)
    rect_tiles = nx * ny * ns              # the cells (tiles, or clusters) of the CPU's boxes
    depth = got["raster_tile_depth"].view(np.uint32).reshape(-1, 2)
    lo = (~depth[:, 0]).view(np.float32).reshape(g.tiles_y, g.tiles_x)
    hi = depth[:, 1].view(np.float32).reshape(g.tiles_y, g.tiles_x)
    covered = depth[:, 1].reshape(g.tiles_y, g.tiles_x) != 0
    unmarked = np.nonzero((per_light == 0) & (rect_tiles > 0))[0]
    occluded = _kept_by_tile_depth(boxes[unmarked], pl.depth_lo[unmarked], pl.depth_hi[unmarked],
                                   covered, lo, hi)
    build.stats.update(
        raster_fragments=int(c[0]), raster_atomics=int(c[1]), raster_marks=int(per_light.sum()),
        rect_marks=int(rect_tiles.sum()), unmarked_lights=int(len(unmarked)),
        occluded_lights=int(occluded), raster_pixel_marks=int(c[2]))
    return {}, []


def _kept_by_tile_depth(boxes, depth_lo, depth_hi, covered, lo, hi,
                        pairs_per_step: int = 1 << 22) -> int:
    """How many of these lights a tile depth-bounds test (tiled's) would keep: some covered
    tile of the light's rectangle (boxes: x0, x1, y0, y1 inclusive) whose depth range meets
    the light's.  Every (light, tile) pair at once, in steps of at most `pairs_per_step`
    pairs (one light's rectangle may be the whole screen)."""
    w = (boxes[:, 1] - boxes[:, 0] + 1).astype(np.int64)
    h = (boxes[:, 3] - boxes[:, 2] + 1).astype(np.int64)
    n = w * h
    ends = np.cumsum(n)
    kept, first = 0, 0
    while first < len(n):
        last = max(first + 1, int(np.searchsorted(ends, ends[first] - n[first] + pairs_per_step, "right")))
        own = np.repeat(np.arange(first, last), n[first:last])
        starts = ends[first:last] - n[first:last]
        k = np.arange(len(own)) + starts[0] - np.repeat(starts, n[first:last])   # tile of its box
        tx = boxes[own, 0] + k % w[own]
        ty = boxes[own, 2] + k // w[own]
        keep = covered[ty, tx] & (lo[ty, tx] <= depth_hi[own]) & (hi[ty, tx] >= depth_lo[own])
        kept += len(np.unique(own[keep]))
        first = last
    return kept


# ---- the slides' figures beside this run's (app/report/notes.py) ------------------------

SLIDES_TILE = {0: "1.44 ms (100%)", 1: "0.27 ms (18%)", 2: "0.36 ms (25%)", 3: "0.10 ms (7%)"}
SLIDES_TILE_MS = {0: 1.44, 1: 0.27, 2: 0.36, 3: 0.10}
SLIDES_SIZE = (1920, 1080)           # their 240 x 135 tiles of 8 x 8
MODEL_GPU = "ps4"                    # the slides' GPU in app/model/cost.py


def contention_figures(technique, size=SLIDES_SIZE) -> dict[int, dict]:
    """Per raster_variant, the contention scene at `size` (its default lights, frame 0): the
    stats twin's atomics and fragments, the tile grid, and the culling passes modelled on
    the slides' PS4.  Counters and model only, no timing (the report rebuilds to the same
    text from the same results); the shading passes skip their light loops (CELLS_ONLY).
    Made once a process (four 1920x1080 frames, ~3 s on llvmpipe: every report write)."""
    return copy.deepcopy(_contention_figures(technique, tuple(size)))


@lru_cache(maxsize=4)
def _contention_figures(technique, size) -> dict[int, dict]:
    from scenes import load_scene
    from ...model import cost, counts, waves
    from ...pipeline.renderer import Renderer
    gpu = cost.BY_KEY[MODEL_GPU]
    out = {}
    scene = load_scene(CONTENTION_SCENE)
    with Renderer(scene, tuple(size)) as r:
        for v in range(len(VARIANTS)):
            opts = technique.resolve_options({"raster_variant": v})
            res = r.render(technique, 0, opts, defines={"CELLS_ONLY": 1})
            frame = waves.frame_data(r, res, opts)
            figs = technique.cull_figures(frame, gpu.wave)
            counts.attach(figs, frame.programs)        # each pass's counted instructions
            st = res.meta["stats"]
            out[v] = {"atomics": int(st["raster_atomics"]), "fragments": int(st["raster_fragments"]),
                      "model_ms": sum(cost.pass_ms(f, gpu) for f in figs.values()),
                      "tiles": (res.build.grid.tiles_x, res.build.grid.tiles_y),
                      "lights": len(scene.lights), "size": tuple(size)}
    return out


def resolution(r) -> str:
    return f"{int(r['width'])}x{int(r['height'])}"


def _share(a, b) -> str:
    return f"{a / b:.0%}" if b else "-"


def _variant_table(technique, study, measured=()) -> list[str]:
    """The slides' tile rasterizer table beside the contention scene's counters (rendered
    here at the slides' resolution), the variant study's rows, and the contention scene's
    own study rows (`measured`: the benchmark's "raster_variant@contention")."""
    import json
    from ...pipeline import gl
    by = {int(r["raster_variant"]): r for r in study}
    there = {int(r["raster_variant"]): r for r in measured}
    r0 = study[0]
    try:
        con = contention_figures(technique)
    except Exception as exc:                 # no GL context where the report is rebuilt
        con = {}
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    atomics = {v: json.loads(r["stats"]).get("raster_atomics") if r.get("stats") else None
               for v, r in by.items()}
    base_ms = float(by[0]["gpu_cull_ms"]) if 0 in by else 0.0
    text = []
    if con:
        tx, ty = con[0]["tiles"]
        w, h = con[0]["size"]
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside the {CONTENTION_SCENE} scene (three lights holding the whole hall and "
                 f"{con[0]['lights'] - 3} small ones, {w}x{h}: {tx}x{ty} tiles; the "
                 f"stats twin's atomics, rendered for this report, and the culling passes (the "
                 f"depth fill included) "
                 f"modelled on the PS4, whose model has no atomic contention) and this run's "
                 f"variant study ({r0['scene']}, {int(r0['lights'])} lights; culling passes with "
                 f"the depth fill measured here, median: on a software rasterizer MSAA is "
                 f"per-sample work and atomics are cheap, so only the atomic counts carry over):",
                 "", f"| variant | slides | {CONTENTION_SCENE}: atomics | of atomic | modelled PS4 "
                 + (f"| {CONTENTION_SCENE}: measured here, {resolution(measured[0])} | of atomic "
                    if there else "")
                 + f"| {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|" + ("---|---|" if there else "") + "---|---|---|---|"]
    else:
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside this run's variant study ({r0['scene']}, {int(r0['lights'])} lights; "
                 f"culling passes with the depth fill, median; only the atomic counts carry over "
                 f"from a software rasterizer); the {CONTENTION_SCENE} scene's counters need a GL "
                 f"context, none here ({why}):", "",
                 f"| variant | slides | {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|---|"]
    for v in range(len(VARIANTS)):
        r = by.get(v)
        cells = [VARIANTS[v], SLIDES_TILE[v]]
        if con:
            c = con[v]
            cells += [f"{c['atomics']:,}", _share(c["atomics"], con[0]["atomics"]),
                      f"{c['model_ms']:.3g} ms"]
            if there:
                m = there.get(v)
                cells += ([f"{float(m['gpu_cull_ms']):.3g} ms ({float(m['gpu_cull_min_ms']):.3g}-"
                           f"{float(m['gpu_cull_max_ms']):.3g})",
                           _share(float(m["gpu_cull_ms"]), float(there[0]["gpu_cull_ms"]))]
                          if m is not None and 0 in there else ["-", "-"])
        if r is None:
            cells += ["-"] * 4
        else:
            cull = float(r["gpu_cull_ms"])
            a, a0 = atomics.get(v), atomics.get(0)
            cells += [f"{cull:.3g} ms", _share(cull, base_ms), f"{a:,}" if a is not None else "-",
                      _share(a, a0) if a is not None and a0 else "-"]
        text.append("| " + " | ".join(cells) + " |")
    if con:
        sub = gl.limits().subgroup_size
        plain = con[0]
        text.append(
            f"\nIn the {CONTENTION_SCENE} scene every pixel marks three lights, so each tile's "
            f"pixels issue their atomics on the same words: compaction leaves "
            f"{_share(con[2]['atomics'], plain['atomics'])} of the plain rasterizer's "
            f"{plain['atomics']:,} atomics (on this driver's "
            f"{f'{sub}-lane ' if sub else ''}subgroups; a 64-lane wave merges more), MSAA "
            f"{_share(con[1]['atomics'], plain['atomics'])}, both "
            f"{_share(con[3]['atomics'], plain['atomics'])}, against the slides' times 25%, 18% "
            f"and 7%.  The model's PS4 culling time for the plain rasterizer, "
            f"{plain['model_ms']:.3g} ms, is {SLIDES_TILE_MS[0] / plain['model_ms']:.2g}x below "
            f"the slides' 1.44 ms: the model counts an atomic as one memory access, and their "
            f"contention is what compaction removes.")
    return text


def _cluster_text(study) -> list[str]:
    """Cluster against tile waste, with and without the depth bound (the `cluster` study)."""
    import json
    by = {int(r["cluster"]): r for r in study}
    if 0 not in by or not ({1, 2} & set(by)):
        return []
    st = {v: json.loads(r["stats"]) if r.get("stats") else {} for v, r in by.items()}
    t = by[0]
    tile = st[0].get("bit_tile_used", "?")
    parts = []
    for v in (1, 2):
        if v in by:
            r = by[v]
            parts.append(f"{float(r['evaluated_pp']):.3g} lights a pixel "
                         f"{'with' if v == CLUSTER_BOUNDED else 'without'} the depth bound "
                         f"(waste {float(r['waste']):.3g}x the exact lights)")
    text = [f"\nThe cluster rasterizer against the tiles (the cluster study, {t['scene']}, "
            f"{int(t['lights'])} lights): tiles evaluate {float(t['evaluated_pp']):.3g} lights a "
            f"pixel (waste {float(t['waste']):.3g}x), clusters {' and '.join(parts)}."]
    if 1 in by and 2 in by:
        b, u = st[1], st[2]
        same = float(by[1]["evaluated_pp"]) == float(by[2]["evaluated_pp"])
        text.append(
            f"The bound {'leaves the evaluations as they are' if same else 'changes the evaluations'}"
            f" (a pixel reads only the cluster of its own depth's slice, which lies within its "
            f"tile's depth range) and saves marking: {b.get('raster_marks', '-')} (cluster, light) "
            f"marks against {u.get('raster_marks', '-')}, {b.get('raster_atomics', '-')} atomics "
            f"against {u.get('raster_atomics', '-')}, culling {float(by[1]['gpu_cull_ms']):.3g} ms "
            f"against {float(by[2]['gpu_cull_ms']):.3g} ms (the bound's own depth pass included).")
    ctile = st.get(1, st.get(2, {})).get("bit_tile_used", "?")
    text.append(f"What the clusters waste would be their size on screen: {ctile} px clusters "
                f"against {tile} px tiles, each marked wherever a light's volume passes through "
                f"it, where a tile is marked only by a lit surface pixel of its own (argued here; "
                f"the --full preset's cluster_tile sweep measures it).")
    return [" ".join(text)]


def _cluster_tile_text(rows) -> list[str]:
    """The paper_cluster_tile sweep (with the cluster table's atomic row, and the rasterized
    tiles of the optimization table beside it): lights evaluated a pixel against the
    clusters' size."""
    import json
    from ...results import PAPER_PREFIX
    sweep = [r for r in rows if r.get("study") == PAPER_PREFIX + "cluster_tile" or (
        r.get("study") == PAPER_PREFIX + "cluster_raster" and int(float(r["raster_variant"])) == 0)]
    if len(sweep) < 2:
        return []
    px = lambda r: int(json.loads(r.get("stats") or "{}").get("bit_tile_used", 0))
    sweep.sort(key=px)
    f = lambda r, k: float(r[k])
    cells = [f"{px(r)} px {f(r, 'evaluated_pp'):.3g} lights a pixel (waste {f(r, 'waste'):.3g}x, "
             f"modelled PS4 culling {f(r, 'model_ps4_cull_ms'):.3g} + shading "
             f"{f(r, 'model_ps4_shade_ms'):.3g} ms)" for r in sweep]
    tiles = {int(float(r["zbin_variant"])): r for r in rows
             if r.get("study") == PAPER_PREFIX + "zbin_table" and r.get("technique") == "raster"}
    waste = [f(r, "waste") for r in sweep]
    falls = all(a <= b for a, b in zip(waste, waste[1:]))
    r0 = sweep[0]
    text = (f"\nThe cluster rasterizer's clusters swept ({r0['scene']}, {int(float(r0['lights']))} "
            f"lights, {int(float(r0['width']))}x{int(float(r0['height']))}, "
            f"{int(float(r0['cluster_slices']))} slices, atomic): " + "; ".join(cells) + ".  ")
    if 0 in tiles:
        t = tiles[0]
        text += (f"The rasterized 8-px tiles (base tile, no z-bins) evaluate "
                 f"{f(t, 'evaluated_pp'):.3g} (waste {f(t, 'waste'):.3g}x).  ")
    text += ("The waste falls as the clusters shrink: it is their size on screen, as argued "
             "above." if falls else "The waste does not fall steadily as the clusters shrink: "
             "their size on screen is not all of it.")
    return [text]


def _notes(technique, rows) -> tuple[str, str]:
    import json
    text = []
    study = [r for r in rows if r.get("study") == "raster_variant"]
    if study:
        text += _variant_table(technique, study, [r for r in rows if r.get("study") ==
                                                  f"raster_variant@{CONTENTION_SCENE}"])
    text += _cluster_text([r for r in rows if r.get("study") == "cluster"])
    text += _cluster_tile_text(rows)
    path = [r for r in rows if r.get("study") == "path"]
    st = [json.loads(r["stats"]) for r in path if r.get("stats")]
    if st:
        vis = sum(s.get("visible_lights", 0) for s in st)
        un = sum(s.get("unmarked_lights", 0) for s in st)
        occ = sum(s.get("occluded_lights", 0) for s in st)
        text.append(f"\nAlong the camera paths, {un} of {vis} visible lights marked no tile "
                    f"(their volume reaches no visible surface); {occ} of them a per-tile depth "
                    f"bounds test would still have kept: occlusion alone removed them.")
    return "what the slides measure", "\n".join(text)
