"""Renderer.render(keep_setup=True): a frame rendered again reuses its untimed set-up (the
floor's exact lists, raster's proxies) while no other frame has written its buffers, runs it
again where one has, and gives the same outputs either way."""
import numpy as np

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep.camera import frame_camera
from scenes.model import Camera
from tests.helpers import make_scene, random_lights


def scene():
    return make_scene(random_lights(np.random.default_rng(5), 64, (-8, 0, -30), (8, 5, -2)),
                      size=(48, 32))


def outputs(result):
    return result.image, result.evaluated, result.contrib_count, result.contrib_hash


def counting_untimed(r):
    """The names of the untimed passes and host steps the renderer runs, as it runs them."""
    ran = []
    run_pass, run_host = r._run_pass, r._run_host

    def untimed_pass(p, *args, **kw):
        if not p.timed:
            ran.append(p.name)
        return run_pass(p, *args, **kw)

    def host(step):
        ran.append(step.name)
        return run_host(step)
    r._run_pass, r._run_host = untimed_pass, host
    return ran


def test_a_frame_rendered_again_reuses_its_set_up_and_gives_the_same_outputs(gl):
    t = REGISTRY["perfect"]                   # untimed: count, plan (host), fill; timed: shade
    with Renderer(scene()) as r:
        want = outputs(r.render(t, keep_setup=True))
        ran = counting_untimed(r)
        again = r.render(t, keep_setup=True)
        assert ran == [], f"the set-up ran again: {ran}"
        assert again.meta["stats"]["bands"] == 1 and again.meta["setup_ms"]
        for a, b in zip(want, outputs(again)):
            np.testing.assert_array_equal(a, b)
        timing = r.render(t, readback=False, keep_setup=True)
        assert ran == [] and set(timing.meta["gpu_ms"]) >= {"shade"}


def test_a_set_up_another_frame_overwrote_runs_again(gl):
    t = REGISTRY["perfect"]
    with Renderer(scene()) as r:
        want = outputs(r.render(t, keep_setup=True))
        aside = frame_camera(Camera((3.0, 2.0, 6.0), (0.0, 1.0, -20.0), near=0.1, far=200.0),
                             *r.size)
        r.render(t, camera=aside, keep_setup=True)   # its own lists, in the same buffers
        ran = counting_untimed(r)
        got = outputs(r.render(t, keep_setup=True))
        assert "count" in ran and "plan" in ran and "fill" in ran
        for a, b in zip(want, got):
            np.testing.assert_array_equal(a, b)


def test_other_lights_or_options_make_another_set_up(gl):
    t = REGISTRY["perfect"]
    sc = scene()
    with Renderer(sc) as r:
        r.render(t, keep_setup=True)
        ran = counting_untimed(r)
        fewer = sc.lights[:40]
        got = outputs(r.render(t, lights=fewer, keep_setup=True))
        assert "count" in ran, "the CPU stage's uploads changed: the set-up must run again"
        with Renderer(sc) as fresh:
            want = outputs(fresh.render(t, lights=fewer))
        for a, b in zip(want, got):
            np.testing.assert_array_equal(a, b)
        ran.clear()
        r.render(t, opts=t.Options().with_(stochastic=8), lights=fewer, keep_setup=True)
        assert "count" in ran, "other options: the set-up must run again"


def test_without_keep_setup_every_frame_runs_whole(gl):
    t = REGISTRY["perfect"]
    with Renderer(scene()) as r:
        r.render(t, keep_setup=True)
        ran = counting_untimed(r)
        r.render(t)
        assert "count" in ran and "fill" in ran
