"""The start-up probe's memory is only reused by the code and scene file that measured it."""
from types import SimpleNamespace

from app.window import probe


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
