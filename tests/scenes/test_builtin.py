"""Builtin procedural scenes: counts, determinism, sane values, light placement."""
import numpy as np
import pytest
import trimesh

from scenes import BUILTIN_SCENES, LIGHT_DTYPE, Camera, Scene, SceneError, load_scene
from scenes.builtin import STRESS_OFFSET
from scenes.geometry import mesh_triangles
from scenes.model import LIGHT_POINT, LIGHT_SPOT, LIGHT_TYPE_NAMES

DEFAULT_LIGHTS = {"city": 4096, "arena": 4096, "hangar": 512, "gallery": 46, "corridor": 512,
                  "contention": 256, "stress": 100_000, "city-glass": 4096}
DEFAULT_DIST = {"city": "geometry", "arena": "uniform", "hangar": "uniform", "gallery": "geometry",
                "corridor": "uniform", "contention": "uniform", "stress": "uniform",
                "city-glass": "geometry"}
NAMES = list(BUILTIN_SCENES)


def test_registry_order():
    assert NAMES == ["city", "arena", "hangar", "gallery", "corridor", "contention", "stress",
                     "city-glass"]


def _check_scene(s: Scene, n: int):
    assert isinstance(s, Scene)
    assert s.resolution == (960, 540)
    L = s.lights
    assert L.dtype == LIGHT_DTYPE and len(L) == n
    for k in LIGHT_DTYPE.names:
        if k != "type":
            assert np.all(np.isfinite(L[k])), k
    assert np.all(L["radius"] > 0)
    assert np.all(L["color"] >= 0) and np.all(L["intensity"] >= 0)
    assert set(np.unique(L["type"]).tolist()) <= set(range(len(LIGHT_TYPE_NAMES)))
    spot = L["type"] == LIGHT_SPOT
    np.testing.assert_allclose(np.linalg.norm(L["direction"][spot], axis=1), 1.0, atol=1e-5)
    assert np.all(L["cos_inner"] >= L["cos_outer"])
    tris = sum(len(m.faces) for m in s.meshes)
    assert 0 < tris <= 5000
    for m in s.meshes:
        assert m.vertices.dtype == np.float32 and m.faces.dtype == np.int32
        assert m.faces.min() >= 0 and m.faces.max() < len(m.vertices)
        assert np.all(np.isfinite(m.vertices))
    c = s.camera
    assert c.fov_y_deg == 60 and 0 < c.near < c.far
    assert 4 <= len(s.path) <= 8
    assert s.max_depth is not None and 2 * c.near <= s.max_depth <= c.far


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("lights", [None, 1, 8192])
def test_builds_with_exact_count(name, lights):
    s = load_scene(name, lights=lights, seed=3)
    _check_scene(s, DEFAULT_LIGHTS[name] if lights is None else lights)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("dist", ["uniform", "geometry"])
def test_deterministic(name, dist):
    a = BUILTIN_SCENES[name](300, 7, dist)
    b = BUILTIN_SCENES[name](300, 7, dist)
    assert all(np.array_equal(a.lights[f], b.lights[f]) for f in a.lights.dtype.names)
    assert len(a.meshes) == len(b.meshes)
    for ma, mb in zip(a.meshes, b.meshes):
        assert ma.vertices.tobytes() == mb.vertices.tobytes()
        assert ma.faces.tobytes() == mb.faces.tobytes() and ma.albedo == mb.albedo
    assert a.camera == b.camera and a.path == b.path and a.max_depth == b.max_depth
    c = BUILTIN_SCENES[name](300, 8, dist)
    assert not np.array_equal(c.lights["position"], a.lights["position"])


