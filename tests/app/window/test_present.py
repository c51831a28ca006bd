"""The window's own passes in this process's EGL context (the `gl` fixture), with no window:
the GLSL twins of app/images.py (display, exposure histogram, heat map) give the Python
functions' pixels, and the diff view marks exactly the pixels whose light set differs from
the stashed reference's."""
from __future__ import annotations

import numpy as np
import pytest

from app import images
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from app.window import passes
from app.views import HEAT_OF, VIEWS

SIZE = (96, 54)


@pytest.fixture(scope="module")
def frame(gl):
    from scenes import load_scene
    scene = load_scene("city", lights=2048, seed=3)
    with Renderer(scene, SIZE) as r:
        yield r, scene, r.render(REGISTRY["clustered"])


def _albedo(r):
    w, h = r.size
    raw = np.frombuffer(r.gbuffer.albedo.read(), np.uint8).reshape(h, w, 4)
    return raw[::-1, :, :3].astype(np.float32) / 255.0


def _stats(r, reference=False, stash=None):
    r.gbuffer.bind_textures()
    if stash is not None:
        stash.bind()
    r.run([passes.view_stats_pass(r.size, reference)])
    return r.read(passes.VIEW_STATS)[0], passes.read_extra(r.read(passes.VIEW_EXTRA))


def _present(r, view, **uniforms):
    """The view drawn into an offscreen framebuffer, image order (row 0 = top)."""
    w, h = r.size
    fbo = r.ctx.simple_framebuffer((w, h), components=4)
    u = {"u_exposure": 1.0, "u_ambient": 0.0, "u_heat_max": 10.0,
         "u_heat_of": 0, "u_heat_overlay": 0, "u_tile": 0, "u_slices": 0, "u_slice_scale": 0.0,
         "u_slice_bias": 0.0, "u_ref_valid": 0, "u_split_x": w + 1, "u_split_view": 0,
         "u_cursor_tile": (-1, -1, -1, -1), "u_cursor": (-1, -1), "u_light_sphere": (0.0, 0.0, 0.0, 0.0),
         "u_tan_half": (0.5, 0.3)}
    u.update(uniforms)
    r.gbuffer.bind_textures()
    r.run([passes.present_pass(fbo, (w, h), (w, h), view, u)])
    rgb = np.frombuffer(fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)[::-1]
    fbo.release()
    return rgb.astype(np.int16)


