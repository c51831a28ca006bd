"""Long runs and determinism.

- 500 frames through one Renderer (tiny resolution, the gallery's mixed spots and points,
  the camera path, every REGISTRY technique in turn, readback=False as a window or the
  benchmark runs it): process memory (RSS from /proc/self/statm) and GL objects stay flat
  after warm-up.  moderngl keeps no global object count, so GL objects are counted two ways:
  the renderer's live objects (its storage buffers and compiled programs), and the GL names
  handed out meanwhile: Mesa gives new names in increasing order, so a probe object made
  before and after the run shows how many objects of its kind were created in between.
- Creating and releasing renderers (scene switches) returns their GL objects.
- Determinism: the same scene, seed and technique give a bit-identical dump, across two
  processes (a capture subprocess and the capture's entry point in the test process) and
  across renderers in one process.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
import gc
import json
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from app.dump import FIELDS, exactness, read_dump
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes import load_scene

ROOT = Path(__file__).resolve().parents[2]
SIZE = (32, 24)
FRAMES = 500
PATH_FRAMES = 60           # camera loop; a multiple of len(REGISTRY) would align, 60 covers both
WARMUP = 120               # two full loops of (camera frame, technique) pairs
RSS_TOLERANCE = 8 << 20
TIMING_KEYS = ("cpu_ms", "gpu_ms", "setup_ms", "cpu_warmup_ms", "wall_s")


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def live_objects(r: Renderer) -> dict[str, int]:
    return {"buffers": len(r.buffers), "programs": len(r.programs._programs)}


def probe_names(ctx) -> dict[str, int]:
    """The GL name the next object of each kind gets (the probes are released again)."""
    out = {}
    b = ctx.buffer(reserve=4)
    out["buffer"] = b.glo
    b.release()
    t = ctx.texture((1, 1), 1)
    out["texture"] = t.glo
    t.release()
    p = ctx.compute_shader("#version 430\nlayout(local_size_x = 1) in;\nvoid main() {}\n")
    out["program"] = p.glo
    p.release()
    return out


def test_500_frames_keep_memory_and_gl_objects_flat(gl):
    scene = load_scene("gallery", seed=5)
    assert len(scene.path) > 0 and set(scene.lights["type"].tolist()) == {0, 1}
    names = list(REGISTRY)
    with Renderer(scene, SIZE) as r:
        checks = 0
        names_before = live_before = rss_before = None
        for f in range(FRAMES):
            t = REGISTRY[names[f % len(names)]]
            out = r.render(t, f, frames=PATH_FRAMES, readback=False)
            assert out.meta["frame"] == f and out.image is None
            if f == WARMUP - 1:
                gc.collect()
                live_before, rss_before = live_objects(r), rss_bytes()
                p1 = probe_names(gl)
                names_before = probe_names(gl)
                probe_cost = {k: names_before[k] - p1[k] for k in p1}   # names one probe uses
            if f % 100 == 50:
                # now and then read every technique back at this frame: still exact
                res = {n: r.render(REGISTRY[n], f, frames=PATH_FRAMES) for n in names}
                bad = {n: exactness(x, res["brute"]) for n, x in res.items()
                       if exactness(x, res["brute"]) != (0, 0)}
                assert not bad, f"frame {f}: differs from brute {bad}"
                checks += 1
        gc.collect()
        live_after, names_after, rss_after = live_objects(r), probe_names(gl), rss_bytes()
    assert checks >= 4
    assert live_after == live_before, f"live GL objects grew: {live_before} -> {live_after}"
    created = {k: names_after[k] - names_before[k] - probe_cost[k] for k in names_after}
    assert all(v <= 2 for v in created.values()), (
        f"GL objects created during {FRAMES - WARMUP} frames after warm-up (renderer promises "
        f"no per-frame allocation): {created}")
    grown = rss_after - rss_before
    assert grown < RSS_TOLERANCE, f"RSS grew by {grown / 2**20:.1f} MiB over {FRAMES - WARMUP} frames"


def test_renderer_create_release_cycles_keep_memory_flat(gl):
    """A scene switch makes a new Renderer and releases the old one; 30 switches must not
    leave GL objects behind (measured as process RSS: llvmpipe keeps compiled programs in
    process memory) nor grow the GL name space by more than each switch recreates."""
    scene = load_scene("gallery", lights=20, seed=5)

    def cycle():
        with Renderer(scene, SIZE) as r:
            for t in REGISTRY.values():
                r.render(t, 0, readback=False)
        del r
        gc.collect()

    for _ in range(3):
        cycle()
    before = rss_bytes()
    for _ in range(30):
        cycle()
    grown = rss_bytes() - before
    assert grown < RSS_TOLERANCE, (
        f"RSS grew by {grown / 2**20:.1f} MiB over 30 renderer create/release cycles "
        f"({grown / 30 / 2**20:.2f} MiB each): Renderer.release() leaves GL objects alive")


def test_repeated_renders_are_bit_identical_in_process(gl):
    scene = load_scene("gallery", lights=60, seed=9)
    runs = []
    for _ in range(2):
        with Renderer(scene, (48, 32)) as r:
            runs.append({n: r.render(t, 7) for n, t in REGISTRY.items()})
            again = {n: r.render(t, 7) for n, t in REGISTRY.items()}
        for n in REGISTRY:
            for k in FIELDS:
                a, b = getattr(runs[-1][n], k), getattr(again[n], k)
                assert a.tobytes() == b.tobytes(), f"{n}: {k} differs between two frames"
    for n in REGISTRY:
        for k in FIELDS:
            a, b = getattr(runs[0][n], k), getattr(runs[1][n], k)
            assert a.tobytes() == b.tobytes(), f"{n}: {k} differs between two renderers"
        assert runs[0][n].contrib_count.sum() > 0


# ------------------------------------------------------------------------ capture determinism

CAPTURE = ["--scene", "gallery", "--lights", "80", "--seed", "13", "--size", "64x48",
           "--frame", "5"]


def _capture(technique: str, out: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "app.capture", *CAPTURE, "--technique", technique,
                           "--dump", str(out)], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)


def _capture_here(technique: str, out: Path) -> subprocess.CompletedProcess:
    """The same capture through its entry point in this (the test) process: another
    process than the subprocess's, with its own GL context and everything run before it."""
    import contextlib
    import io
    from app import capture
    argv = [*CAPTURE, "--technique", technique, "--dump", str(out)]
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        capture.main(argv)
    return subprocess.CompletedProcess(argv, 0, stdout.getvalue(), "")


