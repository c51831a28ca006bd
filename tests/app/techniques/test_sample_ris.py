"""sample-ris (app/techniques/sample_ris): its support is brute's affecting set at every pixel
(arena and a hard case); its estimate, spatial reuse off or unbiased, passes the statistical
check (app.sampling_check) and its faulty weights fail it; biased spatial reuse is
consistent (its error falls with S); one seed gives one frame; `evaluated` is S x M a pixel
of a non-empty cell without reuse; the error of a K-seed mean falls as 1 / sqrt(K)."""
import numpy as np
import pytest

from app import sampling_check
from app.errors import UserError
from app.exactness import check as exact
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from app.techniques.sample_ris import RESERVOIR, SPATIAL
from cpu_prep import layouts, sampling
from scenes import load_scene
from tests.app.techniques.hard_frames import Frame, concat, scene_of, street_camera, unit, view_space
from tests.helpers import floor_and_boxes, random_lights

NAME = "sample-ris"
SIZE = (128, 72)
TECH = REGISTRY[NAME]
FEW = load_scene("arena", lights=64, seed=1).lights


@pytest.fixture(scope="module")
def arena(gl):
    """(renderer, brute's frame) of the arena at 2,048 lights, 128 x 72."""
    scene = load_scene("arena", lights=2048, seed=1)
    scene.resolution = SIZE
    with Renderer(scene) as r:
        ref = r.render(REGISTRY["brute"], 0)
        assert ref.contrib_count.sum() > 0
        yield r, ref


def opts(**values):
    return TECH.resolve_options(values)


def rmse(image, ref) -> float:
    """An image's relative RMSE of the luminance against brute's over its shading pixels
    (app.sampling_check's measure)."""
    shading = ref.depth > 0
    lum, want = (sampling_check.luminance(a)[shading] for a in (image, ref.image))
    return float(np.sqrt(np.mean((lum - want) ** 2)) / np.sqrt(np.mean(want ** 2)))


@pytest.mark.parametrize("spatial", SPATIAL)
def test_support_is_exact_on_the_arena(arena, spatial):
    r, ref = arena
    res = r.render(TECH, 0, opts(spatial_reuse=spatial))
    assert exact(res, ref) is None, exact(res, ref).message()
    assert np.isfinite(res.image).all()


def test_support_is_exact_with_the_camera_inside_lights(gl):
    """The hard cases' camera inside many lights (test_hard_cases), anchors on pixels."""
    rng = np.random.default_rng(11)
    with Frame(scene_of(floor_and_boxes(), street_camera())) as f:
        n = 60
        L = random_lights(rng, n, (-1, -1, -1), (1, 1, 1), radius=(0.5, 40.0), spot_share=0.3)
        eye = np.array(f.scene.camera.position)
        L["position"] = eye + unit(rng.normal(size=(n, 3))) * (
            L["radius"] * rng.uniform(0, 0.95, n))[:, None]
        assert (np.linalg.norm(view_space(L, f.cam)[0], axis=1) < L["radius"]).all()
        lights = concat(L, f.anchors(rng, 8))
        for spatial in ("off", "unbiased"):
            res = f.render(lights, {"spatial_reuse": spatial}, ["brute", NAME])
            f.check(lights, where=f"camera in {n} lights, {spatial}", results=res)


# reuse at the paper's radius, and at 6 px where on this small frame most neighbours pass the
# normal and depth test (at 30 px most fail it: the arena's floor spans 10 to 96 m of depth)
REUSE = {"off": {}, "unbiased": dict(spatial_reuse="unbiased"),
         "unbiased-6px": dict(spatial_reuse="unbiased", reuse_radius=6.0)}


@pytest.mark.parametrize("case", REUSE)
def test_estimate_passes_the_statistical_check(arena, case):
    r, ref = arena
    v = sampling_check.check(r, TECH, opts(**REUSE[case]), ref, seeds=16)
    assert v.passed, v.message()
    assert v.frame_rel_se < 0.05, v.message()       # the check had the power to see a bias


