"""Transparent layers (app/pipeline/transparent.py): depth-peeled layers in front of the
opaque surface, each shaded by the technique's own structure and held to brute's at every
pixel; composited over the opaque image back to front; a scene without transparent surfaces
renders as it always did."""
from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

from app.dump import FIELDS, LAYER_FIELDS, read_dump, write_dump
from app.exactness import check
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep.camera import look_at
from scenes import load_scene
from scenes.geometry import box_mesh
from scenes.model import Camera, Mesh
from tests.helpers import BUILTIN_LIGHTS, affects64, assert_exact, contract_figures, make_scene, random_lights, render_on

SIZE = (96, 64)
# Straight down -z from 10 m in front of a wall at z = -10: the wall is every tile's opaque
# surface, 20 m deep, so each tile's opaque depth range is about [20, 20].
CAMERA = Camera((0.0, 2.0, 10.0), (0.0, 2.0, 0.0), near=0.1, far=100.0)
WALL = ((-40.0, -20.0, -10.2), (40.0, 30.0, -10.0))


def quad(x0, x1, y0, y1, z, opacity, albedo=(0.6, 0.8, 0.9)) -> Mesh:
    """One transparent layer: a rectangle facing the camera at z."""
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], np.float32)
    return Mesh(v, np.array([[0, 1, 2], [0, 2, 3]], np.int32), albedo, opacity=opacity)


def wall() -> Mesh:
    return box_mesh(*WALL, (0.7, 0.7, 0.7))


# The pane at z = 0 (10 m deep: nearer than every tile's opaque minimum) crosses the 48 px tiles'
# edges at the image's centre; a thin glass box behind it (two layers, 15 m) overlaps it.
def pane() -> Mesh:
    return quad(-1.5, 2.5, -0.6, 5.5, 0.0, 0.4)


def glass_box() -> Mesh:
    m = box_mesh((0.5, 0.5, -5.1), (4.0, 3.0, -5.0), (0.9, 0.7, 0.5))
    m.opacity, m.roughness = 0.5, 0.2
    return m


def hard_lights():
    """Lights between the pane and the wall that reach the pane and not the wall (what tiles
    bounded by the opaque depth would miss), lights in front of the pane, and random ones."""
    rng = np.random.default_rng(11)
    between = random_lights(rng, 40, (-3, -1, -4.5), (4, 5, -0.5), radius=(0.6, 3.0), spot_share=0.3)
    front = random_lights(rng, 20, (-3, -1, 0.5), (4, 5, 4), radius=(0.8, 4.0), spot_share=0.3)
    rest = random_lights(rng, 60, (-12, -4, -12), (12, 8, 6), radius=(0.5, 6.0))
    return np.concatenate([between, front, rest])


def hard_scene(extra=(), layers=None):
    return make_scene(hard_lights(), [wall(), *extra], size=SIZE, camera=CAMERA, max_depth=60.0)


@pytest.fixture(scope="module")
def hard(gl):
    """(scene, renderer, brute's frame) of the hard case, the renderer open."""
    scene = hard_scene((pane(), glass_box()))
    with Renderer(scene) as r:
        yield scene, r, r.render(REGISTRY["brute"])


def layer_oracle(renderer, lights, camera):
    """Per layer (count, hash, near a volume's boundary, inside) in float64 at the layers'
    stored positions (tests.helpers.affects64), image order."""
    pos = renderer.transparent.read_positions().astype(np.float64)
    view = look_at(camera.position, camera.target, camera.up)
    out = []
    for p in pos:
        covered = p[..., 3].reshape(-1, 1) > 0
        inside, near = affects64(p[..., :3].reshape(-1, 3), lights, view)
        inside &= covered
        count, hashes = contract_figures(inside)
        out.append((count.reshape(p.shape[:2]), hashes.reshape(p.shape[:2]),
                    (near & covered).any(1).reshape(p.shape[:2]), inside))
    return out


def test_the_layers_are_peeled_in_depth_order(hard):
    scene, r, ref = hard
    d = ref.depth_t
    assert d.shape == (4,) + SIZE[::-1] and ref.meta["transparent"]["layers"] == 3
    assert ref.meta["transparent"]["fragments"] == [int(c) for c in (d > 0).sum((1, 2))]
    assert (d[3] == 0).all() and (d[2] > 0).sum() > 50
    both = (d[:-1] > 0) & (d[1:] > 0)
    assert (d[:-1][both] < d[1:][both]).all()
    assert ((d[1:] > 0) <= (d[:-1] > 0)).all()            # a layer only where the one before has one
    covered = d > 0
    assert (d[covered] < ref.depth[None].repeat(4, 0)[covered]).all()     # in front of the wall
    for k in range(4):
        assert (ref.contrib_count_t[k][~covered[k]] == 0).all()
        assert (ref.contrib_hash_t[k][~covered[k]] == 0).all()


