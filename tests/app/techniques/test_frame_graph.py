"""The frame graph: a technique is one module.  A throw-away technique (throwaway.py),
with a compute prepass (its own define, writing a buffer), a raster pass (writing a buffer
from its fragments) and a shading pass reading both, renders exactly like brute and appears
in capture, the window and the benchmark with no file outside this test changed (the
benchmark: tests/app/bench/test_bench_sweep.py runs its sweep with it registered).  Also: the
renderer refuses undeclared buffers, reads of buffers nothing provided, and options a
technique does not take."""
from __future__ import annotations

import json
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from app.errors import UserError
from app.pipeline.passes import Draw, Pass
from app.pipeline.renderer import Renderer
from app.pipeline.shaders import ShaderError
from app.techniques import REGISTRY
from tests.app.techniques.throwaway import Throwaway
from tests.helpers import assert_exact, make_scene, random_lights, registered, render_all

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def throwaway():
    with registered(Throwaway()) as t:
        yield t


def _scene(rng, size=(61, 37)):
    return make_scene(random_lights(rng, 200, (-12, 0, -40), (12, 8, 5)), size=size)


def test_throwaway_technique_renders_exactly(gl, rng, throwaway):
    results = render_all(_scene(rng))
    assert "throwaway" in results
    assert_exact(results, "throw-away technique")
    res = results["throwaway"]
    assert res.contrib_count.sum() > 0
    assert set(res.meta["gpu_ms"]) == {"gbuffer", "keep", "cover", "shade"}
    assert set(res.meta["bytes"]) == {"lights", "keep", "covered"}
    assert res.meta["options"] == {"keep_value": 7}


def test_passes_really_run(gl, rng, throwaway):
    """Each declared pass matters: a prepass mark the shading pass does not want, or a
    raster pass that draws nothing, leaves every pixel unlit."""
    scene = _scene(rng)
    with Renderer(scene) as r:
        assert r.render(throwaway).contrib_count.sum() > 0

        class WrongMark(Throwaway):
            def passes(self, build, opts):
                ps = super().passes(build, opts)
                return [Pass(ps[0].name, ps[0].shader, writes=ps[0].writes, groups=ps[0].groups,
                             defines={"KEEP_VALUE": "3u"})] + ps[1:]

        class NoCover(Throwaway):
            def passes(self, build, opts):
                ps = super().passes(build, opts)
                return [ps[0], Pass("cover", ps[1].shader, writes=ps[1].writes,
                                    draw=Draw(count=0, target="none")), ps[2]]

        for t in (WrongMark(), NoCover()):
            res = r.render(t)
            assert res.contrib_count.sum() == 0 and res.evaluated.sum() == 0, type(t).__name__


def test_undeclared_buffer_fails_to_compile_in_one_line(gl, rng):
    class Sloppy(Throwaway):
        name = "sloppy"

        def passes(self, build, opts):
            ps = super().passes(build, opts)
            shade = ps[2]
            return ps[:2] + [Pass("shade", shade.shader, reads=("lights", "keep"),
                                  writes=shade.writes, groups=shade.groups, defines=shade.defines)]

    with Renderer(_scene(rng)) as r:
        with pytest.raises(ShaderError) as e:
            r.render(Sloppy())
    msg = str(e.value)
    assert "\n" not in msg
    assert "pass 'shade'" in msg and "'covered'" in msg and "tw_shade.comp:" in msg, msg


def test_reading_a_buffer_nothing_provides_is_an_error(gl, rng):
    class Stale(Throwaway):
        name = "stale"

        def passes(self, build, opts):
            return super().passes(build, opts)[2:]      # no prepass, no raster pass

    with Renderer(_scene(rng)) as r:
        r.render(Throwaway())           # the buffers exist from an earlier frame ...
        with pytest.raises(UserError, match="reads buffer 'keep', which nothing in this frame"):
            r.render(Stale())           # ... but this frame provides none of them


def test_options_belong_to_their_technique(throwaway):
    assert throwaway.resolve_options({"keep_value": 9}).keep_value == 9
    with pytest.raises(UserError, match="--tile is not an option of this technique"):
        throwaway.resolve_options({"tile": 16})
    with pytest.raises(UserError, match="--keep-value must be in 1..1000"):
        throwaway.resolve_options({"keep_value": 0})


def test_throwaway_appears_in_capture_list_and_runs(gl, throwaway, capsys, tmp_path):
    from app import capture
    capture.main(["--list"])
    out = capsys.readouterr().out
    assert "throwaway" in out and "perfect" in out
    capture.main(["--scene", "arena", "--lights", "200", "--size", "48x32",
                  "--technique", "throwaway", "--keep-value", "5", "--dump", str(tmp_path / "t.npz")])
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["technique"] == "throwaway" and summary["exact_per_pixel"] > 0


def test_capture_rejects_an_option_the_technique_does_not_take():
    p = subprocess.run([sys.executable, "-m", "app.capture", "--scene", "arena", "--technique",
                        "tiled", "--duplicated"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "--duplicated is not an option" in lines[0] and "tiled" in lines[0]


def test_throwaway_appears_in_the_window():
    """The window in its own process (one GL context per process): this module registers the
    technique there, then the window starts on it."""
    code = ("import sys; sys.path.insert(0, '.'); "
            "from tests.app.techniques.throwaway import Throwaway; "
            "from app.techniques import register; register(Throwaway()); "
            "from app.window import main; main(sys.argv[1:])")
    env = dict(os.environ)
    env.pop("MODERNGL_WINDOW", None)
    p = subprocess.run([sys.executable, "-c", code, "--window", "headless", "--scene", "arena",
                        "--lights", "64", "--size", "64x36", "--frames", "2", "--technique", "throwaway"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    frames = [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{") and '"frame"' in l]
    assert frames[0]["technique"] == "throwaway" and frames[0]["exact_per_pixel"] > 0


def test_figures_only_steps_run_when_the_frame_is_read_back(gl):
    """Steps that only count figures (fptl's per-tile counts, raster's counting twin of its
    culling passes, the wave counters) run with read-back or figures=True, not on a window
    frame or a timing sample; the frame's counters are the same, and fptl's maps read its
    cells either way."""
    from tests.helpers import make_scene, random_shapes
    rng = np.random.default_rng(3)
    scene = make_scene(random_shapes(rng, 120, (-14, -1, -34), (14, 7, 6)), size=(64, 48))
    with Renderer(scene) as r:
        for name, step in (("fptl", "fptl counts"), ("raster", "raster counters"), ("zbin", "wave counters")):
            t = REGISTRY[name]
            full = r.render(t)
            assert step in full.meta["setup_ms"], name
            quiet = r.render(t, readback=False)
            assert step not in quiet.meta["setup_ms"] and quiet.meta["stats"].keys() < full.meta["stats"].keys()
            asked = r.render(t, readback=False, figures=True)
            assert step in asked.meta["setup_ms"] and asked.meta["stats"] == full.meta["stats"]
            assert quiet.meta["gpu_ms"].keys() == full.meta["gpu_ms"].keys()      # same timed passes
        fptl = REGISTRY["fptl"]
        want = fptl.maps(r.render(fptl), r.read)
        quiet = r.render(fptl, readback=False)
        assert quiet.build.own.tile_counts is None
        got = fptl.maps(quiet, r.read)
        assert got.keys() == want.keys() and all(np.array_equal(got[k][0], want[k][0]) for k in want)
