"""The KHR wave path (GL_KHR_shader_subgroup, WAVE_NATIVE = gl.WAVE_KHR) compiled by glslang
for OpenGL, since llvmpipe has no KHR_shader_subgroup to run it: the texts the shader loader
makes for every program a native render compiles, with WAVE_NATIVE = KHR (the shading
passes; raster's mark and cluster fragment stages, whose compaction is wave.glsl's
waveCompactValue, checked to reach the subgroup calls), and every wave function in a compute
and a fragment stage.  A syntax or type error in the KHR path fails here.  A missing
glslangValidator fails (the set-up installs it with LAB_WITH_XVFB=1), never skips."""
from __future__ import annotations

from pathlib import Path
import re
import shutil
import subprocess

import pytest

from app.pipeline import gl as glmod
from app.pipeline.renderer import Renderer
from app.pipeline.shaders import Source, stage_texts
from app.techniques import REGISTRY
from scenes import load_scene
from tests.helpers import takes

# -G: SPIR-V for OpenGL, whose subgroup operations glslang wants at SPIR-V 1.3; --aml: the
# driver places the default-block uniforms and varyings itself (SPIR-V wants locations).
GLSLANG_ARGS = ("-G", "--target-env", "spirv1.3", "--aml")
ARB_CALLS = re.compile(r"\b(\w+ARB)\b")
GLSLANG_AT = re.compile(r"\b(\d+):(\d+):")


def glslang() -> str:
    exe = shutil.which("glslangValidator")
    if exe is None:
        pytest.fail("glslangValidator not found: install glslang-tools (LAB_WITH_XVFB=1 scripts/setup.sh)")
    return exe


def compile_khr(tmp: Path, name: str, source: Source, text: str, stage: str) -> str:
    """Compile one stage's final text; returns glslang's preprocessed text.  Fails with the
    first error, located as file:line of the project's sources."""
    exe = glslang()
    path = tmp / f"{name}.{stage}"
    path.write_text(text)
    run = subprocess.run([exe, *GLSLANG_ARGS, "-S", stage, str(path), "-o", str(tmp / "out.spv")],
                         capture_output=True, text=True)
    if run.returncode != 0:
        log = run.stdout + run.stderr
        first = next((l for l in log.splitlines() if "ERROR" in l), log.strip()[:300])
        # glslang writes 'ERROR: <source string>:<line>: ...'; the loader's #line numbers
        # the strings by file
        at = lambda m: f"{source.files[int(m[1])] if int(m[1]) < len(source.files) else m[1]}:{m[2]}:"
        pytest.fail(f"{name} ({stage}, KHR path): {GLSLANG_AT.sub(at, first.strip(), count=1)}")
    pre = subprocess.run([exe, "-E", "-S", stage, str(path)], capture_output=True, text=True)
    assert pre.returncode == 0, pre.stdout + pre.stderr
    return pre.stdout


def khr_text(source: Source, defines: dict) -> str:
    return source.text(dict(defines, WAVE_NATIVE=glmod.WAVE_KHR))


def native_programs(gl) -> dict:
    """The program keys of native renders: every technique that takes native_wave, and
    raster's compaction variants (tile and cluster rasterizers) whose fragment stages use it."""
    runs = [(name, {"native_wave": True}) for name in REGISTRY if takes(name, "native_wave")
            and "native_wave" not in REGISTRY[name].Options().ignored()]
    runs += [(name, {"native_wave": True, "scalarize": True}) for name in REGISTRY
             if takes(name, "native_wave", "scalarize")]
    runs += [("raster", {"raster_variant": 2, "native_wave": True}),
             ("raster", {"raster_variant": 3, "cluster": True}),
             ("zbin", {"zbin_variant": 3, "native_wave": True})]
    if not glmod.limits().native_wave:
        pytest.fail("no native wave path on this driver: no native render to take programs from")
    scene = load_scene("corridor", lights=96, seed=3)
    with Renderer(scene, (48, 32)) as r:
        for name, opts in runs:
            r.render(REGISTRY[name], 0, opts)
        keys = [k for k in r.programs.sources if dict(k.optional).get("WAVE_NATIVE")]
    return {k: k._replace(extensions=(),     # the loader emits the path's lines itself
                          optional=tuple(sorted(dict(k.optional, WAVE_NATIVE=glmod.WAVE_KHR).items())))
            for k in keys}