def test_biased_reuse_is_darker_and_fails_the_check(arena):
    """Algorithm 4's 1 / M counts neighbours that cannot draw the kept light: the frame comes
    out darker, by far more than its noise, where Algorithm 6 (above, same options) passes."""
    r, ref = arena
    v = sampling_check.check(r, TECH, opts(spatial_reuse="biased", reuse_radius=6.0), ref,
                             seeds=16)
    assert not v.passed and v.frame_z < -5.0, v.message()


@pytest.mark.parametrize("fault", (1, 2))
@pytest.mark.parametrize("spatial", ("off", "unbiased"))
def test_faulty_weights_fail_the_check(arena, fault, spatial):
    r, ref = arena
    v = sampling_check.check(r, TECH, opts(spatial_reuse=spatial), ref, seeds=4,
                             defines={"SAMPLE_FAULT": fault})
    assert not v.passed, v.message()


def test_biased_reuse_is_consistent(arena):
    """Its error against brute falls as S grows (the variance goes, a bias stays); the check
    sees its bias with enough seeds."""
    r, ref = arena
    err = {s: np.mean([rmse(r.render(TECH, 0, opts(spatial_reuse="biased", light_samples=s,
                                                    sample_seed=k)).image, ref)
                       for k in range(3)]) for s in (1, 16)}
    assert err[16] < 0.6 * err[1], err


def test_one_seed_one_frame(arena):
    r, _ = arena
    for spatial in SPATIAL:
        a, b = (r.render(TECH, 0, opts(spatial_reuse=spatial, sample_seed=7)) for _ in range(2))
        c = r.render(TECH, 0, opts(spatial_reuse=spatial, sample_seed=8))
        assert np.array_equal(a.image, b.image) and np.array_equal(a.evaluated, b.evaluated)
        assert not np.array_equal(a.image, c.image), spatial


def _cell_counts(res) -> np.ndarray:
    """(H, W): the light count of the cell each pixel read (out_cell, the build's ranges)."""
    ranges = res.build.buffers["ranges"]
    return ranges["offset_count"][res.cell.astype(np.int64), 1]


@pytest.mark.parametrize("s, m", [(1, 1), (4, 8), (3, 17)])
def test_evaluated_is_s_times_m_without_reuse(arena, s, m):
    """(On 64 of the arena's lights: some cells empty.)"""
    r, ref = arena
    res = r.render(TECH, 0, opts(light_samples=s, candidates=m), lights=FEW)
    shading, lit = ref.depth > 0, _cell_counts(res) > 0
    assert (shading & lit).any() and (shading & ~lit).any(), "both kinds of pixel"
    assert (res.evaluated[shading & lit] == s * m).all()
    assert (res.evaluated[~(shading & lit)] == 0).all()
    assert (res.image[shading & ~lit] == 0).all(), "a pixel of an empty cell adds nothing"


def test_spatial_reuse_counts_its_evaluations(arena):
    """Each neighbour's p-hat here, unbiased also the kept light's at each neighbour: at
    most k (2k) a reservoir beyond S x M, and some pixel pays them."""
    r, ref = arena
    s, m, k = 2, 4, 5
    lit = (ref.depth > 0) & (_cell_counts(r.render(TECH, 0, opts())) > 0)
    for spatial, most in (("biased", k), ("unbiased", 2 * k)):
        ev = r.render(TECH, 0, opts(light_samples=s, candidates=m, spatial_reuse=spatial,
                                    reuse_neighbours=k)).evaluated[lit].astype(np.int64)
        assert ev.min() >= s * m and ev.max() <= s * (m + most), spatial
        assert (ev > s * m).mean() > 0.05, spatial


def test_the_error_of_a_mean_falls_as_one_over_root_seeds(arena):
    r, ref = arena
    images = sampling_check.seed_images(r, TECH, opts(), 0, 64, 16)
    err4 = np.mean([rmse(images[k:k + 4].mean(0), ref) for k in range(0, 16, 4)])
    err16 = rmse(images.mean(0), ref)
    assert 1.4 < err4 / err16 < 2.8, (err4, err16)