def _min_dist_to_triangles(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    P, T = len(points), len(tris)
    pts = np.repeat(points, T, axis=0)
    tri = np.tile(tris, (P, 1, 1))
    cp = trimesh.triangles.closest_point(tri, pts)
    return np.linalg.norm(cp - pts, axis=1).reshape(P, T).min(axis=1)


@pytest.mark.parametrize("name", NAMES)
def test_geometry_distribution_touches_geometry(name):
    s = BUILTIN_SCENES[name](200, 1, "geometry")
    tris = mesh_triangles(s.meshes)
    L = s.lights
    d = _min_dist_to_triangles(L["position"].astype(np.float64), tris)
    # the reach of each shape's volume from its position (docs/contracts.md "Light model")
    from scenes.model import LIGHT_BOX, LIGHT_CAPSULE
    reach = np.where(L["type"] == LIGHT_CAPSULE, L["radius"] + L["length"] / 2, L["radius"])
    reach = np.where(L["type"] == LIGHT_BOX, np.linalg.norm(L["extent"], axis=1), reach)
    assert np.all(d <= reach), (d - reach).max()


@pytest.mark.parametrize("name", NAMES)
def test_uniform_distribution_in_bounds(name):
    s = BUILTIN_SCENES[name](2000, 1, "uniform")
    lo, hi = s.bounds()
    p = s.lights["position"]
    # the stress scene's outer lights sit STRESS_OFFSET outside its sphere (radius 50 at the
    # vertices), whose faceted mesh's box is a little smaller (49.96): twice the offset
    slack = 1e-3 + (2 * STRESS_OFFSET if name == "stress" else 0.0)
    assert np.all(p >= lo - slack) and np.all(p <= hi + slack)
    # spread over the box, not clumped
    ext = p.max(0) - p.min(0)
    assert np.all(ext[[0, 2]] > 0.8 * (hi - lo)[[0, 2]])


def test_radii_many_small_few_large():
    r = BUILTIN_SCENES["city"](8192, 0, None).lights["radius"]
    assert r.min() >= 2.0 - 1e-6 and r.max() <= 40 + 1e-5
    assert np.median(r) < 5.0 and np.mean(r > 25) < 0.05 and r.max() > 25
    h = BUILTIN_SCENES["hangar"](None, 0, None).lights["radius"]
    assert h.min() >= 4 - 1e-6 and h.max() <= 25 + 1e-5


@pytest.mark.parametrize("name", NAMES)
def test_camera_path_frames_finite(name):
    s = BUILTIN_SCENES[name](1, 0, None)
    assert s.camera_at(0) == s.camera
    for f in range(64):
        c = s.camera_at(f, 64)
        assert isinstance(c, Camera)
        pos, tgt = np.array(c.position), np.array(c.target)
        assert np.all(np.isfinite(pos)) and np.all(np.isfinite(tgt))
        view = tgt - pos
        assert np.linalg.norm(view) > 1e-3
        assert np.linalg.norm(np.cross(view / np.linalg.norm(view), c.up)) > 1e-3


def test_city_long_range():
    s = BUILTIN_SCENES["city"](1, 0, None)
    assert s.camera.far == 3000 and 1500 <= s.max_depth <= 2500
    lo, hi = s.bounds()
    assert hi[2] - lo[2] > 1500


@pytest.mark.parametrize("dist", ["geometry", "uniform"])
def test_gallery_spots(dist):
    s = BUILTIN_SCENES["gallery"](None, 0, dist)
    L = s.lights
    spot = L["type"] == LIGHT_SPOT
    assert spot.sum() == 40 and (~spot).sum() == 6
    sp = L[spot]
    assert np.all(sp["cos_inner"] >= sp["cos_outer"])
    outer = np.degrees(np.arccos(sp["cos_outer"].astype(np.float64)))
    assert np.all(outer >= 10 - 1e-3) and np.all(outer <= 30 + 1e-3)
    assert np.all(sp["radius"] >= 10 - 1e-5) and np.all(sp["radius"] <= 30 + 1e-5)
    assert np.mean(sp["direction"][:, 1] < 0) > 0.9          # mostly pointing down
    pts = L[~spot]
    assert np.all(pts["radius"] <= 3 + 1e-6)
    # --lights N changes the count, spots stay the majority
    s2 = BUILTIN_SCENES["gallery"](100, 0, dist)
    assert len(s2.lights) == 100 and (s2.lights["type"] == LIGHT_SPOT).sum() == 94


@pytest.mark.parametrize("dist", ["geometry", "uniform"])
def test_corridor_mixes_all_four_shapes(dist):
    from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_TYPES
    L = BUILTIN_SCENES["corridor"](1000, 0, dist).lights
    counts = np.bincount(L["type"], minlength=len(LIGHT_TYPES))
    assert counts.tolist() == [200, 200, 400, 200]
    cap, box = L[L["type"] == LIGHT_CAPSULE], L[L["type"] == LIGHT_BOX]
    assert (cap["length"] >= 1.0).all() and np.allclose(cap["direction"], (0, 0, 1))
    assert (box["extent"] > 0).all()
    # a box's up is never along its direction (its axes are defined)
    assert (np.abs(np.einsum("ij,ij->i", box["up"], box["direction"])) < 0.99).all()


@pytest.mark.parametrize("dist", ["uniform", "geometry"])
def test_contention_three_full_screen_lights(dist):
    """Drobot's contention case: the first three lights hold the whole hall (so every
    camera of the path sees them on every pixel), the rest is a field of small points."""
    from scenes.builtin import CONTENTION_HI, CONTENTION_LO
    s = BUILTIN_SCENES["contention"](300, 0, dist)
    L = s.lights
    assert len(L) == 300 and (L["type"] == LIGHT_POINT).all()
    corners = np.array([[x, y, z] for x in (CONTENTION_LO[0], CONTENTION_HI[0])
                        for y in (CONTENTION_LO[1], CONTENTION_HI[1])
                        for z in (CONTENTION_LO[2], CONTENTION_HI[2])])
    big = L[:3]
    reach = np.linalg.norm(corners[None] - big["position"][:, None].astype(np.float64), axis=2).max(1)
    assert (big["radius"] > reach).all()
    lo, hi = s.bounds()
    for c in [s.camera, *s.path]:
        assert np.all(np.array(c.position) > lo) and np.all(np.array(c.position) < hi)
    small = L[3:]
    assert small["radius"].min() >= 0.5 - 1e-6 and small["radius"].max() <= 2.0 + 1e-6
    assert len(BUILTIN_SCENES["contention"](2, 0, dist).lights) == 2


def test_zero_lights_allowed():
    for name in NAMES:
        assert len(BUILTIN_SCENES[name](0, 0, None).lights) == 0


@pytest.mark.parametrize("kwargs, field", [
    (dict(distribution="clumped"), "distribution"),
    (dict(lights=-1), "lights"),
    (dict(lights=2.5), "lights"),
    (dict(lights=True), "lights"),
    (dict(seed=-1), "seed"),
])
def test_bad_arguments(kwargs, field):
    with pytest.raises(SceneError) as ei:
        load_scene("arena", **kwargs)
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"arena: {field}:"), msg
