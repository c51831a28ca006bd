"""Headless capture (docs/contracts.md "Contract: capture and dump").

    python -m app.capture --scene NAME_OR_JSON --technique ID [--lights N] [--seed S]
                          [--size WxH] [--frame K] [--out image.png] [--dump frame.npz]
                          [--heatmap heat.png]

plus the chosen technique's own options (--tile, --slices, ...: an option it does not take
is an error), --classify PNG (list/tree/mixed map of a technique that has the classes
view: tree, hybrid), --check DIR (the exactness check
against the reference technique: on a difference, images in DIR, one line naming the first
differing pixel and its lights, exit status 1; a frame a --cap-policy capped: one line
"intended loss: N pixels, M lights dropped by POLICY" when it equals the reference without
those lights, exit status 3: counted, neither a pass (0) nor a failure (1)) and --list (builtin scenes and techniques).

The CPU stage is built once before the measured frame: the first call of its numba kernels
loads or compiles them, which the printed `cpu_ms` must not contain; that first build's time
is printed apart as `cpu_warmup_ms`.  The frame's GPU passes are timed once by default, and
that first dispatch of each program includes the driver's compile of it (llvmpipe compiles
at the first dispatch), so the printed `gpu_timing` says "first frame"; --repeat N times N
more samples of the frame's passes and prints their per-pass median (`gpu_ms`) and the
total's min / max (`gpu_total_ms`), as the benchmark does (docs/platform.md "Measuring": medians over
repeated frames).

The PNGs are what the window shows (app.images, one definition): --out is the displayed
image, tonemap(exposure * radiance + ambient * albedo) with the window's automatic exposure
unless --exposure X, and its faint ambient (--ambient, 0: none); --heatmap is the window's
heat view pixel for pixel (log2(1 + n) turbo, top of the scale the frame's largest count or
--heat-max N) with its colour bar.  The dump's `image` stays the linear radiance.
"""
from __future__ import annotations

import json
import sys
import time

from pathlib import Path

import numpy as np

from . import cli, fog, stereo_capture

# The output flags, each with the file it must be (None: a folder): never a silently renamed file.
OUTPUTS = (
    ("--out", ".png", "tone-mapped PNG"),
    ("--dump", ".npz", "npz dump of the contract"),
    ("--heatmap", ".png", "lights-evaluated heat map PNG (per pixel, the window's heat view, "
                          "with its colour bar)"),
    ("--classify", ".png", "list/tree/mixed classification PNG (techniques with the classes view)"),
    ("--maps", None, "heat maps of the technique's own structure (e.g. fptl's coarse and pruned "
                     "lists per tile, zbin's bit arrays), one PNG each"),
    ("--check", None, "compare with the reference technique; on a difference write images to "
                      "DIR, name the first differing pixel, exit 1 (a --cap-policy's intended loss: exit 3)"),
)


def build_parser():
    p = cli.Parser(prog="python -m app.capture", description=__doc__.splitlines()[0])
    cli.add_scene_args(p)
    p.add_argument("--technique", default="brute", help="technique id (see --list)")
    p.add_argument("--frame", type=int, default=0, help="camera path frame (of --frames)")
    p.add_argument("--frames", type=int, default=64, help="length of the camera path loop")
    for flag, suffix, text in OUTPUTS:
        p.add_argument(flag, metavar="DIR" if suffix is None else None, help=text)
    p.add_argument("--list", action="store_true", help="print builtin scenes and techniques")
    p.add_argument("--repeat", type=int, default=0, metavar="N",
                   help="time N more samples of the frame's passes after the first (whose "
                        "dispatches include the driver's compiles): gpu_ms is their median")
    cli.add_display_args(p)
    cli.add_motion_arg(p)
    cli.add_option_args(p)
    from .pipeline import transparent
    transparent.add_args(p)
    stereo_capture.add_args(p)
    fog.add_fog_args(p)
    return p


