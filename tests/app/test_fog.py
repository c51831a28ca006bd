"""Volumetric fog through the renderer (app/pipeline/fog.py, glsl/fog_*.comp): clustered's
froxel sets equal brute's on the builtin fog scene and the hard cases, the GPU's figures are
the CPU sets', the passes' in-scatter and transmittance equal float64 evaluations of their
formulas, a scene without fog runs no fog step, and capture's fog flags, dump and --check."""
import math

import numpy as np
import pytest

from app.errors import UserError
from app.pipeline.fog import FogOptions
from cpu_prep import froxels as fx
from scenes import Camera, Fog, load_scene, make_lights
from scenes.model import LIGHT_SPOT

from tests.helpers import make_scene, random_shapes

SIZE = (96, 54)


def render(scene, technique, fo=None, size=SIZE):
    from app.pipeline.renderer import Renderer
    from app.techniques import get
    r = Renderer(scene, size)
    r.fog_options = fo
    return r, r.render(get(technique))


def same_froxels(a, b) -> bool:
    return (a.froxel_count is not None and np.array_equal(a.froxel_count, b.froxel_count)
            and np.array_equal(a.froxel_hash, b.froxel_hash))


SERVING = ("clustered", "tree", "hybrid")


@pytest.mark.parametrize("technique", SERVING)
@pytest.mark.parametrize("grid", [(24, 12, 16), "matched"])
def test_cell_techniques_serve_brute_froxel_sets_on_the_fog_hangar(gl, grid, technique):
    scene = load_scene("hangar-fog", 200)
    _, c = render(scene, technique, FogOptions(grid))
    _, b = render(scene, "brute", FogOptions(c.froxel_grid))
    assert same_froxels(c, b) and c.froxel_count.sum() > c.froxel_count.size
    assert np.array_equal(c.contrib_hash, b.contrib_hash)        # the pixels stay exact
    count, hashes = fx.set_figures(b.froxel_sets, b.build.lights.ids, b.froxel_grid.dims)
    assert np.array_equal(count, b.froxel_count) and np.array_equal(hashes, b.froxel_hash)
    stats = c.meta["stats"]
    assert stats["froxel_unneeded_mean"] >= 0 and "fog" in c.meta
    if grid == "matched":
        assert stats["froxel_unneeded_mean"] == stats["froxel_unneeded_mean_matched"]
    assert set(c.meta["gpu_ms"]) >= {"fog_light", "fog_march", "fog_composite"}
    assert c.meta["fog"]["froxel_source"] == ("cells" if technique == "clustered" else "trees")


def hard_scene(fog):
    rng = np.random.default_rng(7)
    cam = Camera((0.0, 2.0, 0.0), (0.0, 2.0, -1.0), near=0.1, far=200.0)
    shapes = random_shapes(rng, 120, (-20, -2, -45), (20, 10, 3))
    odd = make_lights(4)
    odd["position"] = [(0.1, 2.0, 0.2), (0.0, 2.0, -0.05), (1.0, 2.0, -(fog.far + 3.0)),
                       (-1.0, 2.5, -(fog.far + 0.5))]
    odd["radius"] = [3.0, 0.5, 2.0, 2.0]              # camera inside; across near; past far; straddling
    spot = make_lights(1)
    spot["type"], spot["position"], spot["radius"] = LIGHT_SPOT, (0.0, 2.0, 0.5), 6.0
    spot["direction"], spot["cos_outer"], spot["cos_inner"] = (0.0, 0.0, -1.0), math.cos(0.4), 1.0
    scene = make_scene(np.concatenate([odd, spot, shapes]), size=SIZE, camera=cam)
    scene.fog = fog
    return scene


@pytest.mark.parametrize("technique", SERVING)
def test_a_linear_depth_grid_is_served_exactly_too(gl, technique):
    scene = load_scene("hangar-fog", 200)
    _, c = render(scene, technique, FogOptions((24, 12, 16), depth="linear"))
    zs = c.froxel_grid.zs
    np.testing.assert_allclose(np.diff(zs), (zs[-1] - zs[0]) / 16)     # even slices
    _, e = render(scene, technique, FogOptions((24, 12, 16)))
    assert not np.allclose(e.froxel_grid.zs, zs) and c.meta["fog"]["depth"] == "linear"
    _, b = render(scene, "brute", FogOptions(c.froxel_grid))
    assert same_froxels(c, b) and c.froxel_count.sum() > c.froxel_count.size


