"""The start-up probe: its memory is only reused by the code and scene file that measured it;
it leaves a technique that would refuse out before building it, and says why; it times the
likely fastest first (ranked by a small frame each), so the budget leaves out the slow ones."""
from types import SimpleNamespace

import pytest

from app.errors import FrameTimeout, UserError
from app.pipeline.passes import FrameInput
from app.techniques import REGISTRY
from app.techniques.base import Technique, visible_lights
from app.window import probe
from app.given_options import GivenOptions
from cpu_prep.camera import frame_camera
from scenes import load_scene
from tests.helpers import registered


def test_code_version_follows_the_sources_a_frame_costs(tmp_path):
    (tmp_path / "glsl").mkdir()
    (tmp_path / "app" / "techniques").mkdir(parents=True)
    shader = tmp_path / "glsl" / "shade.comp"
    shader.write_text("void main() {}\n")
    (tmp_path / "app" / "techniques" / "t.py").write_text("x = 1\n")
    (tmp_path / "README.md").write_text("a\n")
    before = probe.code_version(tmp_path)
    (tmp_path / "README.md").write_text("b\n")                 # not a cost source
    probe.code_version.cache_clear()
    assert probe.code_version(tmp_path) == before
    shader.write_text("void main() { }\n")                       # an edited shader
    probe.code_version.cache_clear()
    assert probe.code_version(tmp_path) != before
    probe.code_version.cache_clear()


def test_start_key_changes_with_the_code_and_the_scene_file(tmp_path, monkeypatch):
    scene = tmp_path / "s.json"
    scene.write_text("{}")
    args = SimpleNamespace(scene=str(scene), seed=0, distribution=None)
    key = lambda: probe.start_key(args, 64, (320, 180), "llvmpipe", ["tree", "clustered"], {"tile": 32})
    first = key()
    assert key() == first
    monkeypatch.setattr(probe, "code_version", lambda: "edited")
    assert key() != first
    monkeypatch.undo()
    scene.write_text("{ }")
    assert key() != first
    args.scene = "city"                                   # a builtin: no file to stamp
    assert probe.start_key(args, 64, (320, 180), "llvmpipe", ["clustered", "tree"], {"tile": 32}) == key()


def test_file_stamp_changes_with_the_scene_file(tmp_path):
    scene = tmp_path / "s.json"
    scene.write_text("{}")
    first = probe.file_stamp(str(scene))
    scene.write_text("{ }")
    assert probe.file_stamp(str(scene)) != first
    assert probe.file_stamp("city") is None


class ProbeRenderer:
    """What the probe asks of a renderer, without GL: the frames rendered, by technique; a
    technique named in `build_refuses` refuses in its build (a limit refusal() cannot see)."""

    def __init__(self, scene, loop_budget, build_refuses=()):
        self.scene, self.loop_budget, self.build_refuses = scene, loop_budget, set(build_refuses)
        self.size, self.rendered = (64, 36), []
        self.ctx = SimpleNamespace(finish=lambda: None)
        self.limits = SimpleNamespace(renderer="probe test")

    def resize(self, size):
        self.size = tuple(size)

    def frame_input(self, frame, frames, lights, camera):
        return FrameInput(lights, camera, self.scene.max_depth, loop_budget=self.loop_budget)

    def render(self, technique, frame, opts, lights, readback, camera, deadline=None):
        self.rendered.append(technique.name)
        if technique.name in self.build_refuses:
            raise UserError(f"{technique.name}: a limit only its build meets")
        return SimpleNamespace(meta={"gpu_ms": {"shade": 1.0}})