@pytest.fixture(scope="module")
def dumps(gl, tmp_path_factory):
    """Each technique captured in two processes: a capture subprocess (all of them
    concurrently) and this one: {technique: (a, b)}."""
    d = tmp_path_factory.mktemp("dumps")
    jobs = {(n, i): d / f"{n}-{i}.npz" for n in REGISTRY for i in (0, 1)}
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as ex:
        procs = {(n, 0): ex.submit(_capture, n, jobs[(n, 0)]) for n in REGISTRY}
        here = {(n, 1): _capture_here(n, jobs[(n, 1)]) for n in REGISTRY}
        procs = {**here, **{k: f.result() for k, f in procs.items()}}
    for k, p in procs.items():
        assert p.returncode == 0, f"capture {k} failed: {p.stderr}"
    return {n: tuple((read_dump(jobs[(n, i)]), json.loads(procs[(n, i)].stdout)) for i in (0, 1))
            for n in REGISTRY}


def _strip(meta: dict) -> dict:
    return {k: v for k, v in meta.items() if k not in TIMING_KEYS}


@pytest.mark.parametrize("technique", list(REGISTRY))
def test_capture_dump_is_bit_identical_across_runs(dumps, technique):
    (a, sa), (b, sb) = dumps[technique]
    for k in FIELDS:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape
        assert a[k].tobytes() == b[k].tobytes(), f"{technique}: dump field {k} differs between runs"
    assert _strip(a["meta"]) == _strip(b["meta"]), "meta differs apart from timings"
    assert _strip(sa) == _strip(sb), "printed summary differs apart from timings"
    assert a["meta"]["technique"] == technique
    assert int(a["contrib_count"].sum()) > 0, "the capture lights nothing: determinism is vacuous"


def test_capture_dumps_are_exact_against_brute(dumps):
    """The contract's exactness check through the dumps the CLI writes."""
    ref = dumps["brute"][0][0]
    for n, ((a, _), _) in dumps.items():
        assert (a["contrib_count"] == ref["contrib_count"]).all(), f"{n}: contrib_count"
        assert (a["contrib_hash"] == ref["contrib_hash"]).all(), f"{n}: contrib_hash"
        assert (a["depth"] == ref["depth"]).all(), f"{n}: depth"
        assert np.isfinite(a["image"]).all()