def main(argv=None) -> None:
    args = build_parser().parse_args(argv)
    from scenes import BUILTIN_SCENES, BUILTIN_VARIANTS
    from .techniques import REGISTRY, get
    if args.list:
        print("scenes:     " + " ".join(BUILTIN_SCENES))
        print("variants:   " + " ".join(BUILTIN_VARIANTS))
        print("techniques: " + " ".join(REGISTRY))
        for t in REGISTRY.values():
            role = "" if t.role == "technique" else f" [{t.role}]"
            print(f"  {t.name:10} {t.summary}{role}")
        return
    if args.frame < 0 or args.frames < 1:
        raise cli.UserError("--frame must be >= 0 and --frames >= 1")
    if args.repeat < 0:
        raise cli.UserError(f"--repeat must be >= 0, got {args.repeat}")
    check_suffixes(args)
    views_stereo = stereo_capture.wanted(args)
    technique = get(args.technique)
    if args.classify:
        from .techniques import REGISTRY
        from .views import views_of, with_view
        if "classes" not in views_of(technique):
            raise cli.UserError(f"--classify: {technique.name} has no classes view (it takes one "
                                f"path per wave); techniques with it: "
                                f"{', '.join(with_view(REGISTRY, 'classes'))}")
    opts = cli.options_for(technique, args)
    scene = cli.load_scene_args(args)
    if views_stereo:                         # two eyes (app.stereo_capture)
        return stereo_capture.capture(args, technique, opts, scene, _albedo, gpu_timing)
    from .pipeline.renderer import Renderer
    from . import images, dump
    t0 = time.perf_counter()
    renderer = Renderer(scene, args.size, transparent_layers=args.transparent_layers)
    renderer.fog_options = fog.fog_options(args, scene)
    warm = time.perf_counter()
    technique.build(renderer.frame_input(args.frame, args.frames), opts)
    warm_ms = (time.perf_counter() - warm) * 1e3
    result = renderer.render(technique, args.frame, opts, frames=args.frames,
                             samples=1 + args.repeat)
    result.meta.update(scene=args.scene, lights=len(scene.lights), seed=args.seed)
    if scene.motion is not None:             # the lights of this frame moved (scenes.motion)
        result.meta["motion"] = dict(scene.motion.to_dict(), frame=args.frame, frames=args.frames)
    covered = result.depth > 0
    exposure = (images.auto_exposure(result.image, covered) if args.exposure == "auto"
                else float(args.exposure))
    display = {"exposure": round(exposure, 6), "ambient": args.ambient}
    if args.out:
        images.save_png(result.image, images.ensure_parent(args.out), _albedo(renderer),
                        exposure, args.ambient)
    if args.heatmap:
        display["heat_max"] = images.save_heatmap(result.evaluated, images.ensure_parent(args.heatmap),
                                                  covered, args.heat_max or None)
    if args.classify:
        images.save_classification(result.wave["case_bits"], renderer.size, images.ensure_parent(args.classify),
                                   f"{technique.name}: traversal per 8x8 wave")
    if args.dump:
        dump.write_dump(images.ensure_parent(args.dump), result)
    if args.maps:
        save_maps(technique, result, renderer, args.maps)
    m = result.meta
    print(json.dumps({
        "technique": technique.name, "scene": args.scene, "size": m["resolution"],
        "visible_lights": m["stats"]["visible_lights"],
        "evaluated_per_pixel": round(float(result.evaluated[result.depth > 0].mean()) if (result.depth > 0).any() else 0.0, 3),
        "exact_per_pixel": round(float(result.contrib_count[result.depth > 0].mean()) if (result.depth > 0).any() else 0.0, 3),
        "cpu_ms": {k: round(v, 2) for k, v in m["cpu_ms"].items()}, "cpu_threads": m["cpu_threads"],
        **gpu_timing(m, args.repeat),
        **transparent_summary(result),
        "cpu_warmup_ms": round(warm_ms, 2), "display": display,
        **({"fog": m["fog"]["mismatch"]} if "fog" in m else {}),
        "wall_s": round(time.perf_counter() - t0, 2)}))
    if args.check:
        check_against_reference(renderer, technique, opts, result, args)


def transparent_summary(result) -> dict:
    """The printed line's transparent layers (a scene with transparent surfaces; else {}):
    layers used of L, fragments per layer, exact lights per fragment."""
    t = result.meta.get("transparent")
    if t is None:
        return {}
    covered = result.depth_t > 0
    exact = float(result.contrib_count_t[covered].mean()) if covered.any() else 0.0
    return {"transparent": {"layers": t["layers"], "max_layers": t["max_layers"],
                            "fragments": t["fragments"], "exact_per_fragment": round(exact, 3)}}


