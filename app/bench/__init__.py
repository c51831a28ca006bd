"""Benchmark: what each culling technique costs and what it gains (docs/platform.md "Measuring").

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

        The sweep is its preset's studies (app.bench.study: each registers itself, with its
        own config, rows and report sections; a preset is the list of its studies with their
        configs, app.bench.presets), run in order and timed: the run ends with a line a
        study, its wall time and share (run.json's study_s; run.json's config: the shared
        frame settings, then each study's config).

One parser (`parser`): the sweep's flags, and a subcommand each for cpu, gpu-build and the
path run; a subcommand runs its own study and writes its own files, nothing else.

Modules: study (the registry of studies, the frame settings they share), presets (the
--quick/--full presets as their studies' configs, and the sweep's overrides of them), args (the
list arguments), plan (the rendered jobs), measure (one row from a frame), rendered (the
rendered study), sweep (its measuring, and running a preset), validation (the papers' study),
cpu_series (the CPU-only series), temporal, cpu (the `cpu` subcommand, the growth study),
gpu_build, c_reference, caps, path (--path), cutoff (the light cutoff rule), machine (run.json's
machine figures), stereo (two eyes, a structure per view or one over both frusta: app.stereo), transparent
(the frame with its transparent layers against the opaque-only frame), fog (froxel light
sets and the banding case).  Nothing here names a technique: the exactness
reference and the floor are found by role (app.techniques.with_role).

CPU threads: the CPU stage runs on `--threads` numba threads, 1 by default as in the tree
paper's figure 4 ("single threaded").  On small VMs numba's parallel regions can cost more than
the work (a thread wake-up waits for the scheduler tick), so compare thread counts with care.
"""
from __future__ import annotations

import argparse
import sys


USAGE = """commands:
       python -m app.bench [--quick|--full] --out DIR [...]     the sweep and its report
       python -m app.bench cpu --scene S --technique T [...]     the CPU stage alone, no GL
                                                                  (python -m app.bench cpu --help)
       python -m app.bench gpu-build [...]                       CPU and GPU builds as a ratio
                                                                  (python -m app.bench gpu-build --help)
       python -m app.bench --views stereo --out DIR [...]        the two-eye study alone: both
                                                                  ways, DIR/stereo.csv and .md
       python -m app.bench --path PATH.json --out DIR [...]      every technique along a recorded
                                                                  camera path, per-frame CSV
                                                                  (python -m app.bench --path --help)
"""
PATH = "path"                  # the subcommand a `--path PATH.json` command line is


def parser():
    """The command's one parser: the sweep's flags (the default), and a subcommand each for
    cpu, gpu-build and the path run (written `--path PATH.json`, as it always was)."""
    from .. import cli
    from . import cpu, gpu_build, path, stereo, sweep
    p = cli.Parser(prog="python -m app.bench", description=USAGE + "\nthe benchmark sweep and "
                   "its report:", formatter_class=argparse.RawDescriptionHelpFormatter)
    sweep.add_args(p)
    stereo.add_view_args(p)
    sub = p.add_subparsers(dest="command", parser_class=cli.Parser, metavar="{cpu,gpu-build}")
    cpu.add_args(sub.add_parser("cpu", description=cpu.DESCRIPTION, help=cpu.DESCRIPTION))
    gpu_build.add_args(sub.add_parser("gpu-build", description=gpu_build.DESCRIPTION,
                                      help=gpu_build.DESCRIPTION))
    path.add_args(sub.add_parser(PATH, prog="python -m app.bench --path",
                                 description=path.DESCRIPTION))
    return p


def main(argv=None) -> None:
    """`python -m app.bench ...`: parse once, run the subcommand's study (the sweep: its
    preset's studies) and nothing else."""
    from .path import wants_path
    argv = list(sys.argv[1:] if argv is None else argv)
    p = parser()
    args = p.parse_args([PATH, *argv] if wants_path(argv) else argv)
    if (args.command is None and args.views == "stereo") or args.eye_separation is not None:
        if args.views != "stereo":
            p.error("--eye-separation needs --views stereo")
        if not args.out:
            p.error("the following arguments are required: --out")
        from .presets import preset_from_args
        from .stereo import run_views
        run_views(args, preset_from_args(args))
    elif args.command == "cpu":
        from .cpu import run                # imports no OpenGL
        run(args)
    elif args.command == "gpu-build":
        from .gpu_build import run
        run(args)
    elif args.command == PATH:
        from .path import run
        run(args, argv)
    else:
        if not args.out:
            p.error("the following arguments are required: --out")
        from .sweep import run
        run(args, argv)


__all__ = ["main"]
