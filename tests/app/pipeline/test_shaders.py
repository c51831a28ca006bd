"""Shader loader: #include with #line, defines after #version, unknown defines an error,
compile errors that name the file and line; the program cache."""
import pytest

from app.pipeline import shaders
from app.pipeline.shaders import ProgramCache, ShaderError, Source

MAIN = '#version 430\n// define: N\nlayout(local_size_x = 1) in;\n#include "inc.glsl"\nvoid main() { f(); }\n'


def test_include_is_wrapped_in_line_directives():
    src = Source("main.comp", {"main.comp": MAIN, "inc.glsl": "void f() {}\n"})
    text = src.text({"N": 3})
    lines = text.splitlines()
    assert lines[0] == "#version 430" and lines[1] == "#define N 3" and lines[2] == "#line 2 0"
    i = lines.index("#line 1 1")
    assert lines[i + 1] == "void f() {}" and lines[i + 2] == "#line 5 0"


def test_include_with_a_trailing_comment_is_expanded():
    src = Source("main.comp", {"main.comp": '#version 430\n#include "inc.glsl"   // why\n',
                               "inc.glsl": "void f() {}\n"})
    assert "void f() {}" in src.text({}) and "#include" not in src.text({})


def test_unknown_define_is_an_error():
    src = Source("main.comp", {"main.comp": MAIN, "inc.glsl": ""})
    with pytest.raises(ShaderError, match="unknown define.*TYPO"):
        src.text({"TYPO": 1})


def test_missing_include_and_cycles_are_errors():
    with pytest.raises(ShaderError, match="not found: nope.glsl"):
        Source("m", {"m": '#version 430\n#include "nope.glsl"\n'})
    with pytest.raises(ShaderError, match="cycle"):
        Source("m", {"m": '#version 430\n#include "a"\n', "a": '#include "b"\n', "b": '#include "a"\n'})


def test_include_depth_is_limited():
    files = {f"f{i}": f'#include "f{i + 1}"\n' for i in range(40)}
    files["m"] = '#version 430\n#include "f0"\n'
    with pytest.raises(ShaderError, match="deeper than"):
        Source("m", files)


def test_compile_error_names_included_file_and_line(gl):
    cache = ProgramCache(gl)
    bad = {"main.comp": MAIN, "inc.glsl": "void f() {\n  float x = ;\n}\n"}
    with pytest.raises(ShaderError) as e:
        cache.compute("main.comp", {"N": 1}, bad)
    assert "inc.glsl:2" in str(e.value) and "\n" not in str(e.value)


def test_cache_reuses_programs_and_recompiles_on_define_change(gl):
    cache = ProgramCache(gl)
    files = {"main.comp": MAIN, "inc.glsl": "void f() {}\n"}
    a = cache.compute("main.comp", {"N": 1}, files)
    assert cache.compute("main.comp", {"N": 1}, files) is a
    assert cache.compute("main.comp", {"N": 2}, files) is not a


def test_every_glsl_file_is_reachable():
    from app.gpu_build.prepare import COUNTER_FILES
    from app.pipeline import features
    from app.techniques import REGISTRY
    virtual = dict(features.virtual_files(features.LIGHT_TYPES))
    for t in REGISTRY.values():          # texts techniques generate (e.g. their structs)
        virtual.update(t.glsl)
    virtual.update(COUNTER_FILES)        # the GPU build's generated counter names
    used = set()
    files = shaders.shader_files()
    for name, path in files.items():
        if path.suffix != ".glsl":
            used |= set(Source(name, virtual).files)
    missing = {name for name, path in files.items() if path.suffix == ".glsl"} - used
    assert not missing, f"unused shader files: {missing}"


def test_render_program_error_names_the_failing_stage(gl):
    files = {"v.vert": "#version 430\nvoid main() { gl_Position = vec4(0.0); }\n",
             "f.frag": '#version 430\n// define: K\nout vec4 c;\n#include "inc.glsl"\nvoid main() { c = g(); }\n',
             "inc.glsl": "vec4 g() {\n  return vec4(K) + ;\n}\n"}
    cache = ProgramCache(gl)
    with pytest.raises(ShaderError) as e:
        cache.program("v.vert", "f.frag", {"K": 1}, files)
    assert str(e.value).startswith("f.frag: inc.glsl:2")
    with pytest.raises(ShaderError, match="unknown define"):
        cache.program("v.vert", "f.frag", {"NOPE": 1}, files)
