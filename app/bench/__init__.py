"""Benchmark: what each culling technique costs and what it gains (DESIGN "Measuring").

    python -m app.bench cpu --scene S --technique T [--lights N] [--size WxH] [--tile 48]
                            [--slices 16] [--repeat R] [--threads 1] [--json]
        The CPU stage alone (no GL context at all; app.bench.cpu): technique.build R times
        after a warm-up (numba JIT), median/min/max ms of each stage and total.  An option
        flag the technique does not take is an error.

    python -m app.bench gpu-build [--scene S] [--sweep 8192,32768,131072] [--size WxH]
                                  [--repeat R] [--technique a,b] [--out DIR] [--json]
        Each technique that takes --build, built on the CPU and on the GPU at each light
        count (app.bench.gpu_build): both builds' ms, their ratio, the GPU build's ms by
        pass; --out writes gpu_build.csv (the report's CPU page reads it) and gpu_build.md.

    python -m app.bench --path PATH.json --out DIR [--scenes S] [--lights N] [--size WxH]
                        [--repeat R] [--techniques a,b] [technique options]
        Every technique along a camera path recorded in the window (app.bench.path:
        `python -m app.window --record PATH.json`), one frame per key: DIR/path.csv, one row
        per frame and technique (GPU ms per pass, CPU ms per stage, lights evaluated and
        exact per pixel, pixels that differ from the reference), path.json, path.png.

    python -m app.bench [--quick|--full] --out DIR [--size WxH] [--scenes a,b] [--lights 1024,4096]
                        [--frames K] [--repeat R] [--threads 1] [--cpu-lights ...] [--cpu-size WxH]
        The sweep (app.bench.sweep): scenes x every technique of the registry x light counts x
        camera-path frames; one study per technique option with declared study values, over
        the techniques that declare it; the light cutoff; a CPU-only light-count series; the
        CPU and GPU builds at --gpu-build-lights (study gpu_build, as `gpu-build` measures).
        Writes DIR/results.csv (columns and studies: app.results), DIR/maps.npz (per-block
        maps of the figures), DIR/run.json and DIR/report.md with its PNG plots (app.report).

Modules: presets (the --quick/--full configurations), plan (the jobs), measure (one row from
a frame), sweep (running it all), cpu (the `cpu` subcommand), path (--path), cutoff (the
light cutoff rule), machine (run.json's machine figures).  Nothing here names a technique: the exactness
reference and the floor are found by role (app.techniques.with_role).

CPU threads: the CPU stage runs on `--threads` numba threads, 1 by default as in the tree
paper's figure 4 ("single threaded").  On small VMs numba's parallel regions can cost more than
the work (a thread wake-up waits for the scheduler tick), so compare thread counts with care.
"""
from __future__ import annotations

import sys


USAGE = """usage: python -m app.bench [--quick|--full] --out DIR [...]     the sweep and its report
       python -m app.bench cpu --scene S --technique T [...]     the CPU stage alone, no GL
                                                                  (python -m app.bench cpu --help)
       python -m app.bench gpu-build [...]                       CPU and GPU builds as a ratio
                                                                  (python -m app.bench gpu-build --help)
       python -m app.bench --path PATH.json --out DIR [...]      every technique along a recorded
                                                                  camera path, per-frame CSV
                                                                  (python -m app.bench --path --help)
"""


def main(argv=None) -> None:
    """`python -m app.bench ...`: the `cpu` subcommand, a camera-path run or the sweep."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["cpu"]:
        from .cpu import cpu_main          # imports no OpenGL
        cpu_main(argv[1:])
        return
    if argv[:1] == ["gpu-build"]:
        from .gpu_build import main as gpu_build_main
        gpu_build_main(argv[1:])
        return
    from .path import wants_path
    if wants_path(argv):
        from .path import path_main
        path_main(argv)
        return
    if any(a in ("-h", "--help") for a in argv):
        print(USAGE)                       # the subcommands, then the sweep's own flags
    from .sweep import sweep_main
    sweep_main(argv)


__all__ = ["main"]