def test_brute_layers_match_the_float64_oracle(hard):
    scene, r, ref = hard
    lit = 0
    for k, (count, hashes, near, _) in enumerate(layer_oracle(r, scene.lights, scene.camera)):
        ok = ~near
        assert np.array_equal(ref.contrib_count_t[k][ok], count[ok]), k
        assert np.array_equal(ref.contrib_hash_t[k][ok], hashes[ok]), k
        lit += int(count.sum())
    assert lit > 500


def test_the_hard_case_is_hard(hard):
    """The pane is nearer than every tile's opaque minimum depth, crosses tile edges, and is
    lit by lights that reach no opaque pixel (they lie between the pane and the wall)."""
    scene, r, ref = hard
    pane_px = np.abs(ref.depth_t[0] - 10.0) < 1e-3
    assert pane_px.sum() > 200
    rows, cols = np.nonzero(pane_px)
    # across the tile edges at x = 48 and at GL row 48 (image row 16: GL rows count from the bottom)
    assert cols.min() < 48 <= cols.max() and rows.min() < SIZE[1] - 48 <= rows.max()
    assert ref.depth[ref.depth > 0].min() > 19.0          # every tile's opaque minimum: the wall
    pos = np.flip(r.gbuffer.read_position(), 0).astype(np.float64).reshape(-1, 4)
    view = look_at(CAMERA.position, CAMERA.target, CAMERA.up)
    opaque_inside, _ = affects64(pos[:, :3], scene.lights, view)
    lit_opaque = opaque_inside[pos[:, 3] > 0].any(0)
    pane_inside = layer_oracle(r, scene.lights, scene.camera)[0][3][pane_px.reshape(-1)].any(0)
    assert (pane_inside & ~lit_opaque).sum() >= 5


def test_every_technique_is_exact_on_the_layers_of_the_hard_case(hard):
    scene, r, ref = hard
    results = render_on(r, techniques=[n for n in REGISTRY if n != "brute"], reference=ref)
    assert_exact(results, "hard case")
    for name, res in results.items():
        assert res.contrib_count_t.shape == ref.contrib_count_t.shape, name


def test_every_technique_is_exact_on_the_layers_of_city_glass(gl):
    scene = load_scene("city-glass", lights=BUILTIN_LIGHTS)
    scene.resolution = (96, 54)
    with Renderer(scene) as r:
        results = render_on(r)
    ref = results["brute"]
    assert ref.meta["transparent"]["layers"] >= 3 and ref.contrib_count_t.sum() > 100
    assert_exact(results, "city-glass")