def test_histogram_and_exposure_match_python(frame):
    r, _, res = frame
    s, extra = _stats(r)
    covered = res.depth > 0
    want = images.luminance_histogram(res.image, covered)
    assert int(s["covered"]) == int(covered.sum())
    assert extra["lit"] == int(want.sum()) > 0
    assert np.abs(extra["hist"] - want).sum() <= max(2, want.sum() // 1000)   # a bin edge or two
    assert extra["max_exact"] == int(res.contrib_count[covered].max())
    gpu, cpu = images.exposure_from_histogram(extra["hist"]), images.auto_exposure(res.image, covered)
    assert abs(gpu / cpu - 1) < 1e-3


def test_display_is_the_python_function(frame):
    r, _, res = frame
    _, extra = _stats(r)
    exposure = images.exposure_from_histogram(extra["hist"])
    got = _present(r, "shaded", u_exposure=exposure, u_ambient=0.05)
    want = images.display(res.image, _albedo(r), exposure, 0.05).astype(np.int16)
    assert np.abs(got - want).max() <= 1
    # the dump contract's image is untouched: radiance, no exposure, no ambient
    assert (res.image[res.depth > 0] >= 0).all() and res.image.dtype == np.float32


@pytest.mark.parametrize("heat_of", HEAT_OF)
def test_heat_view_is_the_python_heat_map(frame, heat_of):
    r, _, res = frame
    values = res.evaluated if heat_of == "evaluated" else res.contrib_count
    covered = res.depth > 0
    top = images.heat_max(values, covered)
    got = _present(r, "heat", u_heat_max=top, u_heat_of=HEAT_OF.index(heat_of))
    want = images.heat_rgb(values, covered, top).astype(np.int16)
    assert np.abs(got - want).max() <= 1
    assert (got[~covered] == 0).all()


def test_heat_overlay_tints_only_counted_pixels(frame):
    r, _, res = frame
    shaded = _present(r, "shaded")
    over = _present(r, "heat", u_heat_overlay=1, u_heat_max=float(res.evaluated.max()))
    zero = (res.evaluated == 0)
    assert (over[zero] == shaded[zero]).all()
    assert (np.abs(over - shaded).sum(2)[~zero] > 0).mean() > 0.5


def test_diff_marks_exactly_the_differing_pixels(frame):
    r, scene, res = frame
    stash = passes.Stash(r.ctx, passes.UNITS["REF_COLOR_UNIT"], passes.UNITS["REF_STATS_UNIT"])
    try:
        stash.ensure(r.size)
        r.gbuffer.bind_textures()
        r.run([passes.stash_pass(stash.fbo, r.size)])
        # the same frame against itself: nothing differs
        _, extra = _stats(r, True, stash)
        assert extra["differ"] == 0
        # half the lights: the frame differs where the others reached
        other = r.render(REGISTRY["clustered"], lights=scene.lights[: len(scene.lights) // 2])
        _, extra = _stats(r, True, stash)
        mask = (other.contrib_count != res.contrib_count) | (other.contrib_hash != res.contrib_hash)
        assert extra["differ"] == int(mask.sum())
        stash.bind()
        got = _present(r, "diff", u_ref_valid=1)
        red = (got == np.array([255, 40, 40])).all(2)
        assert mask.any() and not mask.all()
        assert np.array_equal(red, mask)
    finally:
        stash.release()
        r.render(REGISTRY["clustered"])


def test_view_ids_are_the_window_order():
    from app.window.views import view_defines
    assert view_defines() == {f"VIEW_{v.upper()}": i for i, v in enumerate(VIEWS)}


def _bilinear_2x(img: np.ndarray) -> np.ndarray:
    """`img` (h, w, 3) at twice its size, sampled as a GL_LINEAR texture clamped to its edge."""
    h, w, _ = img.shape
    def taps(n):
        t = np.clip((np.arange(2 * n) + 0.5) / 2 - 0.5, 0, n - 1)
        lo = np.floor(t).astype(int)
        return lo, np.minimum(lo + 1, n - 1), t - lo
    y0, y1, fy = taps(h)
    x0, x1, fx = taps(w)
    f = img.astype(np.float64)
    top = f[y0][:, x0] * (1 - fx)[None, :, None] + f[y0][:, x1] * fx[None, :, None]
    bottom = f[y1][:, x0] * (1 - fx)[None, :, None] + f[y1][:, x1] * fx[None, :, None]
    return top * (1 - fy)[:, None, None] + bottom * fy[:, None, None]


def test_a_reduced_frame_is_scaled_up_bilinearly(frame):
    # dynamic resolution: the view presented at its render size into Upscale's texture, then
    # drawn over a viewport twice its size (compose.FrameComposer.draw)
    r, _, _ = frame
    w, h = r.size
    small = _present(r, "shaded", u_exposure=4.0, u_ambient=0.05)
    up = passes.Upscale(r.ctx)
    up.ensure((w, h))
    r.gbuffer.bind_textures()
    u = {"u_exposure": 4.0, "u_ambient": 0.05, "u_heat_max": 10.0, "u_heat_of": 0, "u_heat_overlay": 0,
         "u_tile": 0, "u_slices": 0, "u_slice_scale": 0.0, "u_slice_bias": 0.0, "u_ref_valid": 0,
         "u_split_x": w + 1, "u_split_view": 0, "u_cursor_tile": (-1, -1, -1, -1), "u_cursor": (-1, -1),
         "u_light_sphere": (0.0, 0.0, 0.0, 0.0), "u_tan_half": (0.5, 0.3)}
    r.run([passes.present_pass(up.fbo, (w, h), (w, h), "shaded", u)])
    big = r.ctx.simple_framebuffer((2 * w, 2 * h), components=4)
    up.bind()
    r.run([passes.upscale_pass(big, (2 * w, 2 * h))])
    got = np.frombuffer(big.read(components=3, alignment=1), np.uint8).reshape(2 * h, 2 * w, 3)[::-1]
    big.release()
    up.release()
    want = _bilinear_2x(small)
    assert np.abs(got - want).max() <= 1.0
    nearest = small.repeat(2, 0).repeat(2, 1)
    assert (np.abs(got - nearest) > 1).mean() > 0.05            # filtered, not repeated