def gpu_timing(meta: dict, repeat: int) -> dict:
    """The printed GPU figures: the first frame's passes, or the median of the `repeat`
    samples after it per pass and their total's min / max."""
    if repeat == 0:
        return {"gpu_ms": {k: round(v, 2) for k, v in meta["gpu_ms"].items()},
                "gpu_timing": "first frame (its dispatches include the driver's compiles; "
                              "--repeat N for a median)"}
    timed = [s["gpu_ms"] for s in meta["samples"][1:]]
    totals = [sum(t.values()) for t in timed]
    return {"gpu_ms": {k: round(float(np.median([t[k] for t in timed])), 2) for k in timed[0]},
            "gpu_timing": f"median of {repeat} samples after the first frame",
            "gpu_total_ms": {"min": round(min(totals), 2), "max": round(max(totals), 2)}}


def _albedo(renderer):
    """The G-buffer's albedo, (H, W, 3) float in [0, 1], row 0 = top (the ambient term)."""
    import numpy as np
    w, h = renderer.size
    raw = np.frombuffer(renderer.gbuffer.albedo.read(), np.uint8).reshape(h, w, 4)
    return raw[::-1, :, :3].astype(np.float32) / 255.0


def save_maps(technique, result, renderer, out) -> None:
    """One heat map per map of the technique's own structure, each cell shown over the
    pixels it covers (the same heat-map definition as --heatmap), all on one scale so that
    the maps compare (fptl's coarse against its pruned lists)."""
    from . import images
    maps = technique.maps(result, renderer.read)
    if not maps:
        print(f"{technique.name} has no maps of its own (--maps)", file=sys.stderr)
    h, w = result.depth.shape
    top = images.maps_top(maps)
    for name, (values, label) in maps.items():
        images.save_heatmap(images.cells_to_pixels(values, (w, h)),
                            images.ensure_parent(Path(out) / f"{technique.name}-{name}.png"),
                            vmax=top, label=label)


def check_suffixes(args) -> None:
    """Output files are what their flag says: never a silently renamed file."""
    for flag, suffix, _ in OUTPUTS:
        path = getattr(args, flag[2:])
        if path and suffix is not None and Path(path).suffix.lower() != suffix:
            raise cli.UserError(f"{flag} {path}: the file must end in {suffix}")


INTENDED_LOSS_EXIT = 3       # a script reading 0 as "exact" is never told a capped frame is


def check_against_reference(renderer, technique, opts, result, args) -> None:
    from .exactness import IntendedLoss, check
    from .techniques import with_role
    ref_t = with_role("reference")
    own = renderer.fog_options                   # a fog scene: the reference on the frame's froxels
    renderer.fog_options = fog.reference_options(result, own)
    ref = result if technique is ref_t else renderer.render(ref_t, args.frame, frames=args.frames)
    renderer.fog_options = own
    m = check(result, ref, renderer, technique, ref_t,
              {"frame": args.frame, "frames": args.frames, "opts": opts}, args.check)
    if isinstance(m, IntendedLoss):       # a cap policy's loss: counted, neither pass nor failure
        print(m.message(), file=sys.stderr)
        raise SystemExit(INTENDED_LOSS_EXIT)
    if m is not None:
        print(f"not exact: {m.message()}", file=sys.stderr)
        raise SystemExit(1)
    froxels = fog.check_froxels(result, ref)     # a fog scene: the froxels' light sets too
    if froxels is not None:
        print(f"not exact: {froxels}", file=sys.stderr)
        raise SystemExit(1)
    if technique.role == "sampler":       # its support is exact; its estimate, unbiased?
        from . import sampling_check
        verdict = sampling_check.check(renderer, technique, opts, ref, args.frame, args.frames)
        if not verdict.passed:
            print(f"not unbiased: {verdict.message()}", file=sys.stderr)
            raise SystemExit(1)
        print(f"exact support: every light affecting a pixel in {ref_t.name} can be drawn "
              f"there; {verdict.message()}", file=sys.stderr)
        return
    print(f"exact: {technique.name} equals {ref_t.name} at every pixel"
          + (" and every froxel" if result.froxel_count is not None else ""), file=sys.stderr)


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
