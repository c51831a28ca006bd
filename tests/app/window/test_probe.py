"""The start-up probe: its memory is only reused by the code and scene file that measured it;
it leaves a technique that would refuse out before building it, and says why."""
from types import SimpleNamespace

import pytest

from app.errors import UserError
from app.pipeline.passes import FrameInput
from app.techniques import REGISTRY
from app.techniques.base import visible_lights
from app.window import probe
from app.window.options import WindowOptions
from cpu_prep.camera import frame_camera
from scenes import load_scene


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

    def render(self, technique, frame, opts, lights, readback, camera):
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
    start = lambda: probe.choose_start(args, r, ["tiled", "clustered", "zbin"], WindowOptions({}),
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
                           WindowOptions({}), lambda: scene.lights, scene.camera, probe.FrameCosts())


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