def probe_setup(build_refuses=()):
    """city at 600 lights with a loop budget one under what tiled's cull needs for them: tiled
    and zbin (its tile depth test) refuse, from the counts alone."""
    scene = load_scene("city", lights=600)
    v = visible_lights(FrameInput(scene.lights, frame_camera(scene.camera, 64, 36), scene.max_depth))
    return scene, ProbeRenderer(scene, (v + 255) // 256 * 10 - 1, build_refuses)


def test_the_probe_skips_a_refusing_technique_without_building_it():
    scene, r = probe_setup(build_refuses=["tree"])
    names = ["tiled", "clustered", "tree", "hybrid", "zbin"]

    def opts_of(t):
        if t.name == "hybrid":
            raise UserError("hybrid: options it refuses")
        return t.Options()
    name, times, _, skipped, refused = probe.fastest(r, [REGISTRY[n] for n in names], opts_of,
                                                     scene.lights, scene.camera, budget_s=1e9)
    assert name == "clustered" and list(times) == ["clustered"] and not skipped
    # tiled and zbin never built; clustered's and tree's ranking frames (tree's build refuses,
    # so it is timed after the ranked ones: its build refuses again), clustered's timed frame
    assert r.rendered == ["clustered", "clustered", "tree", "clustered", "tree"]
    assert refused["tiled"].startswith("tiled: culling") and refused["zbin"].startswith("zbin: the tile depth")
    assert refused["tree"] == "tree: a limit only its build meets"
    assert refused["hybrid"] == "hybrid: options it refuses"


def test_the_start_names_each_skipped_technique_and_its_limit_also_when_remembered():
    scene, r = probe_setup()
    args = SimpleNamespace(scene="city", seed=0, distribution=None, reprobe=False)
    start = lambda: probe.choose_start(args, r, ["tiled", "clustered", "zbin"], GivenOptions({}),
                                       lambda: scene.lights, scene.camera, probe.FrameCosts())
    name, lines = start()
    assert name == "clustered" and lines[0].startswith("started on clustered, the fastest exact")
    skipped = lines[1:]
    assert [l.split(":")[0] for l in skipped] == ["skipped tiled", "skipped zbin"]
    assert all(l.count("\n") == 0 and "loop iterations" in l for l in skipped)
    r.rendered.clear()
    name, again = start()                     # the remembered choice: no frame, the same lines
    assert not r.rendered and "at the last probe" in again[0] and again[1:] == skipped
    with pytest.raises(UserError, match="^no technique can render 600 lights of this scene here: tiled: .*; zbin: "):
        probe.choose_start(SimpleNamespace(**dict(vars(args), reprobe=True)), r, ["tiled", "zbin"],
                           GivenOptions({}), lambda: scene.lights, scene.camera, probe.FrameCosts())


def test_progress_lines_before_an_expected_slow_step_and_after_a_slow_one(monkeypatch, capsys):
    import time
    from app.window import progress
    monkeypatch.setattr(progress, "AFTER_S", 0.05)
    with progress.step("quick"):
        pass
    with progress.step("not measured yet", unknown=True):
        pass
    with progress.step("expected slow", expect_s=0.1):
        time.sleep(0.06)
    with pytest.raises(UserError):
        with progress.step("slow, then refused"):
            time.sleep(0.06)
            raise UserError("a limit")
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "window: not measured yet ..."
    assert [l.split(",")[0].split(":")[1].strip() for l in lines[1:]] == ["expected slow", "expected slow",
                                                                          "slow"]
    assert lines[1].endswith("about 0 s ...") and lines[2].startswith("window: expected slow: 0.")


def test_the_start_chooses_among_the_techniques_that_take_the_flags_together():
    from app.window.launch import start_candidates
    args = SimpleNamespace(technique=None, view="shaded")
    assert start_candidates(args, {"cap_policy": "hdrp-fptl-24"}) == (None, ["fptl"])
    viewcap = start_candidates(args, {"cap_policy": "urp-16"})[1]
    assert {"tiled", "fptl"} <= set(viewcap)
    with pytest.raises(UserError, match="no technique takes --cap-policy --fptl-variant .*caps the fine-pruned"):
        start_candidates(args, {"cap_policy": "hdrp-fptl-24", "fptl_variant": "coarse per tile"})


def test_frame_times_read_in_the_unit_that_fits():
    assert [probe.duration(ms) for ms in (355.4, 1500.0, 395163.0)] == ["355 ms", "1.5 s", "395 s"]


# ---- the probe's order: ranked by a small frame each, timed at the probe size in that order ----

class Clock:
    """probe.time's stand-in: the frames' costs on a fake clock, no wall-clock time."""

    def __init__(self):
        self.now = 0.0

    def perf_counter(self):
        return self.now

    @staticmethod
    def strftime(fmt):
        return "then"


class TimedRenderer(ProbeRenderer):
    """ProbeRenderer whose frames cost `cost[name](pixels)` ms on `clock` (GPU ms the same),
    `compile_ms` more for the frame that builds a technique's GL program: its first, and, for
    one in `variants`, its first at each size (a size-dependent shader variant)."""

    def __init__(self, scene, cost, clock, variants=(), compile_ms=5000.0, build_refuses=()):
        super().__init__(scene, None, build_refuses)
        self.cost, self.clock, self.variants, self.compile_ms = cost, clock, set(variants), compile_ms
        self.programs = SimpleNamespace(sources={})
        self.frames = []                                  # (name, size) of each frame

    def render(self, technique, frame, opts, lights, readback, camera, deadline=None):
        self.frames.append((technique.name, self.size))
        super().render(technique, frame, opts, lights, readback, camera)
        name = technique.name
        keys = [(name,)] + ([(name, self.size)] if name in self.variants else [])
        new = [k for k in keys if k not in self.programs.sources]
        self.programs.sources.update(dict.fromkeys(new, "text"))
        passes, compile_ms = self.cost[name](self.size[0] * self.size[1]), self.compile_ms * len(new)
        if deadline is not None and self.clock.now + passes / 1e3 > deadline:
            # Renderer.render: the compile is not counted; the passes stop at the deadline
            spent = max(deadline - self.clock.now, 0.0)
            self.clock.now += spent + compile_ms / 1e3
            raise FrameTimeout(f"{name}: frame stopped at its deadline after {spent:.1f} s of its passes")
        ms = passes + compile_ms
        self.clock.now += ms / 1e3
        return SimpleNamespace(meta={"gpu_ms": {"shade": ms}})


SMALL, PROBE = (8, 8), (64, 36)          # RANK_SCALE of the fake's 64x36 (8 pixels at least)


def per_pixel(ms, fixed=0.0):
    return lambda pixels: fixed + ms * pixels


@pytest.fixture
def timed(monkeypatch):
    """(scene, make(cost, **kw) -> a TimedRenderer on a fake clock that probe.time reads)."""
    clock = Clock()
    monkeypatch.setattr(probe, "time", clock)
    scene = load_scene("city", lights=64)
    return scene, lambda cost, **kw: TimedRenderer(scene, cost, clock, **kw)


def probed(r, scene, names, budget_s):
    ts = [n if isinstance(n, Technique) else REGISTRY[n] for n in names]
    return probe.fastest(r, ts, lambda t: t.Options(), scene.lights, scene.camera, budget_s=budget_s)


def test_a_slow_technique_listed_first_is_timed_last_and_left_out_for_time(timed):
    # tiled first in the registry and 10x clustered's cost: the registry's order would time
    # it alone; ranked by a frame each at 8x8, clustered and tree are timed first (23 + 69 ms),
    # and the budget (80 ms from the first frame at 64x36: the compile frames, 5 s each,
    # are behind) is spent before hybrid, ranked a little slower than tree, and tiled
    scene, make = timed
    r = make({"tiled": per_pixel(0.1), "clustered": per_pixel(0.01), "tree": per_pixel(0.03),
              "hybrid": per_pixel(0.031)})
    names = ["tiled", "clustered", "tree", "hybrid"]
    name, times, size, skipped, refused = probed(r, scene, names, 0.08)
    assert name == "clustered" and list(times) == ["clustered", "tree"] and skipped == ["hybrid", "tiled"]
    assert size == PROBE and not refused and r.size == PROBE
    assert r.frames == ([(n, SMALL) for n in names for _ in (0, 1)]
                        + [("clustered", PROBE), ("tree", PROBE)])
    assert times["clustered"] == pytest.approx(0.01 * 64 * 36)       # one frame, no compile in it


def test_a_technique_expected_over_the_whole_budget_is_not_started(timed):
    # tiled's ranking frame says 10x clustered's: 230 ms expected at the probe size, over the
    # 100 ms budget although clustered's 23 ms left most of it
    scene, make = timed
    r = make({"tiled": per_pixel(0.1), "clustered": per_pixel(0.01)})
    name, times, _, skipped, _ = probed(r, scene, ["tiled", "clustered"], 0.1)
    assert name == "clustered" and list(times) == ["clustered"] and skipped == ["tiled"]
    assert [f for f in r.frames if f[1] == PROBE] == [("clustered", PROBE)]


def test_the_order_follows_the_ranking_frames_and_the_choice_the_probe_size(timed):
    # costs falling in registry order: timed in the reverse order.  hybrid ranks first at
    # 8x8 (no fixed cost) but zbin's fixed cost is a small share at 64x36: zbin is chosen
    scene, make = timed
    names = ["tiled", "clustered", "tree", "hybrid", "zbin"]
    cost = {n: per_pixel(0.05 - 0.01 * k) for k, n in enumerate(names[:3])}
    cost["hybrid"] = per_pixel(0.01)
    cost["zbin"] = per_pixel(0.005, fixed=1.0)
    r = make(cost)
    name, times, _, skipped, _ = probed(r, scene, names, 1e9)
    assert list(times) == ["hybrid", "zbin", "tree", "clustered", "tiled"] and not skipped
    assert name == "zbin"
    assert [f for f in r.frames if f[1] == SMALL] == [(n, SMALL) for n in names for _ in (0, 1)]


def test_a_variant_built_at_the_probe_size_gets_a_second_frame_there(timed):
    scene, make = timed
    r = make({"clustered": per_pixel(0.01), "hybrid": per_pixel(0.02)}, variants=["hybrid"])
    _, times, _, _, _ = probed(r, scene, ["clustered", "hybrid"], 1e9)
    assert [f for f in r.frames if f[1] == PROBE] == [("clustered", PROBE)] + [("hybrid", PROBE)] * 2
    assert times["hybrid"] == pytest.approx(0.02 * 64 * 36)          # not its compile frame


def test_a_ranking_frame_over_the_long_frame_limit_is_its_own_rank(timed):
    # tiled's first 8x8 frame would take 64 s (over LONG_FRAME_MS): it stops at its 6 s
    # deadline (the budget), takes no second one, and is never timed at the probe size
    scene, make = timed
    r = make({"tiled": per_pixel(1000.0), "clustered": per_pixel(0.01)}, compile_ms=1.0)
    name, _, _, skipped, _ = probed(r, scene, ["tiled", "clustered"], 6.0)
    assert name == "clustered" and skipped == ["tiled"]
    assert r.frames == [("tiled", SMALL), ("clustered", SMALL), ("clustered", SMALL), ("clustered", PROBE)]


def test_no_candidate_or_one_takes_no_ranking_frame(timed):
    scene, make = timed
    r = make({"clustered": per_pixel(0.01)})
    assert probed(r, scene, [], 6.0) == (None, {}, PROBE, [], {}) and not r.frames
    name, times, _, skipped, _ = probed(r, scene, ["clustered"], 6.0)
    assert name == "clustered" and list(times) == ["clustered"] and not skipped
    assert r.frames == [("clustered", PROBE)] * 2                     # the first compiles
    assert times["clustered"] == pytest.approx(0.01 * 64 * 36)


def test_refusals_are_left_out_unbuilt_and_a_lone_survivor_is_not_ranked(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(probe, "time", clock)
    scene, base = probe_setup()                     # tiled and zbin refuse at this loop budget
    r = TimedRenderer(scene, {"clustered": per_pixel(0.01)}, clock)
    r.loop_budget = base.loop_budget
    name, _, _, skipped, refused = probed(r, scene, ["tiled", "clustered", "zbin"], 6.0)
    assert name == "clustered" and not skipped and list(refused) == ["tiled", "zbin"]
    assert r.frames == [("clustered", PROBE)] * 2


class Slowpoke(Technique):
    """A technique module nobody told the probe about, registered before every other."""
    name = "slowpoke"


def test_a_new_slow_technique_registered_first_is_the_one_the_start_skips(timed, capsys):
    scene, make = timed
    r = make({"slowpoke": per_pixel(0.1), "clustered": per_pixel(0.01), "tree": per_pixel(0.03)})
    with registered(Slowpoke(), at=0), pytest.MonkeyPatch.context() as m:
        args = SimpleNamespace(scene="city", seed=0, distribution=None, reprobe=True)
        m.setattr(probe, "PROBE_BUDGET_S", 0.08)
        name, lines = probe.choose_start(args, r, ["slowpoke", "clustered", "tree"], GivenOptions({}),
                                         lambda: scene.lights, scene.camera, probe.FrameCosts())
    assert name == "clustered" and len(lines) == 1
    assert lines[0].startswith("started on clustered, the fastest of those probed (clustered 23 ms, tree 69 ms; ")
    assert lines[0].endswith("; not probed for time: slowpoke)")
    err = capsys.readouterr().err.splitlines()
    assert "window: probe: timing 3 techniques at 64x36, the likely fastest first (ranked by a frame " \
           "each at 8x8), 64 lights (--technique NAME starts without the probe)" in err
    assert "window: probe: ranked at 8x8: clustered 1 ms, tree 2 ms, slowpoke 6 ms" in err


# ---- the deadline: a frame that runs past it stops between two passes and is left out ----

def test_a_ranking_frame_past_its_deadline_is_left_out_and_stops_there(timed, capsys):
    # slowpoke (a new module, registered first) needs 3.2 s a ranking frame at 8x8, over the
    # 1 s budget that is each ranking frame's deadline: its first frame stops 1 s into its
    # passes (its 5 s compile not counted), it takes no second one and is left out, with its
    # line; clustered and tree are ranked and timed as before
    scene, make = timed
    r = make({"slowpoke": per_pixel(50.0), "clustered": per_pixel(0.01), "tree": per_pixel(0.03)})
    with registered(Slowpoke(), at=0):
        name, times, _, skipped, refused = probed(r, scene, ["slowpoke", "clustered", "tree"], 1.0)
    assert name == "clustered" and list(times) == ["clustered", "tree"] and skipped == ["slowpoke"]
    assert not refused
    assert r.frames == ([("slowpoke", SMALL)] + [(n, SMALL) for n in ("clustered", "tree") for _ in (0, 1)]
                        + [("clustered", PROBE), ("tree", PROBE)])
    compiles, frames = 3 * 5.0, (0.01 + 0.03) * (2 * 64 + 64 * 36) / 1e3
    assert r.clock.now == pytest.approx(compiles + 1.0 + frames)       # 1 s of slowpoke, not 3.2
    err = capsys.readouterr().err.splitlines()
    assert "window: probe: left out slowpoke: its ranking frame at 8x8 ran past the probe's 1 s deadline " \
           "(frame stopped at its deadline after 1.0 s of its passes)" in err
    assert "window: probe: ranked at 8x8: clustered 1 ms, tree 2 ms, slowpoke (over the 1 s deadline)" in err


def test_a_timing_frame_past_the_budget_is_stopped_and_not_probed_for_time(timed, capsys):
    # tree ranks close to clustered at 8x8 (1 ms: expected 36 ms at 64x36, well in the 1 s
    # budget) but takes 5 s there: its frame stops 1 s in (the budget: what the expectation
    # would not have started), and it is left out for time; the first timed frame has none
    scene, make = timed
    r = make({"clustered": per_pixel(0.01), "tree": lambda pixels: 1.0 if pixels < 100 else 5000.0})
    name, times, _, skipped, refused = probed(r, scene, ["tree", "clustered"], 1.0)
    assert name == "clustered" and list(times) == ["clustered"] and skipped == ["tree"] and not refused
    assert [f for f in r.frames if f[1] == PROBE] == [("clustered", PROBE), ("tree", PROBE)]
    ranking = 2 * 5.0 + 2 * (0.01 * 64 + 1.0) / 1e3
    assert r.clock.now == pytest.approx(ranking + 0.01 * 64 * 36 / 1e3 + 1.0)   # 1 s of tree, not 5
    assert any(l.startswith("window: probe: tree not timed: its frame at 64x36 ran past the probe's 1 s "
                            "budget (frame stopped at its deadline after 1.0 s") for l in capsys.readouterr().err.splitlines())


def test_when_every_ranking_frame_is_past_its_deadline_the_first_is_still_timed(timed):
    scene, make = timed
    r = make({"clustered": per_pixel(50.0), "tree": per_pixel(60.0)}, compile_ms=1.0)
    name, times, _, skipped, refused = probed(r, scene, ["clustered", "tree"], 1.0)
    assert name == "clustered" and list(times) == ["clustered"] and skipped == ["tree"] and not refused