@pytest.mark.parametrize("technique", SERVING)
def test_cell_techniques_serve_brute_froxel_sets_on_the_hard_cases(gl, technique):
    scene = hard_scene(Fog(0.04, (0.9, 0.8, 0.7), 30.0, -0.3))
    _, c = render(scene, technique, FogOptions((13, 7, 11), 8))
    _, b = render(scene, "brute", FogOptions(c.froxel_grid, 8))
    assert same_froxels(c, b)
    assert np.array_equal(c.image, b.image)       # the same lights in the same order


def test_transmittance_without_scattering(gl):
    """Albedo 0: no in-scatter, each pixel its clear colour times exp(-density * path from
    the near plane), the path on the pixel's own ray (one froxel column a pixel)."""
    density, far = 0.05, 40.0
    scene = hard_scene(Fog(density, (0.0, 0.0, 0.0), far, 0.0))
    w, h = SIZE
    r, fogged = render(scene, "brute", FogOptions((w, h, 9)))
    scene.fog = None
    clear = r.render(__import__("app.techniques", fromlist=["get"]).get("brute"))
    depth = fogged.depth.astype(np.float64)
    tx, ty = fogged.froxel_grid.tan_x, fogged.froxel_grid.tan_y
    u = (2 * (np.arange(w) + 0.5) / w - 1)[None, :]
    v = (2 * (np.arange(h) + 0.5) / h - 1)[::-1, None]
    stretch = np.sqrt(1 + (u * tx) ** 2 + (v * ty) ** 2)
    reach = np.where((depth > 0) & (depth < far), depth, far)
    want = clear.image * np.exp(-density * (reach - scene.camera.near) * stretch)[..., None]
    assert np.allclose(fogged.image, want, rtol=2e-4, atol=1e-7)
    assert (fogged.image < clear.image - 1e-6).any()


def hg(cos_t, g):
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cos_t) ** 1.5)


@pytest.mark.parametrize("g", [0.0, 0.6])
def test_inscatter_at_froxel_centres_in_float64(gl, g):
    lights = make_lights(2)
    lights["position"] = [(1.0, 2.5, -6.0), (-2.0, 1.5, -11.0)]
    lights["radius"] = [4.0, 6.0]
    lights["color"] = [(1.0, 0.5, 0.25), (0.2, 0.4, 1.0)]
    lights["intensity"] = [3.0, 5.0]
    fog = Fog(0.03, (0.8, 0.9, 1.0), 25.0, g)
    scene = make_scene(lights, size=SIZE, camera=Camera((0.0, 2.0, 0.0), (0.0, 2.0, -1.0)))
    scene.fog = fog
    r, res = render(scene, "brute", FogOptions((12, 6, 10)))
    got = r.read("froxel_light").reshape(-1, 4)[:, :3].astype(np.float64)
    fg, gpu = res.froxel_grid, res.build.lights.gpu
    us, vs = fg.ndc()
    want = np.zeros_like(got)
    W, H, D = fg.dims
    for k in range(D):
        for j in range(H):
            for i in range(W):
                z = 0.5 * (fg.zs[k] + fg.zs[k + 1])
                P = np.array([0.5 * (us[i] + us[i + 1]) * fg.tan_x * z,
                              0.5 * (vs[j] + vs[j + 1]) * fg.tan_y * z, -z])
                for L in gpu:
                    d = P - L["pos_radius"][:3]
                    d2, rad = d @ d, float(L["pos_radius"][3])
                    if d2 >= rad * rad:
                        continue
                    win = (1 - (d2 / rad ** 2) ** 2) ** 2 / (d2 + 1)
                    l = -d / math.sqrt(d2)
                    want[(k * H + j) * W + i] += (L["color_cos_inner"][:3] * win
                                                  * hg(l @ P / np.linalg.norm(P), g))
    want *= np.asarray(fog.albedo) * fog.density
    assert want.max() > 0 and np.allclose(got, want, rtol=1e-4, atol=1e-7 * want.max())


def test_a_scene_without_fog_runs_no_fog_step(gl):
    _, res = render(load_scene("hangar", 100), "clustered")
    assert res.froxel_count is None and "fog" not in res.meta
    assert not any(k.startswith("fog") for k in res.meta["gpu_ms"])
    assert not any(k.startswith("froxel") for k in res.meta["stats"])