def test_native_programs_compile_on_the_khr_path(gl, tmp_path):
    glslang()
    programs = native_programs(gl)
    names = {k.names for k in programs}
    for want in (("shade_zbin.comp",), ("raster_proxy.vert", "raster_mark.frag"),
                 ("raster_proxy.vert", "raster_cluster.frag")):
        assert want in names, (want, names)
    assert any(k.names == ("shade_clustered.comp",) and dict(k.defines)["SCALARIZED"] for k in programs)
    zbin_checked, compact_checked = False, set()
    for n, key in enumerate(sorted(programs.values())):
        sources, texts = stage_texts(key)
        stages = ["comp"] if len(texts) == 1 else ["vert", "frag"]
        for source, text, stage in zip(sources, texts, stages):
            pre = compile_khr(tmp_path, f"p{n}_{source.files[0]}", source, text, stage)
            d = dict(key.defines)
            if stage == "frag" and d.get("RASTER_COMPACT"):
                # raster's compaction: wave.glsl's waveCompactValue on KHR alone (helper
                # invocations not counted), no ARB call left
                assert not ARB_CALLS.findall(pre), (source.files[0], set(ARB_CALLS.findall(pre)))
                assert "waveCompactValue(" in pre[pre.index("void mark"):], source.files[0]
                for fn in ("subgroupBroadcastFirst", "subgroupBallot", "subgroupBallotExclusiveBitCount",
                           "gl_HelperInvocation"):
                    assert fn in pre, (source.files[0], fn)
                compact_checked.add(source.files[0])
            if stage != "comp":
                continue
            # a shading pass: the wave API on KHR alone, no ARB call left
            assert not ARB_CALLS.findall(pre), (source.files[0], set(ARB_CALLS.findall(pre)))
            if source.files[0] == "shade_zbin.comp" and d.get("SCALARIZED") and d.get("ZBIN_MASKED"):
                body = pre[pre.index("void main"):]     # the slides' final listing, on KHR
                for fn in ("waveAllMin", "waveAllMax", "waveAllBitOr", "waveReadFirstLane"):
                    assert fn in body, fn
                for fn in ("subgroupMin", "subgroupMax", "subgroupOr", "subgroupBroadcastFirst"):
                    assert fn in pre, fn
                zbin_checked = True
    assert zbin_checked
    assert compact_checked == {"raster_mark.frag", "raster_cluster.frag"}, compact_checked


# Every wave function, in a compute stage and (WAVE_FRAGMENT) a fragment stage: the latter
# as raster's compaction would run on wave.glsl (one atomic per distinct bit).
EVERY = """
    uint v = LANE_VALUE;
    uvec4 b = waveBallot(v > 3u);
    uint r = waveAllMin(v) + waveAllMax(v) + waveAllBitOr(v) + waveReadFirstLane(v)
           + b.x + b.y + b.z + b.w + waveLaneCount() + waveLaneIndex()
           + wavePrefixCountBits(v > 2u) + waveCompactValue(v & 7u)
           + (waveActiveAllTrue(v != 0u) ? 1u : 0u) + (waveActiveAnyTrue(v == 5u) ? 1u : 0u);
"""
FILES = {
    "every.comp": "#version 430\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
                  "#include \"wave.glsl\"\n"
                  "layout(std430, binding = 0) buffer Out { uint outv[]; };\n"
                  "void main() {\n#define LANE_VALUE gl_LocalInvocationIndex\n" + EVERY
                  + "    outv[gl_LocalInvocationIndex] = r + groupAllMax(v);\n}\n",
    "every.frag": "#version 450\nlayout(early_fragment_tests) in;\n#define WAVE_FRAGMENT 1\n"
                  "#include \"wave.glsl\"\n"
                  "layout(std430, binding = 0) buffer Bits { uint bits[]; };\n"
                  "flat in uint v_light;\nuniform int u_tiles_x;\n"
                  "void main() {\n#define LANE_VALUE v_light\n" + EVERY
                  + "    uint word = uint(gl_FragCoord.y) * uint(u_tiles_x) + v_light / 32u;\n"
                  "    if (waveCompactValue(word * 32u + (v_light & 31u)) == 0u)\n"
                  "        atomicOr(bits[word], r | (1u << (v_light & 31u)));\n}\n",
}


@pytest.mark.parametrize("name", sorted(FILES))
def test_every_wave_function_compiles_on_the_khr_path(name, tmp_path):
    source = Source(name, FILES)
    pre = compile_khr(tmp_path, name, source, khr_text(source, {}), name.split(".")[1])
    assert not ARB_CALLS.findall(pre), set(ARB_CALLS.findall(pre))
    assert ("shared uint" in pre) == name.endswith(".comp")   # no group* in a fragment stage


def test_glslang_finds_an_error_in_the_khr_path(tmp_path):
    """The check is not vacuous: a type error in the KHR branch alone fails it, located."""
    glslang()
    broken = (Path(__file__).resolve().parents[3] / "glsl" / "wave.glsl").read_text().replace(
        "uvec4 waveBallot(bool b) { return subgroupBallot(b); }",
        "uvec4 waveBallot(bool b) { return subgroupBallot(b).x; }")
    assert "subgroupBallot(b).x" in broken
    files = dict(FILES, **{"wave.glsl": broken})
    source = Source("every.comp", files)
    with pytest.raises(pytest.fail.Exception, match=r"every.comp \(comp, KHR path\): ERROR: wave.glsl:\d+"):
        compile_khr(tmp_path, "every.comp", source, khr_text(source, {}), "comp")
