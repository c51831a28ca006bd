"""The hard cases' frames, shared by their tests (test_hard_cases, test_loop_budget,
test_zbin_technique, the GPU build's): one renderer of a small scene with its G-buffer's
positions, the float64 reference counts it checks brute against, and the scene pieces and
lights the cases place on boundaries; the loop budget's 70,000-light frame."""
from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, settings, strategies as st

from app.dump import mix
from app.pipeline.passes import FrameInput
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep import limits
from cpu_prep.camera import frame_camera
from scenes.geometry import box_mesh
from scenes.model import LIGHT_SPOT, Camera, Scene, make_lights
from tests.helpers import assert_exact, render_on


def Options(**values) -> dict:
    """One set of option values for every technique of a case (each technique takes those
    it declares: tests.helpers.options), with the grid defaults the cases slice with."""
    return {"tile": limits.DEFAULT_TILE, "slices": limits.DEFAULT_SLICES,
            "near_slice_depth": limits.DEFAULT_NEAR_SLICE_DEPTH, **values}

F32_EPS = float(np.finfo(np.float32).eps)


def hyp(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


SEEDS = st.integers(0, 2**32 - 1)


# ---------------------------------------------------------------------------- scene pieces

def street_camera(**kw) -> Camera:
    """The helpers' default view: 3 m up, looking slightly down over floor_and_boxes."""
    return Camera((0.0, 3.0, 10.0), (0.0, 1.0, -20.0), **{"near": 0.1, "far": 200.0, **kw})


def axis_camera(fov: float = 60.0, near: float = 0.1, far: float = 200.0) -> Camera:
    """At the origin looking down -z, y up: view space == world space, exactly, so light
    positions can be placed to the float32 ulp relative to G-buffer positions."""
    return Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), fov, near, far)


def wall(depth: float, half: float = 1e4, thick: float = 1.0):
    """A wall facing the axis camera whose front face is the plane z = -depth."""
    return box_mesh((-half, -half, -depth - thick), (half, half, -depth))


def scene_of(meshes, camera, size=(64, 48), max_depth=150.0, lights=None) -> Scene:
    return Scene("hard", tuple(size), camera, meshes,
                 make_lights(0) if lights is None else lights, max_depth=max_depth)


