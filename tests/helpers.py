"""Scene builders and the exactness check used across the tests."""
from __future__ import annotations

from contextlib import contextmanager
from functools import lru_cache
import json
from pathlib import Path

import numpy as np

from app.dump import mix
from app.techniques import REGISTRY, with_role
from cpu_prep.camera import look_at
from scenes.geometry import box_mesh
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT, Camera, Scene, make_lights

_RENDERERS: dict = {}


def floor_and_boxes(extent: float = 100.0) -> list:
    """A floor and a few boxes at several depths: enough depth variance for every structure."""
    return [box_mesh((-extent, -0.1, -extent), (extent, 0.0, extent)),
            box_mesh((2, 0, -12), (6, 8, -8)), box_mesh((-9, 0, -30), (-3, 14, -24)),
            box_mesh((-2, 0, -4), (-0.5, 1.5, -2.5))]


def random_lights(rng, n: int, lo, hi, radius=(0.3, 6.0), spot_share: float = 0.3,
                  outer_deg=(5.0, 80.0)):
    lights = make_lights(n)
    lights["position"] = rng.uniform(lo, hi, (n, 3))
    lights["radius"] = rng.uniform(*radius, n)
    lights["color"] = rng.uniform(0.2, 1.0, (n, 3))
    lights["intensity"] = 2.0
    spot = rng.random(n) < spot_share
    d = rng.normal(size=(n, 3))
    lights["direction"] = d / np.linalg.norm(d, axis=1, keepdims=True)
    outer = rng.uniform(*outer_deg, n)
    inner = outer * rng.uniform(0.5, 1.0, n)
    lights["type"][spot] = LIGHT_SPOT
    lights["cos_outer"][spot] = np.cos(np.radians(outer[spot]))
    lights["cos_inner"][spot] = np.cos(np.radians(inner[spot]))
    return lights


def random_shapes(rng, n: int, lo, hi, radius=(0.2, 5.0), length=(0.0, 12.0), extent=(0.05, 6.0),
                  shares=(0.25, 0.25, 0.25, 0.25), outer_deg=(0.5, 90.0)):
    """n lights of the four shapes (point, spot, capsule, box) in `shares`, each with its own
    random parameters: spot angles up to 90 and inner 0, capsules of length 0, flat boxes."""
    lights = random_lights(rng, n, lo, hi, radius, spot_share=0.0)
    kind = rng.choice(4, n, p=np.asarray(shares) / np.sum(shares))
    lights["type"] = kind
    spot, cap, box = kind == LIGHT_SPOT, kind == LIGHT_CAPSULE, kind == LIGHT_BOX
    outer = rng.uniform(*outer_deg, n)
    inner = np.where(rng.random(n) < 0.3, 0.0, outer * rng.uniform(0.0, 1.0, n))
    lights["cos_outer"][spot] = np.cos(np.radians(outer[spot]))
    lights["cos_inner"][spot] = np.cos(np.radians(inner[spot]))
    lights["length"][cap] = np.where(rng.random(cap.sum()) < 0.2, 0.0, rng.uniform(*length, cap.sum()))
    up = rng.normal(size=(n, 3))
    lights["up"] = up / np.linalg.norm(up, axis=1, keepdims=True)
    lights["extent"][box] = rng.uniform(*extent, (box.sum(), 3))
    return lights