def test_capture_fog_flags_dump_and_check(gl, tmp_path, capsys):
    from app import capture
    from app.dump import read_dump
    base = ["--scene", "hangar-fog", "--lights", "150", "--size", "64x36"]
    capture.main(base + ["--technique", "clustered", "--froxels", "16x9x12",
                         "--dump", str(tmp_path / "f.npz"), "--check", str(tmp_path / "chk")])
    err = capsys.readouterr().err
    assert "every froxel" in err
    d = read_dump(tmp_path / "f.npz")
    assert d["froxel_count"].shape == d["froxel_hash"].shape == (12, 9, 16)
    assert d["froxel_count"].dtype == np.uint32 and "matched grid" in d["meta"]["fog"]["mismatch"]
    with pytest.raises(SystemExit) as e:           # the shortcut's sets are not brute's
        capture.main(base + ["--technique", "clustered", "--froxels", "16x9x12",
                             "--froxel-lookup", "centre", "--check", str(tmp_path / "chk")])
    assert e.value.code == 1 and "not exact: froxels" in capsys.readouterr().err
    for argv, words in ((["--technique", "tiled"], "does not serve froxels"),
                        (["--technique", "brute", "--size", "4096x2048", "--froxels", "4096x2048x1"],
                         "budget"),
                        (["--technique", "brute", "--froxels", "65x9x9"], "W and H"),
                        (["--technique", "brute", "--froxels", "matched"], "grid of cells"),
                        (["--technique", "tree", "--froxel-lookup", "centre"], "cell lists"),
                        (["--technique", "clustered", "--build", "gpu"], "--build"),
                        (["--technique", "brute", "--froxels", "matched", "--froxel-depth",
                          "linear"], "technique's own slices")):
        with pytest.raises(UserError, match=words):
            capture.main(base + argv)
    with pytest.raises(UserError, match="no fog"):
        capture.main(["--scene", "hangar", "--size", "64x36", "--froxels", "8x8x8"])


def test_a_froxel_past_the_drivers_loop_budget_is_refused(gl):
    from app.pipeline import gl as glmod
    budget = glmod.limits().loop_budget
    if budget is None:
        pytest.skip("this driver runs any loop to its end")
    n = budget // 9 + 1                       # at 8 samples: (8 + 1) loops of n lights a froxel
    lights = make_lights(n)
    lights["position"] = (0.0, 2.0, -8.0)
    lights["radius"] = 50.0
    scene = make_scene(lights, size=(32, 18), camera=Camera((0.0, 2.0, 0.0), (0.0, 2.0, -1.0)))
    scene.fog = Fog(0.05, (0.9, 0.9, 0.9), 20.0, 0.0)
    with pytest.raises(UserError, match="loop budget"):
        render(scene, "clustered", FogOptions((2, 2, 2), 8), size=(32, 18))
    _, ok = render(scene, "clustered", FogOptions((2, 2, 2), 1), size=(32, 18))
    assert int(ok.froxel_count.max()) == n    # one sample: within it, every light met


def test_a_still_frame_takes_its_froxel_sets_from_the_cache(gl):
    from app.pipeline.fog import FroxelSetCache
    from app.pipeline.renderer import Renderer
    from app.techniques import get
    scene = load_scene("hangar-fog", 200)
    r = Renderer(scene, SIZE)
    r.fog_options = FogOptions((24, 12, 16))
    r.froxel_cache = FroxelSetCache()
    first, still = r.render(get("clustered")), r.render(get("clustered"))
    assert first.meta["fog"]["froxel_sets_reused"] is False
    assert still.meta["fog"]["froxel_sets_reused"] is True and same_froxels(first, still)
    assert still.meta["stats"] == first.meta["stats"]
    tree = r.render(get("tree"))                          # another technique: its own sets
    assert tree.meta["fog"]["froxel_sets_reused"] is False and same_froxels(tree, first)
    moved = r.render(get("clustered"), frame=9)           # the camera moved: built again
    _, fresh = render(scene, "clustered", FogOptions((24, 12, 16)))
    assert moved.meta["fog"]["froxel_sets_reused"] is False
    r2 = Renderer(scene, SIZE)
    r2.fog_options = FogOptions((24, 12, 16))
    assert same_froxels(moved, r2.render(get("clustered"), frame=9))
    assert not same_froxels(moved, first)
    assert "froxel_sets_reused" not in fresh.meta["fog"]   # no cache: every frame built