def test_a_scene_without_transparent_surfaces_is_unchanged(gl, tmp_path):
    """No layers, no layer fields in the frame, meta or dump; and a transparent pane hidden
    behind the wall leaves every output bit-identical to the scene without it."""
    plain = hard_scene()
    hidden = hard_scene((quad(-2, 2, 0, 3, -12.0, 0.5),))
    with Renderer(plain) as r:
        assert r.transparent is None
        a = r.render(REGISTRY["clustered"])
        soup = r.gbuffer.soup.copy()
    assert all(getattr(a, k) is None for k in LAYER_FIELDS) and "transparent" not in a.meta
    write_dump(tmp_path / "a.npz", a)
    with np.load(tmp_path / "a.npz") as d:
        assert sorted(d.files) == sorted(FIELDS + ("meta",))
    with Renderer(hidden) as r:
        assert np.array_equal(r.gbuffer.soup, soup)
        b = r.render(REGISTRY["clustered"])
    assert b.meta["transparent"]["layers"] == 0 and (b.depth_t == 0).all()
    for k in ("image", "depth", "evaluated", "contrib_count", "contrib_hash"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k


def test_the_layers_are_composited_over_the_opaque_image_back_to_front(gl):
    """image = a1 L1 + (1 - a1) (a2 L2 + (1 - a2) O), each L the surface's radiance where it
    is the opaque surface, O the wall's."""
    near, far = (-1.5, 2.5, -0.6, 3.9, 0.0), (1.0, 7.0, 0.5, 3.0, -5.0)
    a1, a2 = 0.4, 0.7
    frames = {}
    for key, meshes in {"O": (), "L1": (quad(*near, 1.0),), "L2": (quad(*far, 1.0),),
                        "C": (quad(*near, a1), quad(*far, a2))}.items():
        with Renderer(hard_scene(meshes)) as r:
            frames[key] = r.render(REGISTRY["brute"])
    O, L1, L2, C = (frames[k].image.astype(np.float64) for k in ("O", "L1", "L2", "C"))
    d = frames["C"].depth_t
    cover1 = np.abs(d[0] - 10.0) < 1e-3                          # the near quad, layer 0
    cover2 = (np.abs(d[:2] - 15.0) < 1e-3).any(0)                # the far one, layer 0 or 1
    want = np.where(cover2[..., None], a2 * L2 + (1 - a2) * O, O)
    want = np.where(cover1[..., None], a1 * L1 + (1 - a1) * want, want)
    assert cover1.sum() > 200 and (cover1 & cover2).sum() > 50 and (cover2 & ~cover1).sum() > 50
    assert np.abs(L1 - O)[cover1].max() > 0.1 * O.max()         # the quads are lit
    assert np.allclose(C, want, rtol=1e-5, atol=1e-6 * O.max())
    assert np.array_equal(C[~(cover1 | cover2)], O[~(cover1 | cover2)])


def test_at_most_l_layers_are_kept_the_nearest(gl):
    scene = hard_scene((pane(), glass_box()))
    with Renderer(scene, transparent_layers=2) as r:
        two = r.render(REGISTRY["brute"])
    with Renderer(scene, transparent_layers=4) as r:
        four = r.render(REGISTRY["brute"])
    assert two.contrib_count_t.shape == (2,) + SIZE[::-1] and two.meta["transparent"]["max_layers"] == 2
    for k in LAYER_FIELDS:
        assert np.array_equal(getattr(two, k), getattr(four, k)[:2]), k
    assert (four.depth_t[2] > 0).any()


def test_the_exactness_check_names_a_differing_layer(hard):
    scene, r, ref = hard
    res = r.render(REGISTRY["clustered"])
    assert check(res, ref) is None
    rows, cols = np.nonzero(res.depth_t[1])
    res.contrib_hash_t = res.contrib_hash_t.copy()
    res.contrib_hash_t[1, rows[0], cols[0]] ^= 1
    m = check(res, ref)
    assert m is not None and "transparent layer 1" in m.message()
    assert m.first == (int(cols[0]), int(rows[0])) and m.pixels == 1
    from app.bench.measure import mismatches           # a benchmark row counts it too
    assert mismatches(res, ref) == (0, 1)


def test_capture_dumps_the_layers_and_checks_them(gl, tmp_path):
    """A scene file with `opacity` through `python -m app.capture`: the dump's layer arrays
    of shape (L, H, W), and --check holds every layer to brute's."""
    from app import capture, cli
    pane_entry = {"box": {"min": [-1.5, -0.6, -0.05], "max": [2.5, 3.9, 0.05]},
                  "albedo": [0.6, 0.8, 0.9], "opacity": 0.4}
    doc = {"resolution": [48, 32],
           "camera": {"position": [0, 2, 10], "target": [0, 2, 0], "far": 100},
           "geometry": [{"box": {"min": list(WALL[0]), "max": list(WALL[1])}}, pane_entry],
           "lights": [{"type": "point", "position": [0.5, 1.5, -1.0], "radius": 2.0},
                      {"type": "point", "position": [0.5, 1.5, 3.0], "radius": 5.0}]}
    (tmp_path / "s.json").write_text(json.dumps(doc))
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        cli.run_main(lambda: capture.main(["--scene", str(tmp_path / "s.json"), "--technique", "tiled",
                                           "--transparent-layers", "3", "--dump", str(tmp_path / "d.npz"),
                                           "--check", str(tmp_path / "check")]))
    assert "exact" in err.getvalue() and "not exact" not in err.getvalue()
    d = read_dump(tmp_path / "d.npz")
    assert d["contrib_count_t"].shape == (3, 32, 48) and d["contrib_hash_t"].dtype == np.uint32
    assert d["depth_t"].dtype == np.float32 and d["meta"]["transparent"]["max_layers"] == 3
    assert (d["contrib_count_t"][0] > 0).sum() > 20 and (d["contrib_count_t"][2] == 0).all()
    printed = json.loads(out.getvalue())["transparent"]
    assert printed["layers"] == 2 and printed["fragments"] == d["meta"]["transparent"]["fragments"]


def test_a_capped_frame_is_held_to_brute_without_the_dropped_lights_on_its_layers(hard):
    """A light-cap policy's frame (app.exactness's intended loss): its layers too equal brute's
    rendered without the lights it dropped, and a layer that differs beyond them fails."""
    from app.exactness import IntendedLoss
    from cpu_prep import caps
    from tests.helpers import options
    scene, r, ref = hard
    opts = options("clustered", cap_policy=caps.NAMES.index("urp-16"))
    res = r.render(REGISTRY["clustered"], opts=opts)
    assert res.meta["stats"]["capped_lights"] > 0
    args = {"frame": 0, "opts": opts}
    assert isinstance(check(res, ref, r, REGISTRY["clustered"], REGISTRY["brute"], args), IntendedLoss)
    rows, cols = np.nonzero(res.depth_t[0])
    res.contrib_hash_t = res.contrib_hash_t.copy()
    res.contrib_hash_t[0, rows[0], cols[0]] ^= 1
    m = check(res, ref, r, REGISTRY["clustered"], REGISTRY["brute"], args)
    assert not isinstance(m, IntendedLoss) and "transparent layer 0" in m.message()


def test_a_layer_culled_against_the_opaque_depth_fails_and_is_explained(hard, monkeypatch, tmp_path):
    """tiled with its culling pass reading the opaque G-buffer while its shading reads the
    layer (tiles bounded by the opaque depth, for transparents the naive way) misses the
    lights between the pane and the wall: the check names the layer, the pixel and the lights
    missing there, which the float64 oracle says affect it."""
    scene, r, ref = hard
    opaque = (r.gbuffer.position, r.gbuffer.normal, r.gbuffer.albedo)
    run = Renderer.run

    def culled_against_opaque(self, steps, *a, **kw):
        gb = self.gbuffer
        if self is not r or gb.position is opaque[0] or len(steps) < 2:
            return run(self, steps, *a, **kw)
        layer = (gb.position, gb.normal, gb.albedo)
        gb.position, gb.normal, gb.albedo = opaque
        gb.bind_textures()
        run(self, steps[:-1], *a, **kw)
        gb.position, gb.normal, gb.albedo = layer
        gb.bind_textures()
        return run(self, steps[-1:], *a, **kw)

    monkeypatch.setattr(Renderer, "run", culled_against_opaque)
    res = r.render(REGISTRY["tiled"])
    assert check(res, ref) is not None and (res.contrib_count == ref.contrib_count).all()
    m = check(res, ref, r, REGISTRY["tiled"], REGISTRY["brute"], {"frame": 0}, tmp_path)
    assert "transparent layer 0" in m.message() and m.missing and not m.extra, m.message()
    assert all(p.is_file() for p in m.images.values()) and len(m.images) == 3
    x, row = m.first
    inside = layer_oracle(r, scene.lights, scene.camera)[0][3].reshape(SIZE[1], SIZE[0], -1)
    assert set(m.missing) <= set(np.nonzero(inside[row, x])[0].tolist())
    assert len(m.missing) == m.count[1] - m.count[0]


@pytest.mark.parametrize("opts", [{"build": 1}, {"tile": 16}, {"scalarize": True}],
                         ids=["gpu-build", "tile-16", "scalarized"])
def test_the_options_keep_the_layers_exact(hard, opts):
    """The GPU build (its passes and read-backs run again per layer), other tiles, the
    scalarized walks."""
    scene, r, ref = hard
    names = [n for n in REGISTRY if n != "brute" and set(opts) <= set(REGISTRY[n].Options.names())]
    assert names
    assert_exact(render_on(r, opts, names, reference=ref), str(opts))


def test_later_samples_composite_the_layers_again(hard):
    scene, r, ref = hard
    one = r.render(REGISTRY["clustered"])
    three = r.render(REGISTRY["clustered"], samples=3)
    assert len(three.meta["samples"]) == 3 and "shade" in three.meta["transparent"]["gpu_ms"]
    assert np.array_equal(one.image, three.image) and not np.array_equal(one.image, ref.image * 0)
    for k in LAYER_FIELDS:
        assert np.array_equal(getattr(one, k), getattr(three, k)), k