def affects64(P: np.ndarray, lights: np.ndarray, view_from_world: np.ndarray, rel: float = 1e-4):
    """(inside, near) (N_points, N_lights) bools in float64: whether each light's volume
    (docs/contracts.md "Light model") holds each view-space point, and whether the point lies within
    `rel` of the volume's boundary (where float32 may decide either way)."""
    m = np.asarray(view_from_world, np.float64)
    rot = lambda v: np.asarray(v, np.float64) @ m[:3, :3].T
    unit = lambda v: v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)
    L = rot(lights["position"]) + m[:3, 3]
    D = unit(rot(lights["direction"]))
    r = lights["radius"].astype(np.float64)
    t = lights["type"]
    v = P[:, None, :] - L[None]                                     # (N, L, 3)
    dist = np.linalg.norm(v, axis=2)
    # point (and the sphere of a spot): margin relative to the radius
    inside, near = dist < r, np.abs(dist - r) < rel * r
    # spot: also inside the cone
    along = np.einsum("plk,lk->pl", v, D) / np.maximum(dist, 1e-300)
    cos_o = lights["cos_outer"].astype(np.float64)
    spot = t == LIGHT_SPOT
    inside = np.where(spot, inside & (along > cos_o), inside)
    near = np.where(spot, near | (np.abs(along - cos_o) < rel), near)
    # capsule: distance to the segment
    h = 0.5 * lights["length"].astype(np.float64)
    s = np.clip(np.einsum("plk,lk->pl", v, D), -h, h)
    q = np.linalg.norm(v - s[..., None] * D[None], axis=2)
    cap = t == LIGHT_CAPSULE
    inside = np.where(cap, q < r, inside)
    near = np.where(cap, np.abs(q - r) < rel * (r + h), near)
    # box: local coordinates inside the half extents
    R = unit(np.cross(D, unit(rot(lights["up"]))))
    U = np.cross(R, D)
    loc = np.stack([np.einsum("plk,lk->pl", v, A) for A in (R, U, D)], -1)
    ext = lights["extent"].astype(np.float64)
    box = t == LIGHT_BOX
    rel_box = rel * ext.max(1)[None, :, None]
    inside = np.where(box, (np.abs(loc) < ext[None]).all(-1), inside)
    near = np.where(box, (np.abs(np.abs(loc) - ext[None]) < rel_box).any(-1), near)
    return inside, near


