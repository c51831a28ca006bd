"""The start-up probe's memory is only reused by the code and scene file that measured it."""
from pathlib import Path

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


def test_code_version_of_the_lab_hashes_its_shaders():
    assert any(probe.ROOT.glob("glsl/*.comp")) and len(probe.code_version()) == 16


def test_file_stamp_changes_with_the_scene_file(tmp_path):
    scene = tmp_path / "s.json"
    scene.write_text("{}")
    first = probe.file_stamp(str(scene))
    scene.write_text("{ }")
    assert probe.file_stamp(str(scene)) != first
    assert probe.file_stamp("city") is None
