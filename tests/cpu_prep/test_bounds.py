"""Conservative bounds: every point of a light's volume in front of the near plane projects
inside its screen rectangle; spot bounding spheres contain their cones."""
import math

import numpy as np
from hypothesis import assume, given, settings, strategies as st

from cpu_prep import bounds
from cpu_prep.camera import FrameCamera, perspective
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT


def camera(w=160, h=90, fov=60.0, near=0.1, far=1000.0):
    return FrameCamera(np.eye(4), perspective(fov, w / h, near, far), w, h, near, far,
                       math.tan(math.radians(fov) / 2))


def sphere_samples(rng, c, r, n=4000):
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return c + d * (r * rng.random(n) ** (1 / 3))[:, None]


def project_px(p, cam):
    d = -p[:, 2]
    x = (p[:, 0] / (d * cam.tan_half_x) * 0.5 + 0.5) * cam.width
    y = (p[:, 1] / (d * cam.tan_half_y) * 0.5 + 0.5) * cam.height
    return x, y


@settings(max_examples=300, deadline=None)
@given(st.floats(-20, 20), st.floats(-20, 20), st.floats(-60, 5), st.floats(0.01, 30),
       st.floats(1, 150), st.integers(0, 2**31))
def test_screen_rect_contains_projected_volume(cx, cy, cz, r, fov, seed):
    """Includes spheres that contain the eye, cross the near plane or lie behind it."""
    cam = camera(fov=fov)
    rng = np.random.default_rng(seed)
    c = np.array([[cx, cy, cz]])
    x0, x1, y0, y1 = bounds.screen_rects(c, np.array([r]), cam)
    pts = sphere_samples(rng, c[0], r)
    pts = pts[-pts[:, 2] >= cam.near]            # visible points only
    assume(len(pts) > 0)                         # else nothing to check: another example
    x, y = project_px(pts, cam)
    assert x.min() >= x0[0] and x.max() <= x1[0]
    assert y.min() >= y0[0] and y.max() <= y1[0]


def test_screen_rect_is_tight_for_a_sphere_ahead():
    cam = camera()
    x0, x1, y0, y1 = bounds.screen_rects(np.array([[0.0, 0.0, -20.0]]), np.array([1.0]), cam)
    # projected radius ~ r / sqrt(d^2 - r^2) / tan_half * size/2
    half = 1.0 / math.sqrt(399.0) / cam.tan_half_x * cam.width / 2
    assert abs((x1[0] - x0[0]) / 2 - (half + 1.0)) < 1e-6   # + PIXEL_MARGIN each side


@settings(max_examples=200, deadline=None)
@given(st.floats(0.5, 89.5), st.floats(0.01, 50), st.integers(0, 2**31))
def test_spot_bounding_sphere_contains_cone(angle, r, seed):
    rng = np.random.default_rng(seed)
    pos = rng.normal(size=(1, 3)) * 10
    d = rng.normal(size=(1, 3))
    d /= np.linalg.norm(d)
    cos_o = math.cos(math.radians(angle))
    c, rad = bounds.spot_bounding_spheres(pos, d, np.array([r]), np.array([cos_o]))
    pts = sphere_samples(rng, pos[0], r, 20000)
    v = pts - pos[0]
    inside = (v @ d[0]) > cos_o * np.linalg.norm(v, axis=1)
    assert rad[0] <= r + 1e-12
    dist = np.linalg.norm(pts[inside] - c[0], axis=1)
    assert dist.size == 0 or dist.max() <= rad[0] * (1 + 1e-9) + 1e-12


# ---- the other shapes: every point of the volume in front of the near plane projects inside
# the rectangle, and its depth lies in the depth range ------------------------------------

def _unit(v):
    return v / np.linalg.norm(v)


def _check_inside(pts, cam, rect):
    """The visible points of a volume lie in its rectangle and depth range; an example
    without one checks nothing, so Hypothesis draws another (assume)."""
    pts = pts[-pts[:, 2] >= cam.near]
    assume(len(pts) > 0)
    x0, x1, y0, y1, d0, d1 = rect
    x, y = project_px(pts, cam)
    d = -pts[:, 2]
    assert x.min() >= x0 and x.max() <= x1 and y.min() >= y0 and y.max() <= y1, (rect, x.min(), x.max(), y.min(), y.max())
    assert d.min() >= d0 and d.max() <= d1


def _bounds_of(t, p, d, right, radius, cos_o, length, ext, cam):
    """shape_bounds through the same culling sphere the cull kernel would use."""
    c, r = p, radius
    if t == LIGHT_SPOT:
        (c,), (r,) = bounds.spot_bounding_spheres(p[None], d[None], np.array([radius]), np.array([cos_o]))
    elif t == LIGHT_CAPSULE:
        r = radius + length / 2
    elif t == LIGHT_BOX:
        r = float(np.linalg.norm(ext))
    r = r * (1 + 1e-5) + 1e-6 * np.linalg.norm(c)
    return bounds.shape_bounds(t, *p, *d, *right, radius, cos_o, length, *ext, *c, r,
                               cam.near, cam.tan_half_x, cam.tan_half_y, float(cam.width), float(cam.height))


POS = st.tuples(st.floats(-15, 15), st.floats(-15, 15), st.floats(-40, 3))


def _posed(pos, fov, seed):
    """One example's camera, rng, light position and random unit direction."""
    rng = np.random.default_rng(seed)
    return camera(fov=fov), rng, np.array(pos), _unit(rng.normal(size=3))


