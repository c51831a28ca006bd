"""The exactness check: every registered technique gives brute's contrib_count and
contrib_hash at every pixel, on every builtin scene with both light distributions at
4,096 lights, along the camera path, under every option, and on randomized scenes."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, with_role
from scenes import BUILTIN_SCENES, load_scene
from scenes.model import Camera
from tests.helpers import (BUILTIN_LIGHTS, assert_exact, assume_lit, builtin_reference, make_scene,
                           random_lights, render_all, render_on, takes)

SIZE = (160, 90)         # 10 x 6 tiles of 16 px


@pytest.mark.parametrize("distribution", ["uniform", "geometry"])
@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_builtin_scenes_are_exact(gl, name, distribution):
    scene, ref = builtin_reference(name, BUILTIN_LIGHTS, 1, distribution, SIZE)
    with Renderer(scene) as r:
        results = render_on(r, None, _techniques(), reference=ref)
    assert_exact(results, f"{name}/{distribution}")
    assert ref.contrib_count.sum() > 0, "scene lights touch nothing: test is void"


def _techniques() -> list[str]:
    """Every registered technique but the reference (rendered once, builtin_reference)."""
    return [n for n in REGISTRY if n != with_role("reference").name]


@pytest.mark.parametrize("opts", [
    dict(tile=16, slices=8), dict(tile=64, slices=24), dict(duplicated=True),
    dict(sort_buckets=512), dict(lights_per_leaf=1, max_leaves=8), dict(radius_scale=8.0),
    dict(native_wave=True), dict(tile=20, slices=4), dict(scalarize=True),
    dict(scalarize=True, native_wave=True, duplicated=True), dict(specialised=False)],
    ids=["t16s8", "t64s24", "duplicated", "buckets", "tiny-leaves", "tree-heavy", "native-wave", "t20",
         "scalarized-cells", "scalarized-cells-native", "general-paths"])
def test_options_keep_exactness(gl, opts, request):
    assert not set(opts) & set(with_role("reference").Options.names())    # one reference for all
    scene, ref = builtin_reference("arena", 4096, 3, None, SIZE)
    changed = [n for n in _techniques() if any(takes(n, o) for o in opts)]   # the others: defaults
    assert changed, opts
    with Renderer(scene) as r:
        results = render_on(r, opts, changed, reference=ref)
    assert_exact(results, str(opts))
    # each frame ran with every option asked of it that it takes (tests.helpers.options drops
    # those the technique's mode ignores): only the pairs named in MODE_IGNORES may differ
    for name in changed:
        ran = results[name].meta["options"]
        differ = {k for k, v in opts.items() if takes(name, k) and ran[k] != v}
        want = MODE_IGNORES.get(request.node.callspec.id, {}).get(name, set())
        assert differ == want, f"{name} ran {ran}"


# {option set's id: {technique: options it takes but its mode there does not read}}:
# clustered's wave ops are its scalarized walk's (scalarized-cells-native has both)
MODE_IGNORES = {"native-wave": {"clustered": {"native_wave"}}}


def test_camera_path_frames_are_exact(gl):
    scene = load_scene("city", lights=4096, seed=2)
    scene.resolution = (160, 90)
    with Renderer(scene) as r:
        for frame in (5, 17, 40):
            assert_exact({n: r.render(t, frame, frames=48) for n, t in REGISTRY.items()}, f"frame {frame}")


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), n=st.integers(1, 600), fov=st.floats(20, 120),
       w=st.integers(1, 130), h=st.integers(1, 90), tile=st.sampled_from([8, 16, 33, 48]),
       near=st.sampled_from([0.01, 0.1, 1.0]))
def test_random_scenes_are_exact(gl, seed, n, fov, w, h, tile, near):
    rng = np.random.default_rng(seed)
    lights = random_lights(rng, n, (-25, -2, -45), (25, 10, 12), radius=(0.05, 12.0))
    cam = Camera((0.0, 2.0, 8.0), (rng.uniform(-3, 3), 1.0, -20.0), fov_y_deg=fov, near=near, far=300.0)
    scene = make_scene(lights, size=(w, h), camera=cam)
    results = render_all(scene, dict(tile=tile, slices=int(rng.integers(2, 24))))
    assert_exact(results, f"seed {seed}")
    assume_lit(results)


def test_tiled_pool_overflow_shades_every_light(gl, monkeypatch):
    """Tiles whose lists do not fit the pool are flagged and shade every light: still exact."""
    from app.techniques import tiled
    monkeypatch.setattr(tiled, "POOL_MAX_ENTRIES", 1500)
    scene = load_scene("hangar", lights=512, seed=5)
    scene.resolution = (96, 64)
    results = render_all(scene, dict(tile=16), techniques=["brute", "tiled"])
    assert_exact(results, "pool overflow")
    shaded = results["brute"].depth > 0
    every = (results["tiled"].evaluated == results["brute"].evaluated)[shaded]
    assert every.any() and not every.all()   # some tiles overflowed, some did not