class Frame:
    """One scene on one Renderer: its G-buffer positions (to place lights on pixels), and
    every REGISTRY technique rendered against brute with the checks of the module doc."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self.renderer = Renderer(scene)
        self.renderer.render(REGISTRY["brute"], 0, lights=make_lights(0), readback=False)
        # (H, W, 4) row 0 = top: view-space xyz, w = linear depth (0 = no geometry)
        self.pos = np.ascontiguousarray(self.renderer.gbuffer.read_position()[::-1])
        self.cam = frame_camera(scene.camera, *scene.resolution)
        self.world_from_view = np.linalg.inv(self.cam.view_from_world)

    def close(self):
        self.renderer.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- placing lights --------------------------------------------------------------
    @property
    def covered(self) -> np.ndarray:
        return self.pos[..., 3] > 0

    def to_world(self, view_pts) -> np.ndarray:
        p = np.asarray(view_pts, np.float64)
        m = self.world_from_view
        return p @ m[:3, :3].T + m[:3, 3]

    def dir_to_world(self, view_dirs) -> np.ndarray:
        return np.asarray(view_dirs, np.float64) @ self.world_from_view[:3, :3].T

    def pixel_points(self, rng, k: int) -> np.ndarray:
        """View-space positions of k random covered pixels (with repeats if few)."""
        ys, xs = np.nonzero(self.covered)
        assert len(ys), "scene shows no geometry: the case cannot light anything"
        i = rng.integers(0, len(ys), k)
        return self.pos[ys[i], xs[i], :3].astype(np.float64)

    def anchors(self, rng, k: int, radius=(0.2, 3.0), spot_share: float = 0.0) -> np.ndarray:
        """k lights centred within half their radius of random covered pixels: each surely
        lights its pixel (spots point their axis at it from behind the offset)."""
        P = self.pixel_points(rng, k)
        r = rng.uniform(*radius, k)
        off = rng.normal(size=(k, 3))
        off /= np.linalg.norm(off, axis=1, keepdims=True)
        C = P + off * (r * rng.uniform(0, 0.5, k))[:, None]
        L = make_lights(k)
        L["position"] = self.to_world(C)
        L["radius"] = r
        L["color"] = rng.uniform(0.2, 1.0, (k, 3))
        spot = rng.random(k) < spot_share
        d = P - C
        n = np.linalg.norm(d, axis=1, keepdims=True)
        d = np.where(n > 1e-3, d / np.maximum(n, 1e-30), [0.0, 0.0, -1.0])
        L["direction"] = self.dir_to_world(d)
        L["type"][spot] = LIGHT_SPOT
        outer = rng.uniform(10.0, 80.0, k)
        L["cos_outer"][spot] = np.cos(np.radians(outer[spot]))
        L["cos_inner"][spot] = np.cos(np.radians(outer[spot] * 0.7))
        return L

    # -- rendering and checks ----------------------------------------------------------
    def render(self, lights, opts: dict | None = None, techniques=None) -> dict:
        return render_on(self.renderer, opts, techniques, lights=lights)

    def check(self, lights, opts: dict | None = None, where: str = "",
              must_light: bool = True, results: dict | None = None) -> dict:
        res = results or self.render(lights, opts)
        assert_exact(res, where)
        lo, hi, sure_hash = reference_counts(self.pos, self.cam, lights)
        brute = res["brute"]
        cnt = brute.contrib_count.astype(np.int64)
        under = int((cnt < lo).sum())
        over = int((cnt > hi).sum())
        assert under == 0 and over == 0, (
            f"{where}: brute disagrees with the float64 reference beyond float32 error: "
            f"{under} pixels below the sure count, {over} above the possible count")
        exact = lo == hi
        bad_hash = int((brute.contrib_hash[exact] != sure_hash[exact]).sum())
        assert bad_hash == 0, f"{where}: brute hash differs from the reference at {bad_hash} pixels"
        if must_light:
            assert lo.sum() > 0, f"{where}: case designed to light pixels lights none (test is vacuous)"
            assert cnt.sum() > 0
        return res


def reference_counts(pos4, cam, lights):
    """Per pixel (H, W): lights that surely affect the pixel, lights that may (float32
    rounding of the GPU test), and the contract hash of the sure set.  Float64 on the
    float32 inputs the GPU sees (view-space light data, see view_space()); candidate
    (pixel, light) pairs come from a k-d tree of the covered pixels' positions."""
    from scipy.spatial import cKDTree
    h, w = pos4.shape[:2]
    lo = np.zeros(h * w, np.int64)
    hi = np.zeros(h * w, np.int64)
    hsh = np.zeros(h * w, np.uint32)
    cov = np.flatnonzero(pos4[..., 3].reshape(-1) > 0)
    if len(cov) == 0 or len(lights) == 0:
        return lo.reshape(h, w), hi.reshape(h, w), hsh.reshape(h, w)
    P = pos4[..., :3].reshape(-1, 3)[cov].astype(np.float64)
    L, D = view_space(lights, cam)
    r = lights["radius"].astype(np.float64)
    reach = r * (1 + 1e-4) + 8 * F32_EPS * (np.abs(L).max(1) + np.abs(P).max()) + 1e-30
    near = cKDTree(P).query_ball_point(L, reach, return_sorted=False)
    counts = np.fromiter((len(x) for x in near), np.int64, len(near))
    if counts.sum() == 0:
        return lo.reshape(h, w), hi.reshape(h, w), hsh.reshape(h, w)
    li = np.repeat(np.arange(len(L)), counts)
    pi = np.fromiter((j for x in near for j in x), np.int64, int(counts.sum()))
    d = P[pi] - L[li]
    dist = np.sqrt((d * d).sum(-1))
    # float32: P - L rounds per component (<= 1 ulp of the larger operand); the dot product
    # and the compare add a few ulp of d2
    err = 4 * F32_EPS * (np.abs(P[pi]).max(1) + np.abs(L[li]).max(1)) + 8 * F32_EPS * dist
    sure = dist + err < r[li] * (1 - 8 * F32_EPS)
    maybe = dist - err < r[li] * (1 + 8 * F32_EPS)
    spot = lights["type"][li] == LIGHT_SPOT
    if spot.any():
        cos_o = lights["cos_outer"].astype(np.float64)[li]
        c = (d * D[li]).sum(-1) / np.maximum(dist, 1e-300)
        tol = 2 * err / np.maximum(dist, 1e-300) + 16 * F32_EPS
        sure &= ~spot | ((c > cos_o + tol) & (dist > err))
        maybe &= ~spot | (c > cos_o - tol) | (dist <= err)
    pix = cov[pi]
    lo += np.bincount(pix[sure], minlength=h * w)
    hi += np.bincount(pix[maybe], minlength=h * w)
    ids = mix(li[sure].astype(np.uint32))
    order = np.argsort(pix[sure], kind="stable")
    sp, ids = pix[sure][order], ids[order]
    if len(sp):
        starts = np.flatnonzero(np.r_[True, sp[1:] != sp[:-1]])
        hsh[sp[starts]] = np.bitwise_xor.reduceat(ids, starts)
    return lo.reshape(h, w), hi.reshape(h, w), hsh.reshape(h, w)


