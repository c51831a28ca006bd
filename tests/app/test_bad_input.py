"""Bad input through the command line (docs/contracts.md "Contract: scene files" and "capture"): every
rejection is exit status 2 and exactly one line on stderr naming the field, no traceback.

tests/scenes/test_loader.py unit-tests the loader; here the same kinds of faults go through
`python -m app.capture` as a user would meet them.  The subprocesses of all cases run
concurrently once per module (each costs ~0.5 s of interpreter start-up), and each case is
its own named test reading its result.

Also: buffers beyond the GL limits are refused with a clear message before allocating.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
import json
import os
from pathlib import Path
import re
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import npz_arrays, write_npz

ROOT = Path(__file__).resolve().parents[2]
PYTHON = sys.executable


def good_scene() -> dict:
    return {
        "resolution": [32, 24],
        "camera": {"position": [0, 2, 10], "target": [0, 1, 0], "up": [0, 1, 0],
                   "fov_y_deg": 60, "near": 0.1, "far": 100},
        "geometry": [{"box": {"min": [-20, -0.1, -20], "max": [20, 0, 20]}}],
        "lights": [
            {"type": "point", "position": [0, 1, 0], "radius": 3, "color": [1, 0.9, 0.8],
             "intensity": 5},
            {"type": "spot", "position": [2, 4, 0], "direction": [0, -1, 0], "radius": 10,
             "inner_angle_deg": 20, "outer_angle_deg": 30},
        ],
    }


# ------------------------------------------------------------------------------ case makers
# Each maker writes what it needs into `d` (a fresh directory) and returns the argv after
# `python -m app.capture`.

def scene_file(d: Path, mutate=None, name="scene.json", text=None, raw: bytes | None = None):
    p = d / name
    if raw is not None:
        p.write_bytes(raw)
    elif text is not None:
        p.write_text(text)
    else:
        s = good_scene()
        if mutate:
            mutate(s)
        p.write_text(json.dumps(s, allow_nan=True))   # NaN / Infinity literals on purpose
    return p


def scene_case(mutate=None, extra=(), **kw):
    def make(d: Path):
        return ["--scene", str(scene_file(d, mutate, **kw)), "--technique", "brute", *extra]
    return make


def flag_case(*flags, scene=True):
    def make(d: Path):
        base = ["--scene", str(scene_file(d))] if scene else []
        return [*base, *flags]
    return make


def setp(path: str, value):
    """Mutation setting a dotted/indexed path of the scene dict, e.g. 'lights.0.radius'."""
    def mutate(s):
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        obj = s
        for k in keys[:-1]:
            obj = obj[k]
        obj[keys[-1]] = value
    return mutate


def delp(path: str):
    def mutate(s):
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        obj = s
        for k in keys[:-1]:
            obj = obj[k]
        del obj[keys[-1]]
    return mutate


def with_mesh(content: bytes | None, name="m.obj", make_dir=False):
    def make(d: Path):
        if make_dir:
            (d / name).mkdir()
        elif content is not None:
            (d / name).write_bytes(content)
        s = good_scene()
        s["geometry"].append({"mesh": name})
        p = d / "scene.json"
        p.write_text(json.dumps(s))
        return ["--scene", str(p)]
    return make


def with_npz(change=None, raw: bytes | None = None, name="lights.npz", write=True):
    def make(d: Path):
        if raw is not None:
            (d / name).write_bytes(raw)
        elif write:
            a = npz_arrays()
            if change:
                change(a)
            write_npz(d, a, name)
        s = good_scene()
        s["lights_npz"] = name
        p = d / "scene.json"
        p.write_text(json.dumps(s))
        return ["--scene", str(p)]
    return make


def truncated_npz() -> bytes:
    import io
    buf = io.BytesIO()
    np.savez(buf, **npz_arrays())
    return buf.getvalue()[:200]


def npz_set(key, value):
    def change(a):
        a[key] = value
    return change


def npz_del(key):
    def change(a):
        del a[key]
    return change


# id -> (maker, regex the single stderr line must match: the field it names)
CASES = {
    # non-finite numbers (Python's json reads NaN / Infinity literals)
    "nan_light_position": (scene_case(setp("lights.0.position", [float("nan"), 0, 0])),
                           r"lights\[0\]\.position"),
    "inf_camera_fov": (scene_case(setp("camera.fov_y_deg", float("inf"))), r"camera\.fov_y_deg"),
    "neg_inf_radius": (scene_case(setp("lights.1.radius", float("-inf"))), r"lights\[1\]\.radius"),
    "nan_camera_near": (scene_case(setp("camera.near", float("nan"))), r"camera\.near"),
    "float32_overflow_intensity": (scene_case(setp("lights.0.intensity", 1e39)),
                                   r"lights\[0\]\.intensity"),
    # radius
    "zero_radius": (scene_case(setp("lights.1.radius", 0)), r"lights\[1\]\.radius"),
    "negative_radius": (scene_case(setp("lights.0.radius", -1.5)), r"lights\[0\]\.radius"),
    "opacity_above_one": (scene_case(setp("geometry.0.opacity", 1.5)), r"geometry\[0\]\.opacity"),
    "opacity_negative": (scene_case(setp("geometry.0.opacity", -0.25)), r"geometry\[0\]\.opacity"),
    "opacity_not_a_number": (scene_case(setp("geometry.0.opacity", "glass")), r"geometry\[0\]\.opacity"),
    "string_radius": (scene_case(setp("lights.0.radius", "3")), r"lights\[0\]\.radius"),
    # light types and fields
    "unknown_light_type": (scene_case(setp("lights.0.type", "area")), r"lights\[0\]\.type"),
    "missing_light_type": (scene_case(delp("lights.1.type")), r"lights\[1\]\.type"),
    "missing_light_position": (scene_case(delp("lights.0.position")), r"lights\[0\]\.position"),
    "missing_spot_direction": (scene_case(delp("lights.1.direction")), r"lights\[1\]\.direction"),
    "spot_inner_over_outer": (scene_case(setp("lights.1.inner_angle_deg", 40)),
                              r"lights\[1\]\.inner_angle_deg"),
    "spot_outer_over_90": (scene_case(setp("lights.1.outer_angle_deg", 90.5)),
                           r"lights\[1\]\.outer_angle_deg"),
    # camera
    "missing_camera": (scene_case(delp("camera")), r"\bcamera\b"),
    "missing_camera_position": (scene_case(delp("camera.position")), r"camera\.position"),
    "near_equals_far": (scene_case(lambda s: s["camera"].update(near=5.0, far=5.0)),
                        r"camera\.(near|far)"),
    "near_over_far": (scene_case(lambda s: s["camera"].update(near=50.0, far=1.0)),
                      r"camera\.(near|far)"),
    "zero_near": (scene_case(setp("camera.near", 0)), r"camera\.near"),
    "target_is_position": (scene_case(setp("camera.target", [0, 2, 10])), r"camera\.target"),
    "up_parallel_to_view": (scene_case(lambda s: s["camera"].update(target=[0, -5, 10])),
                            r"camera\.up"),
    # resolution in the file
    "missing_resolution": (scene_case(delp("resolution")), r"resolution"),
    "zero_resolution": (scene_case(setp("resolution", [0, 10])), r"resolution"),
    "absurd_resolution": (scene_case(setp("resolution", [99999, 10])), r"resolution"),
    "fractional_resolution": (scene_case(setp("resolution", [32.5, 24])), r"resolution"),
    "missing_lights": (scene_case(delp("lights")), r"\blights\b"),
    # meshes
    "mesh_missing_file": (with_mesh(None, "nope.obj"), r"geometry\[1\]\.mesh"),
    "mesh_garbage_bytes": (with_mesh(bytes(range(256)) * 4, "m.obj"), r"geometry\[1\]\.mesh"),
    "mesh_is_directory": (with_mesh(None, "dir.obj", make_dir=True), r"geometry\[1\]\.mesh"),
    "mesh_unknown_format": (with_mesh(b"solid x\n", "m.xyzzy"), r"geometry\[1\]\.mesh"),
    # light npz
    "npz_missing_file": (with_npz(write=False), r"lights_npz"),
    "npz_not_a_zip": (with_npz(raw=b"not a zip at all\n"), r"lights_npz"),
    "npz_truncated": (with_npz(raw=truncated_npz()), r"lights_npz"),
    "npz_missing_array": (with_npz(npz_del("radius")), r"lights_npz\.radius"),
    "npz_nan_position": (with_npz(npz_set("position", np.float32([[0, 0, 0], [np.nan, 0, 0], [0, 0, 0]]))),
                         r"lights_npz\.position\[1\]"),
    "npz_zero_radius": (with_npz(npz_set("radius", np.float32([1, 1, 0]))), r"lights_npz\.radius\[2\]"),
    "npz_unknown_type": (with_npz(npz_set("type", np.uint8([0, 7, 0]))), r"lights_npz\.type\[1\]"),
    "npz_wrong_shape": (with_npz(npz_set("color", np.ones((3, 4), np.float32))), r"lights_npz\.color"),
    # malformed files
    "json_unclosed": (scene_case(text="{"), r"JSON"),
    "json_trailing_comma": (scene_case(text='{"resolution": [32, 24],}'), r"JSON"),
    "json_empty_file": (scene_case(text=""), r"JSON"),
    "json_not_utf8": (scene_case(raw=b"\xff\xfe\x00{garbage"), r"scene\.json"),
    "json_top_level_array": (scene_case(text="[1, 2, 3]"), r"top level"),
    "json_nested_too_deep": (scene_case(text="[" * 100000 + "]" * 100000), r"scene\.json"),
    "scene_no_such_file": (lambda d: ["--scene", str(d / "absent.json")], r"absent\.json"),
    # command-line flags
    "size_zero": (flag_case("--size", "0x10"), r"--size"),
    "transparent_layers_zero": (flag_case("--transparent-layers", "0"), r"--transparent-layers"),
    "transparent_layers_past_max": (flag_case("--transparent-layers", "9"), r"--transparent-layers"),
    "size_absurd": (flag_case("--size", "99999x10"), r"--size"),
    "size_not_wxh": (flag_case("--size", "640"), r"--size"),
    "size_negative": (flag_case("--size", "-5x10"), r"--size"),
    "size_over_storage_limit": (flag_case("--size", "4096x4096"), r"4096x4096.*(storage|MiB)"),
    "unknown_technique": (flag_case("--technique", "fastest"), r"technique.*fastest|fastest.*technique"),
    "tile_zero": (flag_case("--tile", "0"), r"--tile"),
    "tile_text": (flag_case("--tile", "abc"), r"--tile"),
    "tile_too_big": (flag_case("--tile", "1000"), r"--tile"),
    "tile_fraction": (flag_case("--tile", "16.5"), r"--tile"),
    "lights_negative": (flag_case("--lights", "-1"), r"--lights"),
    "lights_over_file_count": (flag_case("--lights", "10"), r"lights"),
    "seed_negative": (flag_case("--seed", "-1"), r"--seed"),
    "slices_one": (flag_case("--slices", "1"), r"--slices"),
    "max_leaves_not_pow2": (flag_case("--max-leaves", "3"), r"--max-leaves"),
    "radius_scale_nan": (flag_case("--radius-scale", "nan"), r"--radius-scale"),
    "radius_scale_inf": (flag_case("--radius-scale", "inf"), r"--radius-scale"),
    "frame_negative": (flag_case("--frame", "-1"), r"--frame"),
    "frames_zero": (flag_case("--frames", "0"), r"--frames"),
    "repeat_negative": (flag_case("--repeat", "-1"), r"--repeat must be >= 0"),
    "unknown_flag": (flag_case("--bogus-flag"), r"--bogus-flag"),
    # an option the technique's mode ignores: refused, naming it and the mode
    "raster_cluster_stencil": (flag_case("--technique", "raster", "--cluster", "1", "--stencil"),
                               r"--stencil is ignored in cluster mode \(--cluster 1\)"),
    "raster_cluster_native_wave": (flag_case("--technique", "raster", "--cluster", "2", "--native-wave"),
                                   r"--native-wave is ignored in cluster mode \(--cluster 2\)"),
    "raster_cluster_zbin_variant": (flag_case("--technique", "raster", "--cluster", "1", "--zbin-variant", "1"),
                                    r"--zbin-variant 1 is ignored in cluster mode"),
    "raster_tile_cluster_slices": (flag_case("--technique", "raster", "--cluster-slices", "24"),
                                   r"--cluster-slices 24 is ignored in tile mode"),
    "raster_no_zbins_zbins": (flag_case("--technique", "raster", "--zbin-variant", "2", "--zbins", "64"),
                              r"--zbins 64 is ignored without z-bins \(--zbin-variant 2\)"),
    "stochastic_seed_without_budget": (flag_case("--stochastic-seed", "3"),
                                       r"--stochastic-seed 3 is ignored without --stochastic"),
}


# One case of each kind runs as `python -m app.capture` in its own process, end to end; the
# others call the same entry point (cli.run_main around capture.main) in this process: the
# interpreter's start-up and imports cost ~1.3 s a case, 59 of them a minute of the suite.
IN_OWN_PROCESS = ("negative_radius", "npz_unknown_type", "json_unclosed", "size_over_storage_limit",
                  "unknown_flag", "raster_cluster_stencil")


def _run(argv, cwd) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([PYTHON, "-m", "app.capture", *argv], cwd=cwd, capture_output=True,
                          text=True, timeout=120, env=env)


def _run_here(argv) -> subprocess.CompletedProcess:
    """What `python -m app.capture argv` gives, from its entry point in this process: the
    exit status, stdout and stderr (an uncaught exception as the traceback Python prints)."""
    import contextlib
    import io
    import traceback
    from app import capture, cli
    out, err, status = io.StringIO(), io.StringIO(), 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            cli.run_main(lambda: capture.main(argv))
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except BaseException:           # what the interpreter would print and exit with
            traceback.print_exc(file=err)
            status = 1
    return subprocess.CompletedProcess(argv, status, out.getvalue(), err.getvalue())


@pytest.fixture(scope="module")
def cli_results(gl, tmp_path_factory):
    """Every case's CompletedProcess: the IN_OWN_PROCESS cases' subprocesses concurrently,
    while the others run here, one after another."""
    jobs = {}
    for cid, (make, _) in CASES.items():
        d = tmp_path_factory.mktemp("case")    # neutral name: messages must not match the path
        jobs[cid] = make(d)
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as ex:
        futures = {cid: ex.submit(_run, jobs[cid], ROOT) for cid in IN_OWN_PROCESS}
        here = {cid: _run_here(argv) for cid, argv in jobs.items() if cid not in futures}
        return dict(here, **{cid: f.result() for cid, f in futures.items()})


def test_the_cases_in_their_own_process_are_cases():
    assert set(IN_OWN_PROCESS) <= set(CASES)


@pytest.mark.parametrize("case", list(CASES))
def test_cli_rejects_bad_input(cli_results, case):
    proc = cli_results[case]
    pattern = CASES[case][1]
    err = proc.stderr
    assert "Traceback" not in err, f"{case}: traceback on stderr:\n{err}"
    lines = [l for l in err.splitlines() if l.strip()]
    assert proc.returncode == 2, f"{case}: exit status {proc.returncode}, stderr: {err!r}"
    assert len(lines) == 1, f"{case}: expected exactly one stderr line, got {len(lines)}: {err!r}"
    assert re.search(pattern, lines[0]), f"{case}: '{lines[0]}' does not name /{pattern}/"
    assert len(lines[0]) < 400, f"{case}: message too long ({len(lines[0])} chars)"
    assert "No module named" not in lines[0], (
        f"{case}: the message blames a missing Python module, not the input: '{lines[0]}'")
    assert proc.stdout.strip() == "", f"{case}: printed a result despite the error: {proc.stdout!r}"


def test_good_scene_file_is_accepted(tmp_path):
    """The control: the unmutated scene file renders (so the cases above fail on their fault)."""
    p = scene_file(tmp_path)
    proc = _run(["--scene", str(p), "--technique", "brute", "--dump", str(tmp_path / "d.npz")], ROOT)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "d.npz").is_file()
    s = good_scene()
    s["lights_npz"] = write_npz(tmp_path, npz_arrays())
    (tmp_path / "s2.json").write_text(json.dumps(s))
    proc = _run(["--scene", str(tmp_path / "s2.json"), "--size", "16x8"], ROOT)
    assert proc.returncode == 0, proc.stderr


def test_valid_mesh_with_non_utf8_comment_is_accepted(tmp_path):
    """A well-formed OBJ whose comment holds a Latin-1 byte (as many exporters write) is a
    good mesh: it must load, not be rejected as unreadable."""
    (tmp_path / "m.obj").write_bytes(b"# caf\xe9 export\nv -1 0 -1\nv 1 0 -1\nv 0 1 -1\nf 1 2 3\n")
    s = good_scene()
    s["geometry"].append({"mesh": "m.obj"})
    (tmp_path / "scene.json").write_text(json.dumps(s))
    proc = _run(["--scene", str(tmp_path / "scene.json"), "--size", "16x8"], ROOT)
    assert proc.returncode == 0, proc.stderr


# ------------------------------------------------------------------------------ GL limits

def _tiny_scene():
    from scenes.model import Camera, Scene, make_lights
    from tests.helpers import floor_and_boxes
    return Scene("limits", (16, 8), Camera((0, 3, 10), (0, 1, -20)), floor_and_boxes(),
                 make_lights(0))


def test_output_buffers_over_storage_block_refused_before_allocation(gl, monkeypatch):
    """A resolution whose per-pixel output buffers pass GL_MAX_SHADER_STORAGE_BLOCK_SIZE
    (though each side is within GL_MAX_TEXTURE_SIZE) is refused, naming the limit, before
    the G-buffer or any buffer is allocated."""
    from app.pipeline import gl as glmod, renderer as rmod
    from app.errors import UserError
    lim = glmod.limits()
    w = min(4096, lim.max_texture_size)
    h = lim.max_storage_block // (16 * w) + 1
    assert h <= lim.max_texture_size, "test needs a height within the texture limit"

    def no_alloc(*a, **k):
        raise AssertionError("G-buffer allocated before the size was checked")
    monkeypatch.setattr(rmod, "GBuffer", no_alloc)
    made = []
    real_buffer = type(gl).buffer
    monkeypatch.setattr(type(gl), "buffer", lambda self, *a, **k: made.append(a) or real_buffer(self, *a, **k))
    with pytest.raises(UserError) as exc:
        rmod.Renderer(_tiny_scene(), (w, h))
    msg = str(exc.value)
    assert "\n" not in msg
    assert f"{w}x{h}" in msg and ("storage" in msg.lower())
    assert not made, "GL buffers were allocated before the refusal"


def test_texture_size_limit_refused(gl, monkeypatch):
    from app.pipeline import gl as glmod, renderer as rmod
    from app.errors import UserError
    lim = glmod.limits()
    monkeypatch.setattr(rmod, "GBuffer", lambda *a, **k: pytest.fail("G-buffer allocated"))
    for size in ((lim.max_texture_size + 1, 1), (1, lim.max_texture_size + 1), (0, 5), (5, 0)):
        with pytest.raises(UserError, match="resolution"):
            rmod.Renderer(_tiny_scene(), size)


def test_storage_limit_boundary_and_named_buffer(gl):
    """Exactly at the storage-block limit is allowed (no allocation: the check alone); one
    byte over it for a named buffer is refused naming the buffer, and nothing is kept."""
    from app.pipeline import gl as glmod
    from app.errors import UserError
    from app.pipeline.renderer import Renderer
    lim = glmod.limits()
    with Renderer(_tiny_scene()) as r:
        w = min(4096, lim.max_texture_size)
        r._check_size((w, lim.max_storage_block // (16 * w)))        # at the limit: fine
        with pytest.raises(UserError):
            r._check_size((w, lim.max_storage_block // (16 * w) + 1))
        before = dict(r.buffers)
        alloc = getattr(r, "buffer", None) or getattr(r, "_buffer")   # named storage buffer
        with pytest.raises(UserError, match="entries"):
            alloc("entries", lim.max_storage_block + 1)
        assert r.buffers == before
        # the resize path checks too, and leaves the renderer usable
        with pytest.raises(UserError):
            r.resize((w, lim.max_storage_block // (16 * w) + 1))
        assert r.size == (16, 8)
