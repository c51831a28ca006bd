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

from dataclasses import dataclass, replace

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, layouts, limits, raster_proxies as rp, zbin as zb

from ...pipeline.gbuffer import column_major
from ...pipeline.passes import Buffer, Draw, HostStep, Pass, StencilStep, Target, image_groups
from ..base import TRANSPARENT_REBUILT, Technique, grid_uniforms, prepare, shading_passes
from ..options import StochasticOptions, choice, option
from ..bit_arrays import ShadingOptions, attach_zbins, shading_steps, tile_bit_maps, tile_uniforms, variant_flags
from .counters import raster_counters

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


@dataclass(frozen=True)
class RasterData:
    """raster's own build state (Build.own): the visible lights per (proxy shape, side) group,
    in raster_order's order (one instanced draw a group), and the MSAA samples' full-res
    pixels in their 2x2 block and positions (_msaa_samples)."""
    groups: np.ndarray
    quad: np.ndarray
    sample_pos: np.ndarray


class Raster(Technique, register_at=80):
    name = "raster"
    transparent = TRANSPARENT_REBUILT.format(what="its proxies' depth-tested tile bits are")
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
        b.own = RasterData(groups, quad, positions)
        b.stats.update(_build_stats(b, opts, masked, bits_bytes, dilation, frame.limits))
        return b

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
                                lambda got: raster_counters(build, got), figures=True))
        out += self._cull_passes(build, opts, stats=False)
        if opts.cluster:
            g = build.grid
            return out + shading_passes(
                build, "raster_shade_cluster.comp", ("cluster_bits",), longest=len(build.lights),
                uniforms=dict(grid_uniforms(g), u_words=zb.words_for(len(build.lights))),
                sources={"cluster_bits": "raster_bits"})
        return out + shading_steps(build, opts, "raster_bits")

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
        quad = np.ascontiguousarray(build.own.quad, np.int32)
        writes = {bits_name: Buffer(max(g.cells * words, 1) * 4, cleared=True)}
        if stats:
            writes["raster_counters"] = Buffer(16, cleared=True)
            writes["raster_light_tiles"] = Buffer(max(n, 1) * 4, cleared=True)
        # raster_proxy.vert's and raster_common.glsl's (the cluster passes add the slices)
        uniforms = dict(tile_uniforms(g), u_clip_from_view=clip, u_near=float(cam.near),
                        u_instance=0, u_step=0, u_ndc=(sx, sy, sx - 1.0, sy - 1.0), u_words=words,
                        u_sample_pixel=quad, u_sample_pos=build.own.sample_pos)
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
        groups, out = build.own.groups, []
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
                        timed=not stats, native_wave=compact or stats,
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
        groups = build.own.groups
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
                    draw=draw, timed=not stats, native_wave=compact or stats,
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
    g, n, groups = b.grid, len(b.lights), b.own.groups
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


# ---- the slides' figures beside this run's (app/report/notes.py) ------------------------


def resolution(r) -> str:
    return f"{int(r['width'])}x{int(r['height'])}"


