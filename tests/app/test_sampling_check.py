"""The statistical check of a sampler (app.sampling_check): unbiased estimates pass, a
dropped 1/p or an unnormalised pdf fails (the shaders' SAMPLE_FAULT negative controls), and
on a scene of short lists every single pixel's mean is within its standard error of brute's,
the error of the mean falling as 1/sqrt(K)."""
import numpy as np
import pytest

from app import sampling_check as sc
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, get
from tests.helpers import make_scene, random_lights, with_brute

SAMPLERS = [n for n, t in REGISTRY.items() if t.role == "sampler"]


def _noisy(rng, ref, k, scale=1.0, bias=1.0):
    """K exponential-noise estimates of `ref` (mean ref * bias)."""
    return ref[None] * bias * rng.exponential(1.0, (k,) + ref.shape[:2] + (1,)) * scale


def test_judge_passes_unbiased_noise_and_fails_a_bias(rng):
    ref = rng.uniform(0.1, 1.0, (48, 64, 3))
    shading = np.ones((48, 64), bool)
    assert sc.judge("x", _noisy(rng, ref, 16), ref, shading).passed
    v = sc.judge("x", _noisy(rng, ref, 16, bias=1.1), ref, shading)
    assert not v.passed and v.frame_z > sc.FRAME_Z, v.message()
    assert "biased" in v.message()


def test_judge_holds_blocks_a_frame_total_would_hide(rng):
    """Half the frame 10% bright, half 10% dark: the total is right, the blocks are not."""
    ref = rng.uniform(0.1, 1.0, (64, 64, 3))
    images = _noisy(rng, ref, 32)
    images[:, :32] *= 1.1
    images[:, 32:] *= 0.9
    v = sc.judge("x", images, ref, np.ones((64, 64), bool))
    assert not v.passed and v.blocks_off > 1, v.message()


def test_judge_needs_a_spread():
    with pytest.raises(ValueError, match="2 seeds"):
        sc.judge("x", np.zeros((1, 4, 4, 3)), np.zeros((4, 4, 3)), np.ones((4, 4), bool))


@pytest.fixture(scope="module")
def arena():
    with with_brute("arena", 2048, 3, (128, 72)) as got:
        yield got


@pytest.mark.parametrize("name", SAMPLERS)
def test_samplers_pass_and_their_faults_fail(gl, arena, name):
    r, ref = arena
    t = get(name)
    assert ref.contrib_count.sum() > 0
    assert sc.check(r, t, t.resolve_options(), ref, seeds=8).passed
    for fault in (1, 2):
        v = sc.check(r, t, t.resolve_options(), ref, seeds=4, defines={"SAMPLE_FAULT": fault})
        assert not v.passed, f"SAMPLE_FAULT {fault}: {v.message()}"


@pytest.fixture(scope="module")
def short_lists():
    """A scene whose cells hold a few lights each: K x S draws reach every one at a pixel."""
    rng = np.random.default_rng(11)
    lights = random_lights(rng, 40, (-12, 0, -30), (12, 6, 4), radius=(2.0, 6.0))
    with Renderer(make_scene(lights, size=(64, 40))) as r:
        yield r, r.render(get("brute"), 0)


@pytest.mark.parametrize("name", SAMPLERS)
def test_every_pixel_converges_to_brute(gl, short_lists, name):
    r, ref = short_lists
    t = get(name)
    opts = t.resolve_options({"light_samples": 16})
    images = sc.seed_images(r, t, opts, 0, 64, 48)
    shading = ref.depth > 0
    lum, want = sc.luminance(images)[:, shading], sc.luminance(ref.image)[shading]
    assert (want > 0).mean() > 0.5, "lights touch too little of the frame: test is void"
    z = sc.z_scores(lum, want, 1e-4 * np.abs(want) + 1e-7)
    assert (np.abs(z) > 5).mean() < 0.005, np.sort(np.abs(z))[-10:]
    # the mean of 16 seeds against that of 4: its RMSE falls by sqrt(4) = 2
    rmse = lambda k: np.sqrt(np.mean((lum[:k].mean(0) - want) ** 2))
    ratio = rmse(4) / rmse(16)
    assert 1.4 < ratio < 2.9, ratio


def test_a_failing_check_is_judged_again_over_more_seeds(rng, monkeypatch):
    """A rare draw all K seeds missed (a dark block) passes over ESCALATE x K seeds, the K
    included; a bias in every seed fails there too."""
    ref = rng.uniform(0.1, 1.0, (64, 64, 3))
    reference = type("Frame", (), {"image": ref, "depth": np.ones((64, 64))})()
    technique = type("T", (), {"name": "x"})()

    def run(dark_after):
        calls = []

        def images(renderer, technique, opts, frame, frames, seeds, defines=None, first=0):
            calls.append((first, seeds))
            out = _noisy(rng, ref, seeds)
            out[first + np.arange(seeds) < dark_after, :16, :16] *= 0.5
            return out
        monkeypatch.setattr(sc, "seed_images", images)
        return sc.check(None, technique, None, reference, seeds=16), calls

    v, calls = run(dark_after=16)
    assert v.passed and v.seeds == 16 * sc.ESCALATE, v.message()
    assert calls == [(0, 16), (16, 16 * (sc.ESCALATE - 1))]
    v, _ = run(dark_after=10 ** 6)
    assert not v.passed and v.seeds == 16 * sc.ESCALATE