def contract_figures(inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """contrib_count and contrib_hash (the dump contract's) of (pixels, lights) bools."""
    ids = mix(np.arange(inside.shape[1]))
    return inside.sum(1), np.bitwise_xor.reduce(np.where(inside, ids[None], 0).astype(np.uint32), axis=1)


# The tests' default view: from 10 m in front of the boxes, looking down the floor.
CAMERA = Camera((0.0, 3.0, 10.0), (0.0, 1.0, -20.0), near=0.1, far=200.0)


def pixel_oracle(renderer, lights, camera=CAMERA):
    """The light model in float64 (affects64) at the renderer's G-buffer positions, image
    order: (count, hash, near a volume's boundary) per pixel, and inside (pixels, lights)."""
    pos = renderer.gbuffer.read_position()[::-1].astype(np.float64)
    h, w, _ = pos.shape
    covered = pos[..., 3].reshape(-1, 1) > 0
    view_from_world = look_at(camera.position, camera.target, camera.up)
    inside, near = affects64(pos[..., :3].reshape(-1, 3), lights, view_from_world)
    inside &= covered
    count, hashes = contract_figures(inside)
    return count.reshape(h, w), hashes.reshape(h, w), (near & covered).any(1).reshape(h, w), inside


def npz_arrays(n: int = 3) -> dict:
    """A lights_npz file's arrays (docs/contracts.md "Contract: scene files"): n valid lights, the
    second a spot, the others points; tests change or drop arrays to make bad files."""
    types = np.zeros(n, np.uint8)
    types[1:2] = LIGHT_SPOT
    return {
        "type": types,
        "position": np.arange(3 * n, dtype=np.float32).reshape(n, 3),
        "radius": np.full(n, 2.5, np.float32),
        "color": np.full((n, 3), 0.5, np.float32),
        "intensity": np.full(n, 4.0, np.float32),
        "direction": np.tile(np.array([[0, 0, -3]], np.float32), (n, 1)),
        "cos_inner": np.full(n, 0.95, np.float32),
        "cos_outer": np.full(n, 0.9, np.float32),
    }


def write_npz(folder, arrays: dict, name: str = "lights.npz") -> str:
    """`arrays` saved as folder/name; -> name, for a scene file's lights_npz."""
    np.savez(Path(folder) / name, **arrays)
    return name


def make_scene(lights, meshes=None, size=(96, 64), camera=None, max_depth=150.0, name="test"):
    camera = camera or CAMERA
    return Scene(name, tuple(size), camera, meshes if meshes is not None else floor_and_boxes(),
                 lights, max_depth=max_depth)


def options(name: str, **values):
    """The technique's Options from those of `values` it declares and its mode reads (tests
    set one option for every technique that has it; the CLI instead rejects an option a
    technique lacks, or one that the mode its other options select ignores)."""
    from app.errors import UserError
    t = REGISTRY[name]
    mine = {k: v for k, v in values.items() if k in t.Options.names()}
    default = t.Options().ignored()

    def selects_a_mode(k) -> bool:        # alone, it changes what the technique ignores
        try:
            return t.Options.make({k: mine[k]}).ignored() != default
        except UserError:                 # ignored in the default mode: selects nothing
            return False
    mode = t.Options.make({k: v for k, v in mine.items() if selects_a_mode(k)})
    return t.Options.make({k: v for k, v in mine.items() if k not in mode.ignored()})


def takes(name: str, *option_names: str) -> bool:
    return set(option_names) <= set(REGISTRY[name].Options.names())


ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"


class Results(dict):
    """{technique name: FrameResult}; `explained` holds, for each technique that differs
    from the reference, the exactness check's explanation (app.exactness: the first
    differing pixel, the lights that differ there, images under test-artifacts/), made
    while the renderer was still alive."""
    explained: dict


def render_on(renderer, opts: dict | None = None, techniques=None, reference=None,
              **kw) -> Results:
    """render_all() on an open renderer (kw: frame, lights, frames, ... of Renderer.render).
    `reference`: the reference's result of this frame, rendered once for several option
    sets that it does not take (the results hold it beside the techniques named)."""
    names = techniques or list(REGISTRY)
    frame = kw.pop("frame", 0)
    out = Results({n: renderer.render(REGISTRY[n], frame, options(n, **(opts or {})), **kw)
                   for n in names})
    if reference is not None:
        out[with_role("reference").name] = reference
    out.explained = explain(out, renderer, opts, dict(kw, frame=frame))
    return out


# the builtin scenes' draw the exactness tests hold every technique to (test_exactness,
# test_tree_options share its reference frames); the extremes of light count are the hard
# cases' and the loop budget's (65,536-70,000 lights) and the stress scene's (20,000)
BUILTIN_LIGHTS = 4096


@lru_cache(maxsize=None)
def builtin_reference(name: str, lights: int, seed: int, distribution: str,
                      size: tuple[int, int]):
    """(scene, the reference's result of its frame 0 at `size`) for one draw of a builtin
    scene, rendered once per test process: the tests that check every technique and every
    option set on the builtin scenes share it (the reference takes none of their options),
    and tests/conftest.py schedules the tests of one scene on one worker (SHARED_REFERENCE).
    Every draw asked stays cached (the suite asks for 15, two distributions of each builtin
    scene and arena's 4,096 lights: a few MB each): an evicted one is a brute frame of 4,096
    lights rendered again."""
    from app.pipeline.renderer import Renderer
    from scenes import load_scene
    scene = load_scene(name, lights=lights, seed=seed, distribution=distribution)
    scene.resolution = tuple(size)
    with Renderer(scene) as r:
        return scene, r.render(with_role("reference"))


def render_all(scene, opts: dict | None = None, techniques=None, **kw) -> Results:
    """{technique name: FrameResult} for every registered technique (or those named), each
    with the options of `opts` it declares."""
    from app.pipeline.renderer import Renderer
    with Renderer(scene) as r:
        return render_on(r, opts, techniques, **kw)


def explain(results: dict, renderer, opts: dict | None, render_args: dict) -> dict:
    from app.exactness import check
    ref_name = with_role("reference").name
    if ref_name not in results:
        return {}
    out = {}
    for name, res in results.items():
        m = check(res, results[ref_name], renderer, REGISTRY[name], REGISTRY[ref_name],
                  dict(render_args, opts=options(name, **(opts or {}))),
                  ARTIFACTS / f"{name}-{abs(hash(repr(sorted(render_args))) % 10**8)}")
        if m is not None:
            out[name] = m.message()
    return out


def assert_exact(results: dict, where: str = "") -> None:
    """Every technique gives brute's contrib_count and contrib_hash at every pixel, and
    every output is finite; on failure the message names the first differing pixel and the
    lights that differ there (when the results came from render_all / render_on)."""
    from app.exactness import check
    ref = results[with_role("reference").name]
    assert np.isfinite(ref.image).all(), f"{where}: brute image not finite"
    bad = []
    explained = getattr(results, "explained", {})
    for name, res in results.items():
        assert np.isfinite(res.image).all(), f"{where}: {name} image not finite"
        if name in explained:
            bad.append(explained[name])
        elif (m := check(res, ref)) is not None:
            bad.append(m.message())
    assert not bad, f"{where}: " + "; ".join(bad)


def assume_lit(results: dict) -> None:
    """In a Hypothesis test: an example whose reference frame lights no pixel proves nothing
    about culling (every technique trivially agrees on nothing), so another is drawn."""
    from hypothesis import assume
    assume(bool((results[with_role("reference").name].contrib_count > 0).any()))


IMAGE_RTOL = 1e-4      # of the reference image's peak: float32 sums in another order


def assert_same_image(results: dict, where: str = "", rtol: float = IMAGE_RTOL) -> None:
    """Every technique's image equals the reference's to within rtol of its peak radiance:
    the light sets (assert_exact) do not see a light's weight, the image does."""
    ref = results[with_role("reference").name].image.astype(np.float64)
    peak = float(np.abs(ref).max())
    assert peak > 0, f"{where}: the reference image is black"
    bad = {n: float(np.abs(r.image - ref).max()) / peak for n, r in results.items()}
    bad = {n: e for n, e in bad.items() if not e <= rtol}
    assert not bad, f"{where}: image differs from the reference's by (of its peak) " + \
        ", ".join(f"{n} {e:.3g}" for n, e in bad.items())


def threads_or_skip(n: int) -> None:
    """Skip the test, saying why, when numba has fewer than n threads: a case of n threads
    would run on fewer (numba clamps) and check what the one-thread case already does."""
    import numba
    import pytest
    if n > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"{n} threads asked, numba has {numba.config.NUMBA_NUM_THREADS} "
                    f"(NUMBA_NUM_THREADS, cores): the case would run on fewer")


