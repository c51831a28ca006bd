"""raster (Drobot 2017 rasterization based culling): light proxies drawn against
the scene's depth mark 8x8 tile bit arrays with atomics.

  * the proxies (no GL): every proxy is convex, wound outwards, and holds its light's volume
    grown by its margin M (sampled on the volume's boundary), for all four shapes, narrow and
    90-degree spots, capsules of length 0, flat boxes, tiny and wide screens;
  * every variant (atomic, + MSAA, + compaction, both; two-pass stencil; the hardware depth
    test off) against brute at every pixel on random shape mixes, odd sizes, the eye inside
    lights, lights across the near plane and past the far plane, lights behind walls;
  * the hardware depth test rejects nothing the shader's exact test keeps (same bits with
    and without it, on scenes built to strain it: huge triangles, huge lights, far planes);
  * occlusion: lights behind a wall mark nothing and are counted; the variants' counters
    (MSAA fewer fragments, compaction fewer atomics);
  * the cluster rasterizer (MARK / WALK, eye-inside walks from the near plane) exact too,
    with the depth prepass's bound (every cluster a pixel reads holds the unbounded bits,
    with fewer marks) and without;
  * one rule for options: an option the mode ignores is refused in one line, and no option
    study trips over it;
  * the contention scene (three full-screen lights): every variant exact, the atomics the
    slides' table is about, and the report's notes that set them beside the slides'.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from app.pipeline.passes import FrameInput
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, parts
from app.techniques import raster as rs
from app.techniques.base import prepare
from cpu_prep import raster_proxies as rp
from cpu_prep.camera import frame_camera
from scenes.geometry import box_mesh
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT, Camera, make_lights
from tests.app.techniques.raster_helpers import basis, proxy_vertices
from tests.helpers import CAMERA, assert_exact, make_scene, random_shapes, render_all, render_on

RASTER = REGISTRY["raster"]


# ---------------------------------------------------------------------------- proxies (no GL)

def _planes(tris):
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area = np.linalg.norm(n, axis=1)
    keep = area > 1e-12 * max(area.max(), 1e-300)
    n = n[keep] / area[keep, None]
    return n, np.einsum("ij,ij->i", n, tris[keep, 0])


def _boundary(light, k, rng):
    """k points on the boundary of a light's volume (view space, float64)."""
    p = light["pos_radius"][:3].astype(np.float64)
    R = float(light["pos_radius"][3])
    f = light["dir_cos_outer"][:3].astype(np.float64)
    t = int(light["id_type"][1])
    u = rng.normal(size=(k, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    if t == LIGHT_POINT:
        return p + R * u
    if t == LIGHT_CAPSULE:
        h = 0.5 * float(light["extent_length"][3])
        return p + f * rng.uniform(-h, h, (k, 1)) + R * u
    if t == LIGHT_BOX:
        r = light["right"][:3].astype(np.float64)
        axes = np.stack([r, np.cross(r, f), f])
        e = light["extent_length"][:3].astype(np.float64)
        s = rng.uniform(-1, 1, (k, 3))
        s[np.arange(k), rng.integers(0, 3, k)] = rng.choice([-1.0, 1.0], k)
        return p + (s * e) @ axes
    ca = max(float(light["dir_cos_outer"][3]), 0.0)
    alpha = math.acos(min(ca, 1.0))
    e1, e2 = basis(f)
    phi = rng.uniform(0, 2 * math.pi, k)
    side = rng.random(k) < 0.5
    th = np.where(side, alpha, rng.uniform(0, 1, k) * alpha)        # cone wall or cap
    dist = np.where(side, rng.uniform(0, R, k), R)
    d = (np.sin(th) * np.cos(phi))[:, None] * e1 + (np.sin(th) * np.sin(phi))[:, None] * e2 + \
        np.cos(th)[:, None] * f
    return p + dist[:, None] * d


def _frame(lights, size=(96, 64), camera=CAMERA, fov=None):
    if fov is not None:
        camera = Camera(camera.position, camera.target, fov_y_deg=fov, near=camera.near, far=camera.far)
    return FrameInput(lights, frame_camera(camera, *size), 150.0)


@pytest.mark.parametrize("size,fov,dilation", [((96, 64), 60.0, 0.0), ((96, 64), 60.0, 0.354),
                                               ((1, 1), 150.0, 0.0), ((7, 300), 20.0, 0.354)])
def test_proxies_hold_their_volume_grown_by_the_margin(size, fov, dilation):
    rng = np.random.default_rng(int(sum(size) + fov))
    L = random_shapes(rng, 160, (-14, -1, -34), (14, 7, 6), outer_deg=(0.5, 90.0))
    L["cos_outer"][:20] = 0.0                                   # 90 degrees exactly
    L["type"][:20] = LIGHT_SPOT
    b = prepare(_frame(L, size, fov=fov))
    pl, cam = b.lights, b.frame.camera
    px = rp.proxy_params(pl, cam, dilation)
    assert {int(s) for s in px["shape"]} >= ({0, 3} if size == (1, 1) else {0, 1, 2, 3})
    for i in range(len(pl)):
        g, pr = pl.gpu[i], px[i]
        V = proxy_vertices(g, pr)
        tris = V.reshape(-1, 3, 3)
        n, off = _planes(tris)
        scale = np.abs(V).max() + 1.0
        # convex (every vertex behind every face plane), wound outwards (the centroid inside)
        assert (V @ n.T - off).max() <= 1e-6 * scale, f"light {i}: proxy not convex"
        assert (V.mean(0) @ n.T - off).max() < 0, f"light {i}: proxy wound inwards"
        # the volume grown by M: boundary points pushed M outwards stay inside
        M = float(pr["margin"])
        Q = _boundary(g, 300, rng)
        u = rng.normal(size=Q.shape)
        Q += 0.999 * M * u / np.linalg.norm(u, axis=1, keepdims=True)
        worst = (Q @ n.T - off).max()
        assert worst <= 1e-6 * scale, f"light {i} ({rp.PROXY_NAMES[int(pr['shape'])]}): " \
                                      f"a point of the grown volume lies {worst:g} outside"
        # front faces only for proxies wholly past the near plane (back: conservatively)
        if not pr["back"]:
            assert -V[:, 2].max() > cam.near * (1 + rp.NEAR_SIDE)
        if size == (1, 1) and pr["back"] and float(pr["radius"]) > 2 * np.linalg.norm(g["pos_radius"][:3]):
            assert (np.zeros(3) @ n.T - off).max() < 0                   # the eye inside


def test_margin_covers_a_pixel_fraction_of_footprint():
    """M >= MARGIN_PX (+ dilation) pixels of footprint at the proxy's far end."""
    rng = np.random.default_rng(3)
    L = random_shapes(rng, 100, (-14, -1, -34), (14, 7, 6))
    b = prepare(_frame(L))
    cam = b.frame.camera
    px = rp.proxy_params(b.lights, cam, 0.354)
    for g, pr in zip(b.lights.gpu, px):
        far = -proxy_vertices(g, pr)[:, 2].min()
        assert pr["margin"] >= (rp.MARGIN_PX + 0.354) * 2 * cam.tan_half_y / cam.height * far * 0.999


def test_msaa_samples_pair_with_quadrant_pixels():
    quad, d = rp.msaa_dilation([(0.375, 0.125), (0.875, 0.375), (0.125, 0.625), (0.625, 0.875)])
    assert quad.tolist() == [[0, 0], [1, 0], [0, 1], [1, 1]]
    assert d == pytest.approx(math.sqrt(2) / 4)
    with pytest.raises(ValueError, match="one per quadrant"):
        rp.msaa_dilation([(0.2, 0.2), (0.3, 0.3), (0.7, 0.7), (0.6, 0.8)])


def test_mesh_factors_circumscribe():
    assert rp.K_SPHERE == pytest.approx(1 / 0.93417, rel=1e-4)
    assert rp.K_CAPSULE >= 1 / math.cos(math.pi / rp.SIDES)
    theta = np.linspace(0.01, math.pi / 2 + math.asin(rp.CONE_APEX_MAX), 200)   # every cap angle
    d = rp.cap_plane_distance(theta)
    assert (np.diff(d) <= 1e-12).all() and d.min() >= 1 / rp.K_CONE_MAX - 1e-12


def test_mode_ids_are_generated_from_one_source():
    """u_mode's values cross into GLSL as RASTER_MODE_* from raster.MODES, the proxy shapes as
    PROXY_* from raster_proxies.PROXY_NAMES: no raster shader compares them with a literal."""
    import re
    from pathlib import Path
    folder = Path(rs.__file__).parent
    for path in sorted(folder.glob("raster*")):
        text = path.read_text()
        assert not re.search(r"\b(u_mode|u_shape)\s*[!=]=\s*\d", text), path.name
    for i, name in enumerate(rs.MODES):
        assert f"#define RASTER_MODE_{name.upper()} {i}\n" in rs.STRUCTS_GLSL
    for i, name in enumerate(rp.PROXY_NAMES):
        assert f"#define PROXY_{name.upper()} {i}\n" in rs.STRUCTS_GLSL


# ---------------------------------------------------------------------------- exact (GL)

VARIANTS = [dict(raster_variant=v) for v in range(4)] + [
    dict(stencil=True), dict(stencil=True, raster_variant=3), dict(early_depth=False, raster_variant=1),
    dict(zbin_variant=0, raster_variant=2, native_wave=True),
    dict(cluster=True), dict(cluster=True, raster_variant=3, cluster_tile=8, cluster_slices=24),
    dict(cluster=2), dict(cluster=2, raster_variant=1, cluster_tile=8)]
IDS = ["atomic", "msaa", "compact", "both", "stencil", "stencil-both", "no-early-msaa", "base-native",
       "cluster", "cluster-both", "cluster-unbounded", "cluster-unbounded-msaa"]


@pytest.mark.parametrize("opts", VARIANTS, ids=IDS)
def test_variants_are_exact_on_shape_mixes(gl, opts):
    rng = np.random.default_rng(12)
    L = random_shapes(rng, 300, (-14, -1, -34), (14, 7, 6))
    res = render_all(make_scene(L, size=(75, 43)), opts, techniques=["brute", "raster"])
    assert_exact(res, str(opts))
    st = res["raster"].meta["stats"]
    assert st["raster_marks"] > 0 and res["brute"].contrib_count.sum() > 500
    assert st["raster_marks"] < st["rect_marks"]
    assert res["raster"].meta["stats"]["cells"] == st["tiles"] * (opts.get("cluster_slices", 16)
                                                                 if opts.get("cluster") else 1)
    assert res["raster"].meta["options"]["raster_variant"] == opts.get("raster_variant", 0)


def _hard_lights(rng, eye, n_eye=12, n_near=20):
    """Shapes around the eye (radii past the far plane too), crossing the near plane, and on
    the scene."""
    big = random_shapes(rng, n_eye, eye - 1.0, eye + 1.0, radius=(2.0, 400.0), length=(0.0, 50.0),
                        extent=(2.0, 300.0))
    near = random_shapes(rng, n_near, eye + np.array([-0.6, -0.6, -0.4]), eye + np.array([0.6, 0.6, 0.1]),
                         radius=(0.05, 0.5), length=(0.0, 1.0), extent=(0.02, 0.4))
    scene = random_shapes(rng, 150, (-14, -1, -34), (14, 7, 6))
    return np.concatenate([big, near, scene])


@pytest.mark.parametrize("opts", [{}, dict(raster_variant=3), dict(stencil=True), dict(cluster=True),
                                  dict(cluster=True, raster_variant=1, cluster_tile=4), dict(cluster=2)],
                         ids=["atomic", "both", "stencil", "cluster", "cluster-msaa", "cluster-unbounded"])
def test_eye_inside_near_plane_and_far_plane(gl, opts):
    rng = np.random.default_rng(7)
    L = _hard_lights(rng, np.asarray(CAMERA.position))
    cam = Camera(CAMERA.position, CAMERA.target, near=0.1, far=60.0)      # big lights pass the far plane
    res = render_all(make_scene(L, size=(64, 40), camera=cam), opts, techniques=["brute", "raster"])
    assert_exact(res, f"eye inside / near / far {opts}")
    st = res["raster"].meta["stats"]
    assert st["proxies_back"] >= 20 and st["proxies_front"] > 50


@pytest.mark.parametrize("size", [(1, 1), (2, 1), (3, 257), (49, 47), (97, 65)])
def test_odd_sizes_every_variant(gl, size):
    rng = np.random.default_rng(sum(size))
    L = random_shapes(rng, 120, (-10, -1, -30), (10, 6, 5))
    scene = make_scene(L, size=size)
    with Renderer(scene) as r:
        ref = r.render(REGISTRY["brute"])          # brute takes none of the options
        for opts in (dict(raster_variant=3), dict(raster_variant=1, bit_tile=5), dict(stencil=True),
                     dict(cluster=True, raster_variant=3, cluster_tile=5)):
            res = render_on(r, opts, techniques=["raster"], reference=ref)
            assert_exact(res, f"size {size} {opts}")


def _bits(r, lights, opts):
    r.render(RASTER, 0, RASTER.resolve_options(dict(opts, raster_stats=False)), lights=lights)
    return r.read("raster_bits").copy()


@pytest.mark.parametrize("variant", [0, 1])
def test_early_depth_rejects_nothing_the_shader_keeps(gl, variant):
    """The hardware test is only an early reject: on scenes that strain depth precision
    (a floor 1e5 wide, far plane 1e5, near 0.01, lights from 1 cm to 2 km, the eye inside
    some) it sets exactly the bits of the shader's exact tests alone."""
    rng = np.random.default_rng(variant + 40)
    cam = Camera((0.0, 3.0, 10.0), (0.0, 0.0, -300.0), fov_y_deg=75.0, near=0.01, far=1e5)
    meshes = [box_mesh((-1e5, -1.0, -1e5), (1e5, 0.0, 1e5)), box_mesh((-40, 0, -60), (40, 30, -58)),
              box_mesh((-3, 0, -8), (3, 4, -6))]
    L = np.concatenate([
        random_shapes(rng, 150, (-30, -1, -80), (30, 10, 9), radius=(0.01, 20.0)),
        random_shapes(rng, 40, (-500, -1, -2000), (500, 50, -100), radius=(5.0, 2000.0),
                      extent=(1.0, 500.0), length=(0.0, 500.0)),
        random_shapes(rng, 10, (-1, 2, 9), (1, 4, 11), radius=(1.0, 3000.0), extent=(1.0, 1e3))])
    scene = make_scene(L, meshes=meshes, size=(80, 48), camera=cam, max_depth=1e4)
    with Renderer(scene) as r:
        opts = dict(raster_variant=variant)
        hw, sw = _bits(r, L, opts), _bits(r, L, dict(opts, early_depth=False))
        assert np.array_equal(hw, sw), f"{int((sw & ~hw).astype(bool).sum())} words lose bits"
        assert hw.any()
        res = render_on(r, opts, techniques=["brute", "raster"])
        assert_exact(res, "depth precision")


def test_lights_behind_walls_mark_nothing(gl):
    """Lights behind a wall taller than the eye (their rectangles on screen, their volumes
    reaching no visible surface) set no bit; zbin's base tile (screen rectangles) still
    evaluates them, and a tile depth-bounds test keeps those whose tiles also see the far
    backdrop above the wall (counted as removed by occlusion alone)."""
    cam = Camera((0.0, 2.0, 0.0), (0.0, 2.0, -1.0), near=0.1, far=200.0)
    meshes = [box_mesh((-50, -1, -21), (50, 3, -20)), box_mesh((-200, -1, -61), (200, 60, -60)),
              box_mesh((-200, -1.1, -100), (200, -1, 10))]
    n = 40
    rng = np.random.default_rng(4)
    L = make_lights(n)
    L["position"] = np.column_stack([rng.uniform(-6, 6, n), rng.uniform(0, 2.5, n), rng.uniform(-28, -23, n)])
    L["radius"] = rng.uniform(0.3, 1.0, n)                # none reaches the walls or the floor
    res = render_all(make_scene(L, meshes=meshes, size=(64, 40), camera=cam), dict(zbin_variant=0),
                     techniques=["brute", "zbin", "raster"])       # base tile: rectangles alone
    assert_exact(res, "behind a wall")
    st = res["raster"].meta["stats"]
    assert st["visible_lights"] == n and st["raster_marks"] == 0
    assert st["unmarked_lights"] == n and 0 < st["occluded_lights"] <= n
    assert res["raster"].evaluated.sum() == 0 and res["zbin"].evaluated.sum() > 0


def test_variant_counters(gl):
    """Full-resolution fragments > MSAA fragments; compaction issues fewer atomics than one
    per marking fragment; the bits are a superset of what the pixel-exact stencil marks."""
    rng = np.random.default_rng(9)
    L = random_shapes(rng, 200, (-14, -1, -34), (14, 7, 6), radius=(1.0, 6.0))
    with Renderer(make_scene(L, size=(96, 64))) as r:
        st = {v: r.render(RASTER, 0, RASTER.resolve_options(dict(raster_variant=v))).meta["stats"]
              for v in range(4)}
        stencil = r.render(RASTER, 0, RASTER.resolve_options(dict(stencil=True))).meta["stats"]
    assert st[1]["raster_fragments"] < st[0]["raster_fragments"]
    assert st[0]["raster_atomics"] == st[0]["raster_pixel_marks"] > 0
    assert st[2]["raster_atomics"] < st[0]["raster_atomics"]
    assert st[3]["raster_atomics"] < st[1]["raster_atomics"]
    assert st[0]["raster_marks"] == st[2]["raster_marks"]           # compaction: same bits
    assert stencil["raster_marks"] <= st[0]["raster_marks"]


@pytest.mark.parametrize("cluster", [0, 1])
def test_the_stats_twin_counts_alike_with_and_without_native_waves(gl, monkeypatch, cluster):
    """The twin's counters take one atomic a subgroup on the native path (its ballot's
    lanes) and one a lane on the emulated one: the same counts in the variants without
    compaction (which needs the native path: without it its atomics are one a mark)."""
    rng = np.random.default_rng(9)
    L = random_shapes(rng, 200, (-14, -1, -34), (14, 7, 6), radius=(1.0, 6.0))
    keys = ("raster_fragments", "raster_atomics", "raster_pixel_marks", "raster_marks")

    def counts():
        with Renderer(make_scene(L, size=(96, 64))) as r:
            return [{k: r.render(RASTER, 0, RASTER.resolve_options(
                dict(raster_variant=v, cluster=cluster))).meta["stats"][k] for k in keys}
                for v in (0, 1)]
    native = counts()
    from app.pipeline import gl as glmod
    monkeypatch.setattr(glmod.Limits, "wave_define", property(lambda self: 0))
    emulated = counts()
    assert native == emulated and native[0]["raster_atomics"] > 0


def test_capture_heatmap_and_meta(gl, tmp_path):
    import json
    from app import capture
    capture.main(["--scene", "hangar", "--lights", "256", "--size", "64x36", "--technique", "raster",
                  "--raster-variant", "3", "--heatmap", str(tmp_path / "h.png"),
                  "--dump", str(tmp_path / "d.npz")])
    meta = json.loads(str(np.load(tmp_path / "d.npz")["meta"]))
    assert meta["technique"] == "raster" and meta["stats"]["variant"] == rs.VARIANTS[3]
    assert {"raster fill", "shade"} <= set(meta["gpu_ms"])
    assert (tmp_path / "h.png").stat().st_size > 0


@pytest.mark.parametrize("name", ["hangar"])      # (every builtin scene, default mode: test_exactness)
def test_builtin_scenes_every_mode(gl, name):
    """Builtin scenes with their own lights at 480x270, past llvmpipe's 64x64 bins: there an
    eye-inside proxy drawn later that covers a whole bin once made llvmpipe drop the bin's
    earlier fragments (cluster mode drawn to "none", whose colour renderbuffer llvmpipe took
    as overwritten; now a depth-only target)."""
    from scenes import load_scene
    scene = load_scene(name, seed=1)
    scene.resolution = (480, 270)
    with Renderer(scene) as r:
        ref = r.render(REGISTRY["brute"])          # brute takes none of the options
        for opts in (dict(cluster=True), dict(raster_variant=3), dict(stencil=True, zbin_variant=1)):
            res = render_on(r, dict(opts, raster_stats=False), techniques=["raster"], reference=ref)
            assert_exact(res, f"{name} {opts}")


# ---------------------------------------------------------------------------- cluster depth bound

@pytest.mark.parametrize("variant", [0, 1, 3])
def test_cluster_depth_bound_keeps_every_read_cluster(gl, variant):
    """The bound (cluster 1) against none (cluster 2): the same bits in every cluster a pixel
    reads, so the same evaluations; fewer marks and atomics (the clusters in front of and
    behind each tile's surfaces, and the tiles with no geometry: sky above the backdrop)."""
    rng = np.random.default_rng(20 + variant)
    L = np.concatenate([random_shapes(rng, 300, (-14, -1, -34), (14, 7, 6)),
                        _hard_lights(rng, np.asarray(CAMERA.position), n_eye=4, n_near=6)])
    cam = Camera(CAMERA.position, (0.0, 3.0, -20.0), near=0.1, far=80.0)   # sky in the top rows
    with Renderer(make_scene(L, size=(96, 64), camera=cam)) as r:
        got = {}
        for cluster in (1, 2):
            res = r.render(RASTER, 0, RASTER.resolve_options(dict(cluster=cluster, raster_variant=variant,
                                                                  cluster_tile=8)))
            got[cluster] = (res, r.read("raster_bits").copy())
        (b, bits_b), (u, bits_u) = got[1], got[2]
        g = b.build.grid
        words = b.meta["stats"]["words_per_tile"]
        read = np.unique(b.cell[b.depth > 0])
        assert np.array_equal(b.cell, u.cell)
        rows = lambda bits: bits.view(np.uint32).reshape(g.cells, words)[read]
        assert np.array_equal(rows(bits_b), rows(bits_u)), "a read cluster lost or gained a bit"
        assert np.array_equal(b.evaluated, u.evaluated)
        sb, su = b.meta["stats"], u.meta["stats"]
        assert sb["raster_marks"] < su["raster_marks"] and sb["raster_atomics"] < su["raster_atomics"]
        assert "raster tile depth" in b.meta["gpu_ms"] and "raster tile depth" not in u.meta["gpu_ms"]
        res = render_on(r, dict(cluster=1, raster_variant=variant), techniques=["brute", "raster"])
        assert_exact(res, f"cluster depth bound, variant {variant}")


def test_cluster_depth_pass_figures(gl):
    """The cluster mode's timed passes have their figures for the cost model: the tile depth
    pass (bounded), the proxies; names as the timed passes'."""
    from app.model import predict
    from scenes import load_scene
    sc = load_scene("arena", lights=512, seed=2)
    with Renderer(sc, (72, 48)) as r:
        for cluster, tile in ((1, 32), (1, 12), (2, 32)):
            res = r.render(RASTER, 0, dict(cluster=cluster, cluster_tile=tile))
            timed = {k.split(" (")[0] for k in res.meta["gpu_ms"] if k != "gbuffer"}
            for width, passes in predict.frame_figures(r, RASTER, res, dict(cluster=cluster,
                                                                             cluster_tile=tile)).items():
                assert set(passes) - {predict.SHADE} <= timed | {"raster proxies"}, (cluster, passes.keys())
                assert ("raster tile depth" in passes) == (cluster == 1)
                if cluster == 1:
                    f = passes["raster tile depth"]
                    assert f.loop("depth")["lanes"] == 72 * 48
                    assert (f.shared_atomics > 0) == (tile % 8 == 0)


# ---------------------------------------------------------------------------- one rule for options

@pytest.mark.parametrize("values, flag, mode", [
    (dict(cluster=1, stencil=True), "--stencil", "cluster mode (--cluster 1)"),
    (dict(cluster=2, zbin_variant=0), "--zbin-variant 0", "cluster mode (--cluster 2)"),
    (dict(cluster=1, zbins=64), "--zbins 64", "cluster mode"),
    (dict(cluster=1, printed_mask=True), "--printed-mask", "cluster mode"),
    (dict(cluster=1, native_wave=True), "--native-wave", "cluster mode"),
    (dict(cluster=1, bit_tile=16), "--bit-tile 16", "cluster mode"),
    (dict(cluster=1, early_depth=False), "--no-early-depth", "cluster mode"),
    (dict(cluster_tile=16), "--cluster-tile 16", "tile mode (--cluster 0)"),
    (dict(cluster_slices=24), "--cluster-slices 24", "tile mode"),
    (dict(zbin_variant=0, zbins=64), "--zbins 64", "without z-bins (--zbin-variant 0)"),
    (dict(zbin_variant=2, printed_mask=True), "--printed-mask", "without z-bins (--zbin-variant 2)"),
])
def test_an_option_the_mode_ignores_is_refused(values, flag, mode):
    from app.errors import UserError
    with pytest.raises(UserError) as ei:
        RASTER.resolve_options(values)
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"raster: {flag} is ignored ") and mode in msg, msg
    with pytest.raises(UserError, match="is ignored"):              # however it is made
        RASTER.Options(**values)
    base = {k: v for k, v in values.items() if k in ("cluster", "zbin_variant")}
    with pytest.raises(UserError, match="is ignored"):
        RASTER.resolve_options(base).with_(**values)


def test_the_modes_take_their_own_options():
    """Each mode takes what it reads, defaults of the others included; every raster option
    is read by some mode; another technique's option is refused as before."""
    from app.errors import UserError
    ok = [dict(cluster=1, raster_variant=3, cluster_tile=8, cluster_slices=24, bit_budget_mib=8.0),
          dict(cluster=2, stencil=False, zbin_variant=3, native_wave=False, raster_stats=False),
          dict(stencil=True, zbin_variant=1, zbins=64, printed_mask=True, native_wave=True,
               bit_tile=16, early_depth=False),
          dict(zbin_variant=0, zbins=RASTER.Options().zbins)]
    for values in ok:
        assert RASTER.resolve_options(values).as_dict() == dict(RASTER.Options().as_dict(), **values)
    modes = [RASTER.Options(cluster=c, zbin_variant=z) for c in (0, 1, 2) for z in (0, 3) if not (c and z != 3)]
    modes.append(RASTER.Options(stochastic=4))        # the draw's seed and frame: with a budget
    read = set().union(*(set(RASTER.Options.names()) - set(o.ignored()) for o in modes))
    assert read == set(RASTER.Options.names())
    with pytest.raises(UserError, match="--tile is not an option of this technique"):
        RASTER.resolve_options({"tile": 16})


def test_no_option_study_trips_over_the_rule():
    """The benchmark's studies are the defaults plus one option (app.bench.plan): every
    declared study value of every technique makes valid options."""
    for t in REGISTRY.values():
        for spec in t.Options.specs():
            for v in spec.study:
                assert getattr(t.Options().with_(**{spec.name: v}), spec.name) == v, (t.name, spec.name)


def test_capture_refuses_an_ignored_option_in_one_line():
    import subprocess
    import sys
    from pathlib import Path
    p = subprocess.run([sys.executable, "-m", "app.capture", "--scene", "arena", "--technique", "raster",
                        "--cluster", "1", "--stencil"], cwd=Path(__file__).resolve().parents[3],
                       capture_output=True, text=True, timeout=120)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, p.stderr
    assert "--stencil is ignored in cluster mode (--cluster 1)" in lines[0] and "raster" in lines[0]


# ---------------------------------------------------------------------------- the contention case

def test_contention_scene_variants(gl):
    """The slides' "3 x full screen lights": every pixel marks the three lights, so the plain
    rasterizer issues at least three atomics a pixel, all of a tile's on the same words;
    MSAA draws a quarter of the fragments, compaction merges a subgroup's atomics; exact."""
    from scenes import load_scene
    scene = load_scene("contention")
    size = (96, 54)
    with Renderer(scene, size) as r:
        st = {}
        ref = r.render(REGISTRY["brute"])
        for v in range(4):
            res = render_on(r, dict(raster_variant=v), techniques=["raster"], reference=ref)
            assert_exact(res, f"contention variant {v}")
            assert (res["brute"].contrib_count[res["brute"].depth > 0] >= 3).all()
            st[v] = res["raster"].meta["stats"]
    px = size[0] * size[1]
    assert st[0]["raster_atomics"] == st[0]["raster_pixel_marks"] >= 3 * px
    assert st[1]["raster_fragments"] < 0.5 * st[0]["raster_fragments"]
    assert st[2]["raster_atomics"] < 0.5 * st[0]["raster_atomics"]
    assert st[3]["raster_atomics"] < st[1]["raster_atomics"] and st[3]["raster_atomics"] < st[2]["raster_atomics"]


def test_notes_set_the_slides_tables_beside_the_run(gl):
    """raster's report notes: the slides' tile rasterizer table beside the contention scene's
    atomics (rendered there, at the slides' 240x135 tiles) and the variant study's rows; the
    cluster study's waste with and without the depth bound; the same text twice."""
    import json
    stats = lambda a, m, t: json.dumps({"raster_atomics": a, "raster_marks": m, "bit_tile_used": t})
    row = lambda study, **kw: dict(dict(study=study, scene="arena", lights=4096.0, width=64.0, height=36.0,
                                        gpu_cull_ms=2.0, evaluated_pp=4.0, waste=2.0, stats=stats(90, 9, 8)), **kw)
    rows = [row("raster_variant", raster_variant=float(v), gpu_cull_ms=2.0 - 0.25 * v) for v in range(4)]
    rows += [row("cluster", cluster=float(c), evaluated_pp=(4.5, 17.0, 17.0)[c], waste=(2.4, 8.6, 8.6)[c],
                 gpu_cull_ms=(1.0, 3.0, 4.0)[c], stats=stats((900, 500, 700)[c], (40, 70, 90)[c], (8, 32, 32)[c]))
             for c in range(3)]
    title, text = parts.report_notes(RASTER, rows)
    assert text == parts.report_notes(RASTER, rows)[1]
    assert "| atomic + compaction + 4xMSAA | 0.10 ms (7%) | " in text and "1920x1080: 240x135 tiles" in text
    line = next(l for l in text.splitlines() if l.startswith("| atomic |"))
    assert int(line.split("|")[3].replace(",", "")) >= 3 * 1920 * 1080       # every pixel, three lights
    assert "tiles evaluate 4.5 lights a pixel" in text and "17 lights a pixel with the depth bound" in text
    assert "leaves the evaluations as they are" in text and "500 atomics against 700" in text
    assert "32 px clusters against 8 px tiles" in text


def test_occluded_lights_count_equals_the_per_light_test():
    """The unmarked lights a tile depth-bounds test would keep (meta occluded_lights), counted
    over every (light, tile) pair at once in steps, against the plain per-light test: random
    grids, rectangles up to the whole grid, steps from one pair to all."""
    from app.techniques.raster.counters import kept_by_tile_depth
    rng = np.random.default_rng(1)
    for _ in range(100):
        ty, tx = (int(v) for v in rng.integers(1, 30, 2))
        covered = rng.random((ty, tx)) < 0.7
        lo = rng.uniform(0, 50, (ty, tx)).astype(np.float32)
        hi = lo + rng.uniform(0, 20, (ty, tx)).astype(np.float32)
        m = int(rng.integers(0, 60))
        x0, y0 = rng.integers(0, tx, m), rng.integers(0, ty, m)
        x1, y1 = np.minimum(x0 + rng.integers(0, tx, m), tx - 1), np.minimum(y0 + rng.integers(0, ty, m), ty - 1)
        boxes = np.column_stack([x0, x1, y0, y1]).astype(np.int32)
        dl = rng.uniform(0, 60, m).astype(np.float32)
        dh = dl + rng.uniform(0, 10, m).astype(np.float32)
        want = sum(bool((covered[sl] & (lo[sl] <= dh[i]) & (hi[sl] >= dl[i])).any())
                   for i in range(m) for sl in [np.s_[y0[i]:y1[i] + 1, x0[i]:x1[i] + 1]])
        for step in (1, 7, 1 << 22):
            assert kept_by_tile_depth(boxes, dl, dh, covered, lo, hi, step) == want
