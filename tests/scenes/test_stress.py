"""The stress scene (Bevy's many_lights): the sphere's mesh, the lattice,
every light reaching the mesh on its side, cameras inside and outside, counts up to a
million, and every technique exact against brute on it."""
import numpy as np
import pytest

from scenes import BUILTIN_SCENES, SceneError, load_scene
from scenes.builtin import (STRESS_LIGHTS, STRESS_OFFSET, STRESS_RADIUS, STRESS_RANGE,
                            fibonacci_sphere, geodesic_sphere, inscribed_radius, stress_range)
from scenes.errors import MAX_LIGHTS
from scenes.geometry import mesh_triangles

SPHERE = geodesic_sphere(STRESS_RADIUS, 15)


def test_geodesic_sphere_is_closed_and_wound_outwards():
    v, f = SPHERE.vertices.astype(np.float64), SPHERE.faces
    assert len(f) == 20 * 15 ** 2 and len(v) == 10 * 15 ** 2 + 2      # Euler: V - E + F = 2
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), STRESS_RADIUS, rtol=1e-6)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert (uses == 2).all()                                          # watertight
    t = v[f]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    assert (np.einsum("ij,ij->i", t.mean(1), n) > 0).all()
    assert STRESS_RADIUS - 0.1 < inscribed_radius(SPHERE) < STRESS_RADIUS


def test_fibonacci_lattice_is_even():
    p = fibonacci_sphere(2000)
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-12)
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    np.fill_diagonal(d, np.inf)
    nn = d.min(1)
    assert nn.min() > 0.6 * nn.mean() and nn.max() < 1.4 * nn.mean()
    assert np.abs(p.mean(0)).max() < 1e-3                             # no side favoured


def _distance_to_mesh(points, meshes):
    import trimesh
    tris = mesh_triangles(meshes)
    P, T = len(points), len(tris)
    cp = trimesh.triangles.closest_point(np.tile(tris, (P, 1, 1)), np.repeat(points, T, axis=0))
    return np.linalg.norm(cp - np.repeat(points, T, axis=0), axis=1).reshape(P, T).min(1)


@pytest.mark.parametrize("dist", ["uniform", "geometry"])
@pytest.mark.parametrize("n", [500, STRESS_LIGHTS])
def test_every_light_reaches_the_mesh_on_its_side(dist, n):
    s = BUILTIN_SCENES["stress"](n, 4, dist)
    L = s.lights
    assert len(L) == n and (L["type"] == 0).all()
    assert (L["radius"] == np.float32(stress_range(n))).all()
    pos = L["position"].astype(np.float64)
    rho = np.linalg.norm(pos, axis=1)
    sphere = s.meshes[0] if len(s.meshes[0].faces) == len(SPHERE.faces) else s.meshes[1]
    r_in = inscribed_radius(sphere)
    # light 2k inside every face's plane, 2k+1 outside every vertex (uniform); a face's
    # normal's side (geometry)
    if dist == "uniform":
        assert (rho[0::2] < r_in).all() and (rho[1::2] > STRESS_RADIUS).all()
    else:
        assert (rho[0::2] < STRESS_RADIUS).all() and (rho[1::2] > r_in).all()
    pick = np.random.default_rng(0).choice(n, min(n, 150), replace=False)
    d = _distance_to_mesh(pos[pick], [sphere])
    assert (d >= STRESS_OFFSET * 0.99).all()
    assert (d <= STRESS_OFFSET + (STRESS_RADIUS - r_in) + 1e-4).all()
    assert (2 * d < L["radius"][pick]).all()            # each light's disc on the mesh is real


def test_range_and_counts():
    assert stress_range(STRESS_LIGHTS) == stress_range(1_000_000) == STRESS_RANGE
    # below the default count each point of the sphere stays in reach of 0.9 lights
    for n in (1000, 20000, STRESS_LIGHTS):
        assert n * stress_range(n) ** 2 / (4 * STRESS_RADIUS ** 2) == pytest.approx(0.9)
    assert stress_range(1) == STRESS_RADIUS / 4
    assert len(load_scene("stress").lights) == STRESS_LIGHTS
    with pytest.raises(SceneError, match="stress: lights"):
        load_scene("stress", lights=MAX_LIGHTS + 1)


def test_million_lights():
    s = load_scene("stress", lights=1_000_000, seed=2)
    assert len(s.lights) == 1_000_000
    assert np.isfinite(s.lights["position"]).all()
    rho = np.linalg.norm(s.lights["position"].astype(np.float64), axis=1)
    assert rho.min() > STRESS_RADIUS - 0.2 and rho.max() < STRESS_RADIUS + 0.1


def test_cameras_inside_then_outside():
    s = BUILTIN_SCENES["stress"](10, 0, None)
    keys = [s.camera, *s.path]
    rho = [np.linalg.norm(k.position) for k in keys]
    reach = STRESS_RADIUS + STRESS_OFFSET + STRESS_RANGE
    assert [r < STRESS_RADIUS - 1 for r in rho] == [True] * 4 + [False] * 3
    assert all(r > reach + 10 for r in rho[4:])
    for k in keys:              # every key looks at the sphere's wall
        d = np.subtract(k.target, k.position)
        assert np.linalg.norm(d) > 1 and np.isfinite(d).all()


# frames of the 7-key loop: inside, grazing the wall (3,794 visible lights at 20,000), and
# outside, 20 m above the surface (14,796 visible: brute alone takes ~6 s of it)
FRAMES = (2, 5)


def test_every_technique_exact_at_20000_lights(gl):
    """160x90, 20,000 lights, a view from inside and one from outside (where the far
    hemisphere's lights are behind the near one's pixels): every technique gives brute's
    lights at every pixel, and the lights light a good part of the mesh."""
    from app.pipeline.renderer import Renderer
    from tests.helpers import assert_exact, render_on
    scene = load_scene("stress", lights=20000, seed=1)
    with Renderer(scene, (160, 90)) as r:
        for frame in FRAMES:
            res = render_on(r, frame=frame, frames=7)
            assert_exact(res, f"stress frame {frame}")
            lit = res["brute"].contrib_count[res["brute"].depth > 0]
            assert lit.size and (lit > 0).mean() > 0.3, f"frame {frame}: lights touch too little"