def test_reservoir_struct_is_the_shaders():
    assert RESERVOIR.itemsize == layouts.std430_offsets(RESERVOIR)[1] == 32
    assert "Reservoir" in TECH.glsl["ris_structs.glsl"]


def test_spatial_reuse_options():
    spec = TECH.Options.spec("spatial_reuse")
    assert spec.choices == ("off", "biased", "unbiased") and "biased" in spec.help
    assert opts(spatial_reuse="unbiased").spatial_reuse == 2
    with pytest.raises(UserError, match="reuse-neighbours"):
        opts(reuse_neighbours=3)                    # ignored without spatial reuse
    assert opts(spatial_reuse="biased", reuse_neighbours=3).reuse_neighbours == 3


@pytest.mark.parametrize("o", [dict(light_samples=2, candidates=1), dict(light_samples=3, candidates=8,
                                                                  sample_seed=5)])
def test_replay_draws_the_shaders_lights(arena, o):
    """The cost model's replay (sample_ris/replay.py): per pixel the shader's evaluations,
    and the light each last-round reservoir kept is one of the replay's draws for it (M = 1:
    the draw itself), so its uint32 streams and CDF search are the shader's."""
    from app.model import waves
    from app.techniques import parts
    from app.techniques.blocks import cell_ranges
    from app.techniques.sample_ris import NO_LIGHT, replay
    r, _ = arena
    res = r.render(TECH, 0, o)
    fr = waves.frame_data(r, res, opts(**o))
    for width in (32, 64):
        rp = waves.replay(parts.wave_program(TECH, fr, width))
        assert np.array_equal(rp.evaluated, np.ascontiguousarray(res.evaluated[::-1]).ravel())
    ranges = cell_ranges(fr.build)
    lanes = np.nonzero(fr.shading)[0]
    lanes = lanes[ranges[fr.cell[lanes], 1] > 0]
    first, count = ranges[fr.cell[lanes], 0], ranges[fr.cell[lanes], 1]
    last = replay.round_masses(lanes, fr.opts, fr.opts.light_samples - 1)
    e = np.stack([sampling.draw_entries(fr.build.buffers["sample_cdf"], first, count, u)[0]
                  for u in last], 1)
    drawn = np.asarray(fr.build.buffers["entries"], np.int64)[e]
    kept = r.read("ris_reservoirs").view(RESERVOIR)["light"][lanes].astype(np.int64)
    has = kept != NO_LIGHT
    assert has.sum() > 100
    assert (drawn[has] == kept[has, None]).any(1).all()


def test_replay_refuses_spatial_reuse(arena):
    from app.model import waves
    from app.techniques import parts
    r, _ = arena
    o = dict(spatial_reuse="unbiased")
    fr = waves.frame_data(r, r.render(TECH, 0, o), opts(**o))
    with pytest.raises(NotImplementedError, match="spatial reuse off only"):
        parts.wave_program(TECH, fr, 64)


def test_the_cost_model_prices_its_replay(gl):
    """Its candidates pass (named shade) carries the priced marks of what the replay issues:
    the light loop, the affects test and the shading of every shape."""
    from app.model import predict
    scene = load_scene("corridor", lights=96, seed=3)          # all four shapes
    with Renderer(scene, (48, 32)) as r:
        figures = predict.frame_figures(r, TECH, r.render(TECH, 0), {})
    assert {"cell", "light", "test:spot", "shade:box"} <= set(figures[32]["shade"].ops)
    assert all(v["shade"] > 0 for v in predict.modelled(figures).values())


def test_every_study_value_runs_over_the_defaults():
    """A benchmark study sets one option over the defaults (app.bench.plan): each studied
    value must make valid options there."""
    for spec in TECH.Options.specs():
        for v in spec.study:
            TECH.Options().with_(**{spec.name: v})
