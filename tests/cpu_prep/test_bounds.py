"""Conservative bounds: every point of a light's volume in front of the near plane projects
inside its screen rectangle; spot bounding spheres contain their cones."""
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from cpu_prep import bounds
from cpu_prep.camera import FrameCamera, perspective


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
    if len(pts) == 0:
        return
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
