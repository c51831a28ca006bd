"""--stochastic (Tokuyoshi & Harada 2016; cpu_prep.stochastic) on the techniques: every one
(raster in both its modes) equals brute under the same draw at every pixel, in its light sets
and in its image (a light row that lost its 1/p weight keeps its set but not its radiance); a
seed reproduces its frame bit for bit; box lights stay exact; off (0) is today's frame, and a
seed or frame without a budget is refused; and, over K seeds, the mean frame converges to
the unbounded reference (UNBOUNDED_FALLOFF) at the rate 1/sqrt(K) the closed-form variance
predicts.  Bad budgets are one line and exit 2."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.bench.cutoff import unbounded_lights
from app.errors import UserError
from app.exactness import check
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, with_role
from app.techniques.options import StochasticOptions
from cpu_prep import stochastic as st
from cpu_prep.camera import look_at
from scenes.model import LIGHT_BOX, make_lights
from tests.helpers import (CAMERA, assert_exact, assert_same_image, make_scene, random_lights,
                           render_on, takes)

ROOT = Path(__file__).resolve().parents[3]
SIZE = (64, 36)
BUDGET = 64                       # t = 1/64: most lights are culled well inside the frame
SEEDS = 256                       # renders of a 64x36 frame with brute: about a second
# every registered technique in its default mode, and raster's cluster rasterizer besides
MODES = {"default": {}, "raster cluster mode": {"cluster": 1}}


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(3)
    return make_scene(random_lights(rng, 24, (-10, 0, -30), (10, 6, 5), radius=(2.0, 8.0)), size=SIZE)


@pytest.fixture(scope="module")
def renderer(gl, scene):
    with Renderer(scene) as r:
        yield r


def draw(seed, budget=BUDGET, frame=0):
    return {"stochastic": budget, "stochastic_seed": seed, "stochastic_frame": frame}


CULLING = [n for n, t in REGISTRY.items() if t.role != "sampler"]


def test_every_technique_takes_it_brute_included():
    """Every culling technique; a sampler estimates brute's frame by draws of its own and
    refuses the option in one line."""
    assert all(issubclass(REGISTRY[n].Options, StochasticOptions) for n in CULLING)
    for n, t in REGISTRY.items():
        if n not in CULLING:
            with pytest.raises(UserError, match="is not an option of this technique"):
                t.resolve_options({"stochastic": 16})


@pytest.mark.parametrize("seed", [1, 9])
@pytest.mark.parametrize("mode", list(MODES))
def test_every_technique_is_exact_against_brute_under_the_same_draw(renderer, seed, mode):
    names = [n for n in CULLING if mode == "default" or n == "brute" or takes(n, *MODES[mode])]
    res = render_on(renderer, dict(draw(seed), **MODES[mode]), names)
    assert len(res) > 1 and (res["brute"].contrib_count > 0).mean() > 0.3
    assert_exact(res, f"seed {seed}")
    assert_same_image(res, f"seed {seed}")
    for name, r in res.items():          # each frame was drawn, and with the draw asked for
        assert {k: r.meta["options"][k] for k in draw(0)} == draw(seed), name
        assert r.meta["stats"]["stochastic_seed"] == seed, name
    stats = res["brute"].meta["stats"]
    assert stats["stochastic_t"] == 1 / BUDGET
    if mode != "default":
        return
    # the draw changes which lights reach a pixel: another seed's frame differs
    other = renderer.render(REGISTRY["brute"], opts=draw(seed + 1))
    assert (other.contrib_hash != res["brute"].contrib_hash).any()


def test_the_check_renders_brute_with_the_frames_draw(renderer):
    t, ref_t = REGISTRY["clustered"], with_role("reference")
    res = renderer.render(t, opts=draw(4))
    plain = renderer.render(ref_t)                           # capture's reference: defaults
    assert (plain.contrib_count != res.contrib_count).any()
    assert check(res, plain, renderer, t, ref_t, {"opts": t.Options.make(draw(4))}) is None


def test_a_seed_reproduces_its_frame_bit_for_bit_and_the_dump_says_the_draw(renderer):
    b = REGISTRY["brute"]
    one, two = (renderer.render(b, opts=draw(5, frame=2)) for _ in range(2))
    assert one.image.tobytes() == two.image.tobytes()
    assert np.array_equal(one.contrib_hash, two.contrib_hash)
    assert renderer.render(b, opts=draw(5, frame=3)).image.tobytes() != one.image.tobytes()
    meta = one.meta
    assert {k: meta["options"][k] for k in draw(0)} == draw(5, frame=2)
    s = meta["stats"]
    assert (s["stochastic_t"], s["stochastic_seed"], s["stochastic_frame"]) == (1 / BUDGET, 5, 2)
    # dark this frame: the lights with alpha_i xi_i >= 1 (no box here), counted from the
    # scene; at t = 1/64 none of these, at t = 1 (budget 1) some
    L = renderer.scene.lights
    peak = L["intensity"].astype(np.float64) * L["color"].max(1)
    for budget in (BUDGET, 1):
        dark = (peak.max() / budget / peak) * st.draw_xi(len(L), 5, 2) >= 1.0
        res = one if budget == BUDGET else renderer.render(b, opts=draw(5, budget=budget, frame=2))
        assert res.meta["stats"]["stochastic_dark_lights"] == dark.sum(), budget
    assert dark.sum() > 0


def test_off_is_the_exact_frame(renderer):
    b = REGISTRY["brute"]
    off, plain = renderer.render(b, opts={"stochastic": 0}), renderer.render(b)
    assert off.image.tobytes() == plain.image.tobytes()
    assert not any(k.startswith("stochastic") for k in plain.meta["stats"])
    assert (plain.build.lights.gpu["right"][:, 3] == 0).all()


def test_box_lights_stay_exact(gl):
    L = make_lights(3)
    L["type"] = LIGHT_BOX
    L["position"] = [(-4, 1, -10), (0, 1, -14), (4, 1, -10)]
    L["direction"], L["up"] = (0, -1, 0), (0, 0, 1)
    L["extent"], L["intensity"] = (3, 3, 4), 5.0
    with Renderer(make_scene(L, size=SIZE)) as r:
        exact = r.render(REGISTRY["brute"])
        stoch = r.render(REGISTRY["brute"], opts=draw(2, budget=4))
    assert exact.contrib_count.any()
    assert stoch.image.tobytes() == exact.image.tobytes()


def test_the_mean_over_seeds_converges_to_the_unbounded_reference(renderer, scene):
    """Over K seeds the mean frame's RMSE against the UNBOUNDED_FALLOFF frame is
    sqrt(mean_x Var(x) / K), Var the closed form sum_i u_i^2 (alpha_i / f_i - 1)+ (u_i: light
    i's unbounded contribution, rendered alone; f_i = 1/(d^2+1) at the G-buffer's point).
    Measured (24 lights, t = 1/64): RMSE/predicted 1.00, 1.00, 0.96, 1.05, 0.95 at K = 1,
    4, 16, 64, 256; RMSE(4)/RMSE(16) = 2.09."""
    b = REGISTRY["brute"]
    ub = unbounded_lights(scene.lights, scene)
    unbounded = {"UNBOUNDED_FALLOFF": 1}
    ref = renderer.render(b, lights=ub, defines=unbounded).image.astype(np.float64)
    n = len(scene.lights)
    u = np.stack([renderer.render(b, lights=_alone(ub, i), defines=unbounded).image
                  for i in range(n)], -2).astype(np.float64)                 # (H, W, n, 3)
    assert np.abs(u.sum(-2) - ref).max() <= 1e-5 * ref.max()
    pos = renderer.gbuffer.read_position()[::-1].astype(np.float64)[..., :3]   # view space
    m = look_at(CAMERA.position, CAMERA.target, CAMERA.up)
    lv = scene.lights["position"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    f = 1.0 / (((pos[..., None, :] - lv) ** 2).sum(-1) + 1.0)
    var = st.variance(u, f, st.alphas(scene.lights, 1.0 / BUDGET))          # (H, W, 3)
    assert var.mean() > 0

    frames = np.stack([renderer.render(b, opts=draw(k)).image for k in range(SEEDS)]).astype(np.float64)
    # the sample variance over the seeds is the closed form's
    assert 0.85 < frames.var(0, ddof=1).sum() / var.sum() < 1.15

    def rmse(k):          # over the SEEDS // k disjoint groups of k seeds
        means = frames.reshape(SEEDS // k, k, *frames.shape[1:]).mean(1)
        return float(np.sqrt(((means - ref) ** 2).mean()))
    for k in (1, 4, 16, 64):
        assert 0.8 < rmse(k) / np.sqrt(var.mean() / k) < 1.25, k
    assert 1.6 < rmse(4) / rmse(16) < 2.5                    # 1/sqrt(K): 2
    mean = frames.mean(0)
    # per pixel: mean squared z-score ~ 1; the image's mean bias within 4 sigma, bounded by
    # the mean per-pixel sigma (pixels share the draw, so their errors correlate, at most fully)
    z2 = ((mean - ref) ** 2 / np.maximum(var / SEEDS, 1e-30))[var > 0]
    assert z2.mean() < 2.0
    assert abs((mean - ref).mean()) <= 4 * np.sqrt(var / SEEDS).mean()


def _alone(lights, i):
    out = lights.copy()
    out["intensity"][np.arange(len(out)) != i] = 0.0
    return out


def capture(*args):
    return subprocess.run([sys.executable, "-m", "app.capture", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("value", [-1, st.MAX_BUDGET + 1])
def test_a_budget_out_of_range_is_refused(value):
    with pytest.raises(UserError, match="--stochastic must be in 0..65536 \\(got"):
        REGISTRY["tiled"].Options.make({"stochastic": value})


@pytest.mark.parametrize("name", ["seed", "frame"])
def test_a_draw_without_a_budget_is_refused(name):
    with pytest.raises(UserError, match=f"--stochastic-{name} 3 is ignored without --stochastic"):
        REGISTRY["brute"].Options.make({"stochastic": 0, f"stochastic_{name}": 3})


def test_bad_stochastic_input_is_one_line_and_exit_2():
    for args, says in ((("--stochastic", "-3"), "--stochastic must be in"),
                       (("--stochastic", "64", "--cap-policy", "urp-16"), "not offered together")):
        r = capture("--scene", "arena", "--lights", "8", "--size", "16x16", "--technique", "tiled", *args)
        assert r.returncode == 2 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