@settings(max_examples=200, deadline=None)
@given(POS, st.floats(0.05, 10), st.floats(0.0, 30), st.floats(10, 150), st.integers(0, 2**31))
def test_capsule_rect_contains_its_volume(pos, r, length, fov, seed):
    cam, rng, p, d = _posed(pos, fov, seed)
    rect = _bounds_of(LIGHT_CAPSULE, p, d, np.zeros(3), r, 1.0, length, np.zeros(3), cam)
    t = rng.uniform(-length / 2, length / 2, 6000)
    pts = sphere_samples(rng, np.zeros(3), r, 6000) + p + t[:, None] * d
    _check_inside(pts, cam, rect)


@settings(max_examples=200, deadline=None)
@given(POS, st.tuples(st.floats(0.01, 8), st.floats(0.01, 8), st.floats(0.01, 8)),
       st.floats(10, 150), st.integers(0, 2**31))
def test_box_rect_contains_its_volume(pos, ext, fov, seed):
    """Boxes in front, across the near plane, around the eye and behind it."""
    cam, rng, p, d = _posed(pos, fov, seed)
    ext = np.array(ext)
    right = _unit(np.cross(d, _unit(rng.normal(size=3))))
    up = np.cross(right, d)
    rect = _bounds_of(LIGHT_BOX, p, d, right, 1.0, 1.0, 0.0, ext, cam)
    loc = rng.uniform(-1, 1, (6000, 3)) * ext
    loc[:64] = np.sign(rng.normal(size=(64, 3))) * ext          # the corners too
    pts = p + loc[:, :1] * right + loc[:, 1:2] * up + loc[:, 2:] * d
    _check_inside(pts, cam, rect)


@settings(max_examples=200, deadline=None)
@given(POS, st.floats(0.05, 20), st.floats(0.0, 90.0), st.floats(10, 150), st.integers(0, 2**31))
def test_spot_cone_rect_contains_its_volume(pos, r, angle, fov, seed):
    cam, rng, p, d = _posed(pos, fov, seed)
    cos_o = math.cos(math.radians(angle))
    rect = _bounds_of(LIGHT_SPOT, p, d, np.zeros(3), r, cos_o, 0.0, np.zeros(3), cam)
    v = sphere_samples(rng, np.zeros(3), r, 20000)
    inside = (v @ d) > cos_o * np.linalg.norm(v, axis=1)
    _check_inside(p + v[inside], cam, rect)


def test_cone_and_box_covers_are_tighter_than_spheres():
    """A narrow spot seen from the side and a thin box: the shape's own rectangle is much
    smaller than its bounding sphere's."""
    cam = camera()
    p, d = np.array([-3.0, 0.0, -20.0]), np.array([1.0, 0.0, 0.0])
    spot = _bounds_of(LIGHT_SPOT, p, d, np.zeros(3), 8.0, math.cos(math.radians(5)), 0, np.zeros(3), cam)
    sphere = bounds.screen_rects(p[None] + d * 4.0, np.array([4.0]), cam)
    area = lambda x0, x1, y0, y1: (x1 - x0) * (y1 - y0)
    assert area(*spot[:4]) < 0.3 * area(*(v[0] for v in sphere))
    box = _bounds_of(LIGHT_BOX, p, d, np.array([0.0, 0.0, 1.0]), 1.0, 1.0, 0, np.array([3.0, 3.0, 0.1]), cam)
    assert box[1] - box[0] < 0.5 * (box[3] - box[2])      # thin along x on screen


def test_fast_projection_equals_listing_1():
    """project_axis()'s form for a sphere wholly in front of the near plane against listing
    1's general one, over 1e-2..3 m near planes, 1e-2..1e5 m depths, radii up to the depth,
    1-150 degree fields of view, on and far off screen: under 1e-6 pixel on a 10,000-pixel
    screen where an edge can be on it (|n| <= 2), 1e-10 relative beyond."""
    import numba

    @numba.njit(error_model="numpy")
    def both(ca, cz, r, near_z, tan):
        out = np.empty((ca.shape[0], 4))
        for i in range(ca.shape[0]):
            a, b = bounds.project_axis(ca[i], cz[i], r[i], near_z[i], tan[i])
            c, d = bounds.project_axis_general(ca[i], cz[i], r[i], near_z[i], tan[i])
            out[i] = a, b, c, d
        return out

    rng = np.random.default_rng(7)
    n = 400_000
    near = 10 ** rng.uniform(-2, 0.5, n)
    depth = 10 ** rng.uniform(-2, 5, n)
    r = depth * 10 ** rng.uniform(-6, 0, n)
    tan = np.tan(np.radians(rng.uniform(1, 150, n)) / 2)
    ca = depth * tan * rng.uniform(-3, 3, n)
    ca[::7] *= 10 ** rng.uniform(0, 4, len(ca[::7]))
    ahead = -depth + r < -near
    assert ahead.sum() > n // 2
    o = both(ca[ahead], -depth[ahead], r[ahead], -near[ahead], tan[ahead])
    diff, ref = np.abs(o[:, :2] - o[:, 2:]), np.abs(o[:, 2:])
    assert np.all(diff[ref <= 2] * 5000 < 1e-6)
    assert np.all(diff <= 1e-10 * np.maximum(ref, 1))