def view_space(lights, cam):
    """Light positions and directions in view space, float32 as the GPU receives them
    (float64 transform, rounded once), returned as float64."""
    m = cam.view_from_world
    pos = (lights["position"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    d = lights["direction"].astype(np.float64) @ m[:3, :3].T
    d = (d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-30)).astype(np.float32)
    return pos.astype(np.float64), d.astype(np.float64)


def visible_count(f, lights, opts=None) -> int:
    """Lights the CPU stage keeps (frustum cull) for this frame."""
    b = REGISTRY["brute"].build(FrameInput(lights, f.cam, f.scene.max_depth), None)
    return int(b.stats["visible_lights"])


def tie_radius(P, C, delta):
    """For the axis camera (view == world): round the centres C to float32 as the light
    buffer stores them, then give each light the float32 radius |P - C| (1 + delta), so the
    GPU's float32 test at P sits exactly on its rounding boundary for |delta| ~ ulp."""
    C32 = np.asarray(C, np.float64).astype(np.float32)
    dist = np.linalg.norm(np.asarray(P, np.float64) - C32.astype(np.float64), axis=-1)
    return C32, (dist * (1 + np.asarray(delta, np.float64))).astype(np.float32)


def concat(*arrays):
    return np.concatenate([a for a in arrays if len(a)])


def unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)

def lights_ending_on(rng, f, pixels, m: int = 24):
    """Lights whose volumes end on the depth b of `pixels` (a mask of the frame's; b their
    median depth), for the axis camera: m touching random ones of them along the view axis,
    from in front and from behind, at r (1 +- a few ulp) (tie_radius), and 8 whose depth
    range [c - r, c + r] ends on b.  -> (lights, b)."""
    b = float(np.median(f.pos[..., 3][pixels]))
    ys, xs = np.nonzero(pixels)
    i = rng.integers(0, len(ys), m)
    P = f.pos[ys[i], xs[i], :3].astype(np.float64)
    r = rng.uniform(0.001, 0.3, m) * b
    z = np.array([0.0, 0.0, 1.0])
    sign = np.where(np.arange(m) % 2 == 0, 1.0, -1.0)          # in front / behind
    delta = np.where(np.arange(m) % 4 == 0, -1e-4, rng.uniform(-4, 4, m) * F32_EPS)
    A = make_lights(m)
    A["position"], A["radius"] = tie_radius(P, P + sign[:, None] * z * r[:, None], delta)
    B = make_lights(8)
    rb = rng.uniform(0.001, 0.3, 8) * b
    sb = np.where(np.arange(8) % 2 == 0, 1.0, -1.0)
    B["position"] = np.column_stack([rng.uniform(-0.4, 0.4, (8, 2)) * b, -(b - sb * rb)])
    B["radius"] = rb
    return concat(A, B), b


# ---------------------------------------------------------------------------- the loop budget's frame

N_DECOYS, N_LIT = 66_000, 4_000
DEPTH = 20.5           # view depth of the band of floor pixels the case is about (2 rows)


def budget_frame() -> Frame:
    cam = Camera((0.0, 10.0, 0.0), (0.0, 0.0, -DEPTH), fov_y_deg=40.0, near=0.1, far=300.0)
    floor = box_mesh((-500.0, -1.0, -500.0), (500.0, 0.0, 500.0))
    return Frame(scene_of([floor], cam, size=(24, 16), max_depth=60.0))


def budget_lights(f: Frame, rng) -> tuple[np.ndarray, np.ndarray]:
    """(lights, the pixels' band mask): decoys first in depth order, lit lights after."""
    depth = f.pos[..., 3]
    band = np.abs(depth - DEPTH) < 1.3
    assert band.sum() >= 20, "no floor pixels at the case's depth"
    ys, xs = np.nonzero(band)
    i = rng.integers(0, len(ys), N_LIT)
    P = f.pos[ys[i], xs[i], :3].astype(np.float64)          # view space, on the floor
    lo_d, hi_d = float(depth[band].min()), float(depth[band].max())
    # decoys: 0.8 m above the floor pixels' band, depth inside it, radius 0.02
    D = P[rng.integers(0, N_LIT, N_DECOYS)].copy()
    D[:, 2] = -rng.uniform(lo_d - 0.5, hi_d - 0.05, N_DECOYS)
    D[:, 1] += 0.8
    decoys = make_lights(N_DECOYS)
    decoys["position"] = f.to_world(D)
    decoys["radius"] = 0.02
    # lit: on the floor pixels, centre pushed 0.05 m deeper than every decoy centre
    C = P.copy()
    C[:, 2] = np.minimum(C[:, 2], -(hi_d - 0.05)) - 0.05
    lit = make_lights(N_LIT)
    lit["position"] = f.to_world(C)
    lit["radius"] = np.linalg.norm(C - P, axis=1) + 0.3
    lit["color"] = rng.uniform(0.2, 1.0, (N_LIT, 3))
    return concat(decoys, lit), band
