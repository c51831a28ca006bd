"""Hard cases for culling exactness: every REGISTRY technique against brute, per pixel.

Each case is built to sit on a boundary where a culling structure could lose a light: the
camera inside lights, lights straddling the near plane or reaching forward from behind the
eye, spheres within float32 epsilon of a frustum side plane, lights touching pixels on tile
edges and on depth-slice boundaries, very far and tiny lights, depth ties, odd screens,
extreme fields of view, spot cones, empty frames and cells past the 16-bit index widths.

Every case checks three things:
  1. all techniques give brute's contrib_count and contrib_hash at every pixel, finite images
     (tests.helpers.assert_exact);
  2. brute itself against a float64 CPU reference with float32 error bounds: per pixel the
     lights that surely affect it <= brute's count <= those that may, and where the two
     agree brute's hash equals the reference hash (so "all equal brute" cannot pass with a
     brute that drops lights);
  3. where a case is designed to light pixels, that it does (a test that cannot fail is not
     a test): anchor lights are placed on G-buffer positions, so some pixels are surely lit.

Resolutions are tiny (brute runs on a CPU rasterizer).  Hypothesis is derandomized so that
CI runs are reproducible; raise max_examples locally to search wider.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st

from app.errors import UserError
from app.pipeline.passes import FrameInput
from app.techniques import REGISTRY
from cpu_prep import grid as gridmod, layouts
from cpu_prep.camera import frame_camera
from cpu_prep.limits import NODE_MAX_LIGHTS, NODE_MAX_SKIP
from scenes.geometry import box_mesh
from scenes.model import LIGHT_POINT, LIGHT_SPOT, Camera, make_lights
from tests.helpers import floor_and_boxes, options, random_lights, takes
from tests.app.techniques.hard_frames import (F32_EPS, SEEDS, Frame, Options, axis_camera, concat, hyp,
                                              lights_ending_on, scene_of, street_camera, tie_radius,
                                              unit, view_space, visible_count, wall)


# ---------------------------------------------------------------------------- camera in lights

@hyp(15)
@given(seed=SEEDS, radius=st.floats(0.05, 40.0), offset=st.floats(0.0, 0.95),
       spot=st.booleans(), outer=st.floats(1.0, 89.0))
def test_camera_inside_one_light(gl, seed, radius, offset, spot, outer):
    rng = np.random.default_rng(seed)
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        L = make_lights(1)
        eye = np.array(f.scene.camera.position)
        L["position"] = eye + unit(rng.normal(size=3)) * radius * offset
        L["radius"] = radius
        if spot:
            L["type"] = LIGHT_SPOT
            L["direction"] = unit(rng.normal(size=3))
            L["cos_outer"] = math.cos(math.radians(outer))
            L["cos_inner"] = math.cos(math.radians(outer * 0.5))
        lights = concat(L, f.anchors(rng, 3))
        f.check(lights, where=f"camera in one light r={radius} offset={offset} spot={spot}")
        # a big enough point light around the eye reaches the floor at the bottom of the view
        if not spot and radius * (1 - offset) > 8.0:
            solo = f.render(L)
            assert solo["brute"].contrib_count.sum() > 0


@hyp(10)
@given(seed=SEEDS, n=st.integers(2, 300))
def test_camera_inside_many_lights(gl, seed, n):
    rng = np.random.default_rng(seed)
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        L = random_lights(rng, n, (-1, -1, -1), (1, 1, 1), radius=(0.5, 40.0), spot_share=0.3)
        eye = np.array(f.scene.camera.position)
        L["position"] = eye + unit(rng.normal(size=(n, 3))) * (
            L["radius"] * rng.uniform(0, 0.95, n))[:, None]
        L["radius"][:1], L["type"][:1] = 20.0, LIGHT_POINT  # at least one point light reaches the floor
        L["position"][0] = eye
        vpos, _ = view_space(L, f.cam)
        assert (np.linalg.norm(vpos, axis=1) < L["radius"]).all(), "eye not inside every light"
        f.check(L, where=f"camera in {n} lights")


# ---------------------------------------------------------------------------- near plane / behind

@hyp(25)
@given(seed=SEEDS, near=st.sampled_from([0.01, 0.1, 0.5, 2.0]), n=st.integers(1, 60),
       tile=st.sampled_from([4, 8, 48]))
def test_lights_straddling_near_plane(gl, seed, near, n, tile):
    """Light centres at depth near +- r (spots too), inside and beside the view: the
    Mara-McGuire rectangles clip at the near plane, one tangent point in front of it and
    the other behind.  A wall just behind the near plane makes small lights count; small
    tiles make a rectangle that misses part of the clipped sphere miss pixels."""
    rng = np.random.default_rng(seed)
    cam = axis_camera(fov=70.0, near=near, far=200.0)
    meshes = [wall(near * 1.5 + 0.05, half=50.0)] + floor_and_boxes()
    with Frame(scene_of(meshes, cam)) as f:
        r = rng.uniform(0.05, 3.0, n) * max(near, 0.1) * rng.choice([1.0, 10.0], n)
        depth = near + r * rng.uniform(-0.99, 0.99, n)
        t = math.tan(math.radians(35.0))
        reach = np.maximum(depth, near)[:, None] * np.array([t * 64 / 48, t])
        xy = rng.uniform(-1.0, 1.0, (n, 2)) * (reach + r[:, None] * 1.5)
        L = make_lights(n)
        L["position"] = np.column_stack([xy, -depth])
        L["radius"] = r
        spot = rng.random(n) < 0.3
        L["type"][spot] = LIGHT_SPOT
        L["direction"] = unit(rng.normal(size=(n, 3)) + [0, 0, -1.5])
        L["cos_outer"][spot] = np.cos(np.radians(rng.uniform(5, 85, spot.sum())))
        L["cos_inner"][spot] = L["cos_outer"][spot]
        f.check(concat(L, f.anchors(rng, 2)), Options(tile=tile), where=f"near plane {near}")


@hyp(15)
@given(seed=SEEDS, n=st.integers(1, 40))
def test_lights_behind_camera_reaching_forward(gl, seed, n):
    """Centres behind the eye (negative depth), volumes reaching past the near plane."""
    rng = np.random.default_rng(seed)
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        back = np.asarray(f.cam.view_from_world[2, :3])         # view +z in world: behind the eye
        eye = np.array(f.scene.camera.position)
        behind = rng.uniform(0.05, 10.0, n)
        lateral = rng.normal(size=(n, 3)) * rng.uniform(0, 2, (n, 1))
        lateral -= (lateral @ back)[:, None] * back
        L = make_lights(n)
        L["position"] = eye + back * behind[:, None] + lateral
        L["radius"] = behind + np.linalg.norm(lateral, axis=1) + rng.uniform(0.5, 15.0, n)
        spot = rng.random(n) < 0.5
        L["type"][spot] = LIGHT_SPOT
        fwd = -back
        L["direction"][spot] = unit(fwd + rng.normal(size=(spot.sum(), 3)) * 0.3)
        L["cos_outer"][spot] = np.cos(np.radians(rng.uniform(10, 89, spot.sum())))
        L["cos_inner"][spot] = L["cos_outer"][spot]
        # one guaranteed reach: a point light 1 m behind the eye, radius 20
        L["position"][0], L["radius"][0], L["type"][0] = eye + back * 1.0, 20.0, LIGHT_POINT
        vpos, _ = view_space(L, f.cam)
        assert (vpos[:, 2] > 0).all(), "light centres must be behind the eye"
        f.check(L, where="behind the camera")


# ---------------------------------------------------------------------------- frustum edges

SIDES = {  # outward normal of each side plane (view space), as a function of (tan_x, tan_y)
    "left": lambda tx, ty: unit([-1.0, 0.0, tx]),
    "right": lambda tx, ty: unit([1.0, 0.0, tx]),
    "bottom": lambda tx, ty: unit([0.0, -1.0, ty]),
    "top": lambda tx, ty: unit([0.0, 1.0, ty]),
}


@hyp(20)
@given(seed=SEEDS, fov=st.floats(20.0, 120.0), depth=st.floats(1.0, 60.0),
       size=st.sampled_from([(64, 48), (61, 37), (96, 17)]))
def test_lights_within_float32_epsilon_of_frustum_sides(gl, seed, fov, depth, size):
    """Two kinds of edge lights on each side plane of the frustum:
    a) spheres tangent to the side plane from outside, off by a few float32 ulp of r either
       way: they must survive the frustum cull (conservative) and light nothing wrongly;
    b) centres outside the frustum whose sphere reaches an edge pixel's G-buffer position by
       r (1 +- a few ulp): whether the pixel is lit is decided by float32 rounding, and every
       technique must agree with brute."""
    rng = np.random.default_rng(seed)
    cam = axis_camera(fov=fov, near=0.1, far=500.0)
    with Frame(scene_of([wall(depth)], cam, size=size, max_depth=100.0)) as f:
        tx, ty = f.cam.tan_half_x, f.cam.tan_half_y
        h, w = f.pos.shape[:2]
        tangent, touching = [], []
        footprint = 2 * depth * ty / h          # one pixel at the wall's depth
        for side, normal in SIDES.items():
            n = normal(tx, ty)
            for _ in range(4):
                r = rng.uniform(0.01, 3.0)
                # a: tangent point Q on the side plane at the wall's depth
                along = rng.uniform(-0.9, 0.9)
                if side in ("left", "right"):
                    q = [(1 if side == "right" else -1) * tx * depth, along * ty * depth, -depth]
                else:
                    q = [along * tx * depth, (1 if side == "top" else -1) * ty * depth, -depth]
                delta = rng.integers(-3, 4) * F32_EPS
                tangent.append((np.asarray(q) + n * r * (1 + delta), r))
                # b: an edge pixel (row 0 = top)
                if side == "left":
                    py, px = rng.integers(0, h), 0
                elif side == "right":
                    py, px = rng.integers(0, h), w - 1
                elif side == "top":
                    py, px = 0, rng.integers(0, w)
                else:
                    py, px = h - 1, rng.integers(0, w)
                P = f.pos[py, px, :3].astype(np.float64)
                r = footprint * rng.uniform(1.5, 20.0)      # centre outside the frustum
                C, rt = tie_radius(P, P + n * r, rng.uniform(-4, 4) * F32_EPS)
                touching.append((C, rt))
                touching.append((P + n * r * (1 - 1e-4), r))      # surely lit
        A = make_lights(len(tangent))
        A["position"] = [c for c, _ in tangent]
        A["radius"] = [r for _, r in tangent]
        B = make_lights(len(touching))
        B["position"] = [c for c, _ in touching]
        B["radius"] = [r for _, r in touching]
        res = f.check(concat(A, B), where=f"frustum edges fov={fov} depth={depth} size={size}")
        # (a) alone: all kept by the conservative frustum cull
        kept = visible_count(f, A)
        assert kept == len(A), (
            f"frustum cull dropped {len(A) - kept} of {len(A)} lights tangent to a side "
            f"plane within float32 epsilon")
        # (b) centres are outside the frustum, and some edge pixels are lit
        c = B["position"].astype(np.float64)
        outside = ((c[:, 0] < -tx * -c[:, 2]) | (c[:, 0] > tx * -c[:, 2])
                   | (c[:, 1] < -ty * -c[:, 2]) | (c[:, 1] > ty * -c[:, 2]))
        assert outside.all()
        assert res["brute"].contrib_count.sum() > 0


def _plane_normal(a: float, axis: int) -> np.ndarray:
    """Unit normal of the plane through the eye where view x/depth (axis 0) or y/depth
    (axis 1) equals a: pointing towards larger x (or y)."""
    n = np.zeros(3)
    n[axis], n[2] = 1.0, a
    return unit(n)


@hyp(15)
@given(seed=SEEDS, tile=st.sampled_from([4, 7, 16, 32, 48]), depth=st.floats(1.0, 80.0),
       size=st.sampled_from([(96, 64), (64, 48), (50, 37)]))
def test_lights_on_tile_boundaries(gl, seed, tile, depth, size):
    """Lights whose centre lies across a tile edge from the pixel they touch, at distance
    r (1 +- a few ulp): the pixel's tile must list the light.  Positions from the tile edges
    of the grid (x = k * tile pixels) and the G-buffer positions of the pixels beside them."""
    rng = np.random.default_rng(seed)
    cam = axis_camera(fov=60.0, near=0.1, far=500.0)
    floor = box_mesh((-1e3, -3.0, -1e3), (1e3, -2.0, 1e3))
    opts = Options(tile=tile)
    with Frame(scene_of([wall(depth), floor], cam, size=size, max_depth=150.0)) as f:
        w, h = size
        tx, ty = f.cam.tan_half_x, f.cam.tan_half_y
        grid = gridmod.make_grid(f.cam, tile, opts["slices"], 150.0, opts["near_slice_depth"])
        assert grid.tiles_x > 1 or grid.tiles_y > 1
        centres, radii, aims = [], [], []
        for axis, count, size_px, tan in ((0, grid.tiles_x, w, tx), (1, grid.tiles_y, h, ty)):
            for k in range(1, count):
                edge = k * tile                       # pixel edge between tiles k-1 and k (GL)
                a = (2.0 * edge / size_px - 1.0) * tan
                n = _plane_normal(a, axis)
                for side, sign in ((edge - 1, 1.0), (edge, -1.0)):   # pixel left/below, right/above
                    for _ in range(2):
                        other = rng.integers(0, h if axis == 0 else w)
                        gx, gy = (side, other) if axis == 0 else (other, side)
                        P = f.pos[h - 1 - gy, gx]             # GL row gy -> image row
                        if P[3] <= 0:
                            continue
                        r = rng.uniform(0.005, 2.0)
                        C = P[:3].astype(np.float64) + sign * n * r
                        for delta in (rng.uniform(-4, 4) * F32_EPS, -1e-4):
                            c32, r32 = tie_radius(P[:3], C, delta)
                            centres.append(c32)
                            radii.append(r32)
                            aims.append(-sign * n)            # a spot's axis runs through P
        L = make_lights(len(centres))
        L["position"] = centres
        L["radius"] = radii
        L["direction"] = aims
        spot = rng.random(len(L)) < 0.3
        L["type"][spot] = LIGHT_SPOT
        L["cos_outer"][spot] = np.cos(np.radians(rng.uniform(1.0, 89.0, spot.sum())))
        L["cos_inner"][spot] = L["cos_outer"][spot]
        f.check(L, opts, where=f"tile edges tile={tile} depth={depth} size={size}")


def _max_depth_for_boundary(cam, opts: dict, k: int, target: float) -> float | None:
    """The scene max_depth (<= 1e5) that puts the lower bound of depth slice k of the grid
    exactly at `target` (bisection on make_grid(...).slice_bounds(): no copy of the slicing
    formula), or None if no such max_depth exists."""
    def bound(md):
        g = gridmod.make_grid(cam, opts["tile"], opts["slices"], md, opts["near_slice_depth"])
        return float(g.slice_bounds()[0][k])
    lo, hi = target * 1.0001, 1e5
    if not bound(lo) <= target <= bound(hi):
        return None
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if bound(mid) < target:
            lo = mid
        else:
            hi = mid
        if hi / lo - 1 < 1e-15:
            break
    assert abs(bound(hi) / target - 1) < 1e-12
    return hi




@hyp(8)
@given(seed=SEEDS, slices=st.sampled_from([3, 5, 16, 32]), depth=st.floats(6.0, 800.0),
       pick=st.floats(0.0, 1.0))
def test_lights_on_depth_slice_boundaries(gl, seed, slices, depth, pick):
    """A wall at depth D; the scene's max_depth is chosen so that a slice boundary of the
    grid (slice_bounds()) falls exactly on the wall's pixel depth, then swept over a few
    float32 ulp around it, so the GPU's float32 log() puts the wall's pixels on either side.
    Lights touch the wall's pixels along the view axis from in front and from behind at
    r (1 +- a few ulp), others have a depth range ending exactly on the boundary; a floor
    crosses every boundary with lights centred on them."""
    rng = np.random.default_rng(seed)
    size = (32, 24)
    cam = axis_camera(fov=60.0, near=0.1, far=1e5)
    opts = Options(slices=slices, tile=8)
    fc = frame_camera(cam, *size)
    floor = box_mesh((-1e5, -3.0, -1e5), (1e5, -2.0, 1e5))
    with Frame(scene_of([wall(depth), floor], cam, size=size)) as f:
        wall_px = np.abs(f.pos[..., 3] - depth) < depth * 1e-4
        assert wall_px.sum() > 10
        L, b = lights_ending_on(rng, f, wall_px)
        ks = [k for k in range(2, slices) if _max_depth_for_boundary(fc, opts, k, b) is not None]
        assume(ks)     # e.g. 3 slices: no max_depth <= 1e5 puts a boundary past ~707 m
        k = ks[int(pick * len(ks) * 0.999)]
        # The GPU's float32 log() moves a slice boundary by up to ~1e-6 of the depth (measured
        # on llvmpipe); sweep the boundary over +-1.3e-6 around the wall's pixel depth.
        lo_b, _ = gridmod.make_grid(fc, opts["tile"], slices, 1e4, opts["near_slice_depth"]).slice_bounds()
        C = make_lights(len(lo_b) - 1)             # on the floor, at boundary depths
        C["position"] = np.column_stack([rng.uniform(-0.3, 0.3, len(C)) * lo_b[1:],
                                         np.full(len(C), -2.0), -lo_b[1:]])
        C["radius"] = 0.05 * lo_b[1:] + 0.5
        L = concat(L, C)
        others = [n for n in REGISTRY if n != "brute"]
        brute = f.render(L, opts, techniques=["brute"])
        for j in range(-13, 14):
            target = b * (1 + j * 1e-7)
            md = _max_depth_for_boundary(fc, opts, k, target)
            assert md is not None
            f.scene.max_depth = md
            res = dict(brute, **f.render(L, opts, techniques=others))
            f.check(L, opts, where=f"slice {k}/{slices} boundary at {target!r} (wall {b!r})",
                    results=res)


# ---------------------------------------------------------------------------- far and tiny

@hyp(12)
@given(seed=SEEDS, n=st.integers(5, 80))
def test_very_far_lights(gl, seed, n):
    """Far plane 1e5, a huge floor and a wall at 9e4: lights at depth 1e3 .. 1e5 (some
    beyond the far plane, reaching back over it)."""
    rng = np.random.default_rng(seed)
    cam = Camera((0.0, 20.0, 0.0), (0.0, 0.0, -3e4), (0.0, 1.0, 0.0), 60.0, 0.5, 1e5)
    meshes = [box_mesh((-1e5, -1.0, -1e5), (1e5, 0.0, 1e3)),
              box_mesh((-1e5, 0.0, -9.1e4), (1e5, 5e4, -9e4))]
    with Frame(scene_of(meshes, cam, max_depth=1e5)) as f:
        far = f.pos[..., 3] >= 1e3
        assert far.any()
        ys, xs = np.nonzero(far)
        i = rng.integers(0, len(ys), n)
        P = f.pos[ys[i], xs[i], :3].astype(np.float64)
        r = -P[:, 2] * rng.uniform(0.002, 0.2, n)
        A = make_lights(n)
        A["position"] = f.to_world(P + unit(rng.normal(size=(n, 3))) * (r * rng.uniform(0, 0.7, n))[:, None])
        A["radius"] = r
        # random far lights, some beyond the far plane
        B = random_lights(rng, n, (-3e4, 0, -1.2e5), (3e4, 3e3, -1e3), radius=(10.0, 5e3))
        f.check(concat(A, B), where="far lights")


@hyp(12)
@given(seed=SEEDS, n=st.integers(10, 200), camera=st.sampled_from(["street", "axis"]))
def test_tiny_lights_on_surfaces(gl, seed, n, camera):
    """Radius 1e-3 lights centred right on the G-buffer surface points (within r/2), so
    each lights its pixel; spots among them aim at the surface."""
    rng = np.random.default_rng(seed)
    if camera == "street":
        cam, meshes = street_camera(), floor_and_boxes()
    else:
        cam, meshes = axis_camera(near=0.01), [wall(7.5), box_mesh((-1, -1, -4), (0, 0, -3))]
    with Frame(scene_of(meshes, cam)) as f:
        L = f.anchors(rng, n, radius=(1e-3, 1e-3), spot_share=0.3)
        f.check(L, where=f"tiny lights ({camera})")


# ---------------------------------------------------------------------------- ties

@hyp(12)
@given(seed=SEEDS, n=st.integers(2, 400), dup=st.integers(0, 50), tile=st.sampled_from([8, 48]))
def test_many_lights_at_identical_depth(gl, seed, n, dup, tile):
    """All lights at one view depth (the wall's), plus exact duplicates: the depth sort, the
    per-cell lists and tree node bounds all see ties."""
    rng = np.random.default_rng(seed)
    depth = 12.0
    with Frame(scene_of([wall(depth)], axis_camera())) as f:
        L = make_lights(n + dup)
        xy = rng.uniform(-1, 1, (n, 2)) * depth * np.array([f.cam.tan_half_x, f.cam.tan_half_y])
        L["position"][:n] = np.column_stack([xy, np.full(n, -depth)])
        L["position"][n:] = L["position"][0]
        L["radius"][:n] = rng.uniform(0.05, 4.0, n)
        L["radius"][0] = max(L["radius"][0], 0.5)          # the duplicated light lights the wall
        L["radius"][n:] = L["radius"][0]
        f.check(L, Options(tile=tile), where=f"ties n={n} dup={dup}")


# ---------------------------------------------------------------------------- screens

ODD_SIZES = [(1, 1), (257, 3), (3, 257), (2, 1), (1, 2), (49, 47), (97, 65)]


@hyp(25)
@given(seed=SEEDS, size=st.one_of(st.sampled_from(ODD_SIZES),
                                  st.tuples(st.integers(1, 110), st.integers(1, 80))),
       tile=st.sampled_from([4, 5, 16, 33, 48, 64]))
def test_odd_screen_sizes(gl, seed, size, tile):
    """Screens that are no multiple of the tile (or of the 8x8 shading group), 1x1, very
    wide and very tall."""
    rng = np.random.default_rng(seed)
    with Frame(scene_of(floor_and_boxes(), street_camera(), size=size)) as f:
        L = concat(f.anchors(rng, 4, radius=(0.5, 6.0), spot_share=0.3),
                   random_lights(rng, 40, (-10, 0, -30), (10, 8, 5)))
        f.check(L, Options(tile=tile), where=f"size {size} tile {tile}")


@pytest.mark.parametrize("size", [(1, 1), (257, 3), (3, 257)])
def test_degenerate_screens_named(gl, size):
    """The three named shapes always run (hypothesis may not draw them)."""
    rng = np.random.default_rng(sum(size))
    with Frame(scene_of(floor_and_boxes(), street_camera(), size=size)) as f:
        L = concat(f.anchors(rng, 3), random_lights(rng, 30, (-10, 0, -30), (10, 8, 5)))
        for tile in (4, 48):
            f.check(L, Options(tile=tile), where=f"size {size} tile {tile}")


# ---------------------------------------------------------------------------- field of view

@hyp(20)
@given(seed=SEEDS, fov=st.one_of(st.sampled_from([1.0, 150.0]), st.floats(1.0, 150.0)))
def test_vertical_fov_1_to_150(gl, seed, fov):
    rng = np.random.default_rng(seed)
    with Frame(scene_of(floor_and_boxes(), street_camera(fov_y_deg=fov))) as f:
        L = concat(f.anchors(rng, 6, radius=(0.01, 5.0), spot_share=0.3),
                   random_lights(rng, 60, (-40, 0, -60), (40, 10, 12)))
        f.check(L, where=f"fov {fov}")


# ---------------------------------------------------------------------------- spot cones

@hyp(20)
@given(seed=SEEDS, outer=st.one_of(st.sampled_from([0.5, 89.5, 90.0]), st.floats(0.5, 90.0)),
       edge=st.sampled_from(["hard", "soft", "inner 0"]))
def test_spot_cones_pointing_at_camera(gl, seed, outer, edge):
    """Spots from 0.5 to 90 degrees (glTF's range; inner == outer for a hard edge, inner 0 as
    glTF's default) pointing at the eye: behind surface points (the axis runs through the
    pixel: surely lit), in open space (the eye inside the cone), and around the eye."""
    rng = np.random.default_rng(seed)
    inner = {"hard": outer, "soft": outer * 0.5, "inner 0": 0.0}[edge]
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        eye_v = np.zeros(3)
        P = f.pixel_points(rng, 12)
        dist = np.linalg.norm(P, axis=1)
        # behind the surface point, on the line eye -> P
        C1 = P * (1 + rng.uniform(0.001, 0.2, 12))[:, None]
        r1 = np.linalg.norm(C1, axis=1) - dist + rng.uniform(0.5, 5.0, 12)
        # in front of the geometry, aiming at the eye
        C2 = P * rng.uniform(0.05, 0.9, 12)[:, None]
        r2 = np.linalg.norm(C2, axis=1) * rng.uniform(0.5, 1.5, 12)
        # around the eye
        C3 = unit(rng.normal(size=(6, 3))) * rng.uniform(0.0, 2.0, (6, 1))
        r3 = rng.uniform(0.5, 20.0, 6)
        C = np.concatenate([C1, C2, C3])
        r = np.concatenate([r1, r2, r3])
        d = eye_v - C
        d[np.linalg.norm(d, axis=1) < 1e-6] = [0.0, 0.0, 1.0]
        L = make_lights(len(C))
        L["type"] = LIGHT_SPOT
        L["position"] = f.to_world(C)
        L["radius"] = r
        L["direction"] = f.dir_to_world(unit(d))
        L["cos_outer"] = 0.0 if outer == 90.0 else math.cos(math.radians(outer))   # as the loader stores it
        L["cos_inner"] = math.cos(math.radians(inner))
        f.check(L, where=f"spots outer={outer} inner={inner}")


# ---------------------------------------------------------------------------- empty frames

def _no_visible(kind: str, cam) -> np.ndarray:
    rng = np.random.default_rng(7)
    n = 50
    L = random_lights(rng, n, (-1, -1, -1), (1, 1, 1), radius=(0.1, 3.0), spot_share=0.4)
    fwd = np.array([0.0, 0.0, -1.0])
    if kind == "none":
        return make_lights(0)
    if kind == "behind":                    # whole volume behind the near plane
        depth = -(L["radius"] + rng.uniform(0.2, 5.0, n))
        L["position"] = np.column_stack([rng.uniform(-3, 3, (n, 2)), -depth])
    elif kind == "beyond_far":
        depth = cam.far + L["radius"] * 1.01 + rng.uniform(0.0, 100.0, n)
        L["position"] = np.column_stack([rng.uniform(-3, 3, (n, 2)), -depth])
    elif kind == "outside_sides":           # left of the frustum by more than r (+ margins)
        depth = rng.uniform(1.0, 100.0, n)
        t = math.tan(math.radians(cam.fov_y_deg) / 2) * 64 / 48
        side = rng.choice([-1.0, 1.0], n)
        x = side * (t * depth * 1.2 + L["radius"] * math.sqrt(1 + t * t) * 1.2 + 0.5)
        L["position"] = np.column_stack([x, rng.uniform(-1, 1, n), -depth])
    elif kind == "spots_facing_away_behind":   # apex behind the eye, cone facing away,
        L["type"] = LIGHT_SPOT                 # sphere alone would reach far in front
        L["position"] = np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(0.01, 1.0, n)])
        L["radius"] = rng.uniform(5.0, 30.0, n)
        L["direction"] = -fwd                  # (up to 44 degrees the bounding sphere is
        L["cos_outer"] = L["cos_inner"] = np.cos(np.radians(rng.uniform(1.0, 44.0, n)))  # tight)
    return L


@pytest.mark.parametrize("kind", ["none", "behind", "beyond_far", "outside_sides",
                                  "spots_facing_away_behind"])
def test_no_visible_lights(gl, kind):
    cam = axis_camera(fov=60.0, near=0.1, far=150.0)
    with Frame(scene_of([wall(20.0), box_mesh((-50, -3, -200), (50, -2, 0))], cam)) as f:
        L = _no_visible(kind, cam)
        res = f.check(L, where=f"no visible lights: {kind}", must_light=False)
        for name, r in res.items():
            assert r.meta["stats"]["visible_lights"] == 0, f"{name}: {kind} lights not culled"
            assert int(r.evaluated.sum()) == 0, f"{name} evaluated lights in an empty frame"
            assert int(r.contrib_count.sum()) == 0
            assert np.isfinite(r.image).all() and (r.image == 0).all()
        assert f.covered.any()


# ---------------------------------------------------------------------------- index widths

PACKED_SIZE = (16, 16)       # one tile at the default 48-pixel tile
PACKED_MAX_DEPTH = 100.0


def _packed_frame() -> "Frame":
    """Axis camera, a wall in the middle of the default grid's depth slice around 20 m, on a
    single-tile screen: every light near the wall falls in one cell."""
    cam = axis_camera(fov=60.0, near=0.1, far=300.0)
    opts = Options()
    grid = gridmod.make_grid(frame_camera(cam, *PACKED_SIZE), opts["tile"], opts["slices"],
                             PACKED_MAX_DEPTH, opts["near_slice_depth"])
    assert grid.tiles_x == grid.tiles_y == 1
    lo_b, hi_b = grid.slice_bounds()
    k = int(grid.slice_of(20.0))
    depth = float(math.sqrt(lo_b[k] * hi_b[k]))
    assert hi_b[k] - lo_b[k] > 2.0
    return Frame(scene_of([wall(depth, half=100.0)], cam, size=PACKED_SIZE,
                          max_depth=PACKED_MAX_DEPTH))


def _packed_lights(f: "Frame", n: int, rng) -> np.ndarray:
    """n small point lights inside the view, within +-0.5 m of the wall's depth (one slice),
    64 of them on the wall's pixels so the cell lights something."""
    depth = float(np.median(f.pos[..., 3][f.covered]))
    L = make_lights(n)
    xy = rng.uniform(-0.95, 0.95, (n, 2)) * depth * np.array([f.cam.tan_half_x, f.cam.tan_half_y])
    L["position"] = np.column_stack([xy, -depth + rng.uniform(-0.5, 0.5, n)])
    L["radius"] = 0.02
    m = min(64, n)
    L["position"][:m] = f.pixel_points(rng, m)
    L["radius"][:m] = 0.3
    return L


def _leaf_checks(name, build, n):
    if "nodes" not in build.buffers:
        return
    nodes = build.buffers["nodes"]
    is_leaf, count, skip = layouts.unpack_node_bits(nodes["bits"])
    assert count[is_leaf].max() <= NODE_MAX_LIGHTS
    assert skip.max() <= NODE_MAX_SKIP
    assert int(count[is_leaf].sum()) == int(build.stats["list_entries"]) == n, \
        f"{name}: leaves hold {int(count[is_leaf].sum())} entries of {n}"


@pytest.mark.parametrize("n", [65_535, 65_536])
def test_cell_light_counts_at_16_bit_width(gl, n):
    """Exactly 65,535 / 65,536 lights in one tile and one depth slice (a 16x16 screen, one
    tile): the 16-bit leaf light count of tree/hybrid must fall back (more leaves) instead of
    wrapping at its first count past the width (more lights than that: test_loop_budget's
    70,000, the stress scene's).  Rendered with options that force one-leaf cells:
    max_leaves=1 (tree and hybrid), and radius_scale=1e-3 (the hybrid chooses lists)."""
    rng = np.random.default_rng(n)
    with _packed_frame() as f:
        L = _packed_lights(f, n, rng)
        brute = f.render(L, techniques=["brute"])
        all_opts = [Options(max_leaves=1), Options(radius_scale=1e-3)]
        fi = FrameInput(L, f.cam, PACKED_MAX_DEPTH)
        for k, opts in enumerate(all_opts):
            # the second option set: only the techniques it changes (the others' frames
            # would be the first set's again)
            changed = {o for o in {*opts, *all_opts[0]} if opts.get(o) != all_opts[0].get(o)}
            names = [x for x in REGISTRY if k == 0 or any(takes(x, o) for o in changed)]
            for name in names:
                b = REGISTRY[name].build(fi, options(name, **opts))
                assert b.stats["visible_lights"] == n
                if "list_entries" in b.stats:
                    assert b.stats["list_entries"] == n, f"{name}: lights not all in one cell"
                _leaf_checks(name, b, n)
            others = [x for x in names if x != "brute"]
            assert "tree" in others and "hybrid" in others
            res = dict(brute, **f.render(L, opts, techniques=others))
            f.check(L, opts, where=f"{n} lights in one cell, {opts}", results=res)


@pytest.mark.parametrize("max_leaves,ok", [(16384, True), (32768, False)])
def test_tree_skip_count_at_15_bit_width(gl, max_leaves, ok):
    """One tile holding 16,400 lights with lights_per_leaf=1: max_leaves=16384 gives trees
    of 32,767 nodes (the 15-bit skip count exactly); 32768 would need 65,535 and must be
    refused with a clear error, never wrapped.  Techniques without trees are unaffected."""
    rng = np.random.default_rng(max_leaves)
    n = 16_400
    with _packed_frame() as f:
        L = _packed_lights(f, n, rng)
        opts = Options(lights_per_leaf=1, max_leaves=max_leaves)
        res, refused = {}, {}
        for name in REGISTRY:
            try:
                res[name] = f.renderer.render(REGISTRY[name], 0, options(name, **opts), lights=L)
            except UserError as exc:
                refused[name] = str(exc)
        # every technique with trees refuses past the width (its own one line), every other renders
        want = set() if ok else {n for n in REGISTRY if takes(n, "max_leaves")}
        assert set(refused) == want and set(res) == set(REGISTRY) - want, \
            f"refused {sorted(refused)}, rendered {sorted(res)}; expected {sorted(want)} to refuse"
        for name, msg in refused.items():
            assert "15 bits" in msg or "skip" in msg, f"{name}: unclear refusal: {msg}"
            assert "\n" not in msg
        if ok:
            for name in REGISTRY:
                b = REGISTRY[name].build(FrameInput(L, f.cam, PACKED_MAX_DEPTH), options(name, **opts))
                if "nodes" in b.buffers:
                    _, _, skip = layouts.unpack_node_bits(b.buffers["nodes"]["bits"])
                    assert skip.max() == NODE_MAX_SKIP, f"{name}: tree not at the skip width"
        f.check(L, opts, where=f"skip width max_leaves={max_leaves}", results=res)


def test_more_than_65536_lights_in_one_tile_default_options(gl):
    """70,000 small lights packed in one tile's frustum, default options (the tree splits
    the tile into 64 leaves; the hybrid picks per cell)."""
    rng = np.random.default_rng(70_000)
    with _packed_frame() as f:
        L = _packed_lights(f, 70_000, rng)
        f.check(L, where="70,000 lights in one tile")


@pytest.mark.parametrize("capacity", [1, 37, 400])
def test_light_list_pool_overflow_shades_every_light(gl, monkeypatch, capacity):
    """Techniques that allocate per-tile lists from one fixed pool (a module constant
    POOL_MAX_ENTRIES, e.g. tiled's 8M entries) must flag tiles whose list does not fit and
    shade every light there, never drop one.  The pool is shrunk so that it overflows at
    this tiny size."""
    import sys as _sys
    pooled = {n: _sys.modules[type(t).__module__] for n, t in REGISTRY.items()
              if hasattr(_sys.modules[type(t).__module__], "POOL_MAX_ENTRIES")}
    if not pooled:
        pytest.skip("no technique allocates from a fixed pool")
    rng = np.random.default_rng(capacity)
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        L = concat(f.anchors(rng, 20, radius=(0.5, 4.0), spot_share=0.3),
                   random_lights(rng, 150, (-10, 0, -30), (10, 8, 5)))
        opts = Options(tile=8)
        brute = f.render(L, opts, techniques=["brute"])
        visible = brute["brute"].meta["stats"]["visible_lights"]
        for mod in pooled.values():
            monkeypatch.setattr(mod, "POOL_MAX_ENTRIES", capacity)
        res = dict(brute, **f.render(L, opts, techniques=list(pooled)))
        f.check(L, opts, where=f"pool of {capacity} entries", results=res)
        for n in pooled:
            full = res[n].evaluated == visible
            assert full.any(), f"{n}: no tile overflowed a pool of {capacity} entries"
            assert not full[f.covered].all() or capacity == 1
