"""brute against a float64 numpy oracle: per-pixel count and hash equal away from
light-volume boundaries; the dump arrays' orientation (row 0 = top)."""
import numpy as np
import pytest

from app.dump import mix
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep.camera import look_at
from tests.helpers import make_scene, random_lights


def oracle(scene, renderer, lights):
    """(count, hash, near_boundary) per pixel, image order, in float64."""
    pos = renderer.gbuffer.read_position()[::-1].astype(np.float64)     # image order
    h, w, _ = pos.shape
    P = pos[..., :3].reshape(-1, 1, 3)
    m = look_at(scene.camera.position, scene.camera.target, scene.camera.up)
    L = lights["position"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    D = lights["direction"].astype(np.float64) @ m[:3, :3].T
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    v = P - L[None]
    dist = np.linalg.norm(v, axis=2)
    r = lights["radius"].astype(np.float64)[None]
    cos_o = lights["cos_outer"].astype(np.float64)[None]
    spot = (lights["type"] == 1)[None]
    along = np.einsum("pij,ij->pi", v, D) / np.maximum(dist, 1e-30)
    inside = (dist < r) & (~spot | (along > cos_o))
    near = (np.abs(dist - r) < 1e-4 * r) | (spot & (np.abs(along - cos_o) < 1e-4))
    valid = pos[..., 3].reshape(-1) > 0
    inside &= valid[:, None]
    ids = mix(np.arange(len(lights)))
    count = inside.sum(1)
    hashes = np.bitwise_xor.reduce(np.where(inside, ids[None], 0).astype(np.uint32), axis=1)
    return count.reshape(h, w), hashes.reshape(h, w), (near & valid[:, None]).any(1).reshape(h, w)


@pytest.mark.parametrize("size", [(96, 64), (1, 1), (333, 217)])
def test_brute_matches_float64_oracle(gl, rng, size):
    lights = random_lights(rng, 150, (-15, -1, -35), (15, 6, 8), radius=(0.5, 8.0))
    scene = make_scene(lights, size=size)
    with Renderer(scene) as r:
        res = r.render(REGISTRY["brute"])
        count, hashes, near = oracle(scene, r, lights)
    ok = ~near
    assert res.contrib_count.shape == (size[1], size[0])
    assert np.array_equal(res.contrib_count[ok], count[ok])
    assert np.array_equal(res.contrib_hash[ok], hashes[ok])
    if size != (1, 1):
        assert count.sum() > 100 and ok.mean() > 0.9


def test_image_rows_start_at_the_top(gl, rng):
    """The floor is at the bottom of the image, the sky (depth 0) at the top."""
    scene = make_scene(random_lights(rng, 10, (-5, 0, -10), (5, 2, 0)), size=(64, 48))
    with Renderer(scene) as r:
        res = r.render(REGISTRY["brute"])
    assert (res.depth[-1] > 0).all() and (res.depth[0] == 0).any()