def with_threads(n: int, fn):
    """fn() with numba's thread count set to n (the test skipped where numba has fewer:
    threads_or_skip), restored after."""
    from cpu_prep import using_threads
    threads_or_skip(n)
    with using_threads(n):
        return fn()


@contextmanager
def registered(technique, at: float = float("inf")):
    """`technique` in the registry (at position `at`: app.techniques.base.register) while the
    block runs, unregistered after it, whatever the block raises."""
    from app.techniques.base import register, unregister
    register(technique, at=at)
    try:
        yield technique
    finally:
        unregister(technique.name)


def path_file(tmp_path, n=3) -> Path:
    """A camera-path file of `n` keys flying down arena's middle (scenes.camera_path's format)."""
    keys = [{"t": k / 30, "position": [0.0, 6.0, 20.0 - 6 * k], "target": [0.0, 4.0, -20.0],
             "up": [0, 1, 0], "fov_y_deg": 60, "near": 0.1, "far": 500} for k in range(n)]
    p = tmp_path / "fly.json"
    p.write_text(json.dumps({"format": "many-light-lab camera path", "version": 1,
                             "scene": "arena", "size": [320, 180], "keys": keys}))
    return p


@contextmanager
def with_brute(name: str, lights: int, seed: int, size: tuple[int, int]):
    """(renderer, brute's frame 0) of a builtin scene's draw at `size`, the renderer open."""
    from app.pipeline.renderer import Renderer
    from scenes import load_scene
    scene = load_scene(name, lights=lights, seed=seed)
    scene.resolution = tuple(size)
    with Renderer(scene) as r:
        yield r, r.render(with_role("reference"), 0)
