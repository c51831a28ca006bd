"""capture's `--views stereo` (app.stereo): both eyes of the frame, each written as capture
writes one frame, the file names suffixed by the eye.

    --views mono|stereo        mono (default): one frame, as always
    --eye-separation M         metres between the eyes (default 0.064)
    --stereo-way per-view|union   the technique's structure built per eye, or once over the
                               union of the two frusta (app.stereo; default per-view)

--out f.png writes f-left.png and f-right.png; --dump d.npz d-left.npz and d-right.npz, whose
meta adds eye, way, separation (and, in the union way, share and shared_cpu_ms); --heatmap
likewise; --check DIR holds each eye to the reference rendered for that eye (its images in
DIR/left, DIR/right; a sampler's support, then its estimate over seeds as mono's --check),
exit 1 when an eye differs, after both are checked.
"""
from __future__ import annotations

import json
from pathlib import Path
import sys
import time

from . import cli, stereo
from .errors import UserError

# capture's flags that stereo does not take (each is about one view's own figures)
MONO_ONLY = (("classify", "--classify"), ("maps", "--maps"))


def add_args(p) -> None:
    g = p.add_argument_group("views (app.stereo)")
    g.add_argument("--views", choices=stereo.VIEWS, default="mono",
                   help="mono: one frame (default); stereo: two eyes, each written with -left / "
                        "-right before the file's suffix")
    g.add_argument("--eye-separation", type=float, default=None, metavar="M",
                   help=f"--views stereo: metres between the eyes (default {stereo.DEFAULT_SEPARATION})")
    g.add_argument("--stereo-way", choices=stereo.WAYS, default=None,
                   help="--views stereo: per-view (the structure built per eye, default) or union "
                        "(one CPU stage over both frusta: the technique's structure where it is a "
                        "view-space grid, else its cull and sort; docs/usage.md)")


def wanted(args) -> bool:
    """Whether the command line asks for stereo; a stereo flag without it is an error."""
    if args.views == "stereo":
        return True
    for flag, value in (("--eye-separation", args.eye_separation), ("--stereo-way", args.stereo_way)):
        if value is not None:
            raise UserError(f"{flag} needs --views stereo")
    return False


def eye_path(path: str, eye: str) -> Path:
    p = Path(path)
    return p.with_name(f"{p.stem}-{eye}{p.suffix}")


def capture(args, technique, opts, scene, _albedo, gpu_timing) -> None:
    """Both eyes of args.frame (capture.main's stereo branch, which hands over its helpers:
    the G-buffer's albedo of the renderer, the printed GPU figures of a meta)."""
    for name, flag in MONO_ONLY:
        if getattr(args, name):
            raise UserError(f"{flag} is a mono figure: not with --views stereo")
    way = args.stereo_way or "per-view"
    sep = stereo.check_separation(stereo.DEFAULT_SEPARATION if args.eye_separation is None
                                  else args.eye_separation)
    stereo.refuse(technique, opts, way)
    if scene.fog is not None and way == "union":
        raise UserError("--stereo-way union: a fog scene's froxels take their candidates from "
                        "cells in the eye's own camera, which the union's shared structure does "
                        "not index; --stereo-way per-view renders it")
    from .pipeline.renderer import Renderer
    from . import dump, fog, images
    t0 = time.perf_counter()
    renderer = Renderer(scene, args.size, transparent_layers=args.transparent_layers)
    renderer.fog_options = fog.fog_options(args, scene)
    warm = time.perf_counter()               # as mono's: the numba kernels' first call apart
    technique.build(renderer.frame_input(args.frame, args.frames), opts)
    warm_ms = (time.perf_counter() - warm) * 1e3
    albedo = {}          # each eye's G-buffer albedo, read while the renderer holds it
    sf = stereo.render(renderer, technique, opts, way, sep, args.frame, args.frames,
                       samples=1 + args.repeat,
                       on_eye=lambda e, r: albedo.update({e: _albedo(renderer)}) if args.out else None)
    eyes = {}
    for eye, result in sf.results.items():
        result.meta.update(scene=args.scene, lights=len(scene.lights), seed=args.seed)
        if scene.motion is not None:
            result.meta["motion"] = dict(scene.motion.to_dict(), frame=args.frame, frames=args.frames)
        covered = result.depth > 0
        exposure = (images.auto_exposure(result.image, covered) if args.exposure == "auto"
                    else float(args.exposure))
        display = {"exposure": round(exposure, 6), "ambient": args.ambient}
        if args.out:
            images.save_png(result.image, images.ensure_parent(eye_path(args.out, eye)),
                            albedo[eye], exposure, args.ambient)
        if args.heatmap:
            display["heat_max"] = images.save_heatmap(
                result.evaluated, images.ensure_parent(eye_path(args.heatmap, eye)), covered,
                args.heat_max or None)
        if args.dump:
            dump.write_dump(images.ensure_parent(eye_path(args.dump, eye)), result)
        m = result.meta
        eyes[eye] = {
            "visible_lights": m["stats"]["visible_lights"],
            "evaluated_per_pixel": round(float(result.evaluated[covered].mean()) if covered.any() else 0.0, 3),
            "exact_per_pixel": round(float(result.contrib_count[covered].mean()) if covered.any() else 0.0, 3),
            "cpu_ms": {k: round(v, 2) for k, v in m["cpu_ms"].items()},
            **gpu_timing(m, args.repeat), "display": display}
    line = {"technique": technique.name, "scene": args.scene, "views": "stereo", "way": way,
            "separation": sep, "size": list(renderer.size), "eyes": eyes}
    if way == "union":
        line.update(share=sf.share, shared_cpu_ms={k: round(v, 2) for k, v in sf.shared_ms[-1].items()})
    line["cpu_warmup_ms"] = round(warm_ms, 2)
    line["wall_s"] = round(time.perf_counter() - t0, 2)
    print(json.dumps(line))
    if args.check:
        check_eyes(renderer, technique, opts, sf, args)


def with_role_reference():
    from .techniques import with_role
    return with_role("reference")


class _EyeRenderer:
    """The renderer as one eye's frames see it: every render() with that eye's camera (and
    the union way's defines), for the sampler's statistical check (app.sampling_check)."""

    def __init__(self, renderer, kw: dict):
        self.renderer, self.kw = renderer, kw

    def render(self, technique, *a, **k):
        return self.renderer.render(technique, *a, **dict(k, **self.kw))


def check_eyes(renderer, technique, opts, sf, args) -> None:
    """Each eye against the reference rendered for that eye; one line an eye, exit 1 when
    one differs.  A sampler: its support pixel by pixel, then its estimate statistically
    against that eye's reference (app.sampling_check), as mono's --check."""
    from .exactness import check
    from . import fog, sampling_check
    ref_t = with_role_reference()
    failed = False
    own = renderer.fog_options
    for eye, result in sf.results.items():
        t, kw = sf.renders[eye]
        # the reference per eye: the frame itself only when it is that (brute, per view); a
        # fog scene's on that eye's own froxels
        renderer.fog_options = fog.reference_options(result, own)
        ref = result if technique is ref_t and sf.way == "per-view" else \
            renderer.render(ref_t, args.frame, frames=args.frames, camera=kw["camera"])
        renderer.fog_options = own
        m = check(result, ref, renderer, t, ref_t,
                  dict(kw, frame=args.frame, frames=args.frames, opts=opts),
                  str(Path(args.check) / eye))
        froxels = None if m is not None else fog.check_froxels(result, ref)
        if m is not None or froxels is not None:
            failed = True
            print(f"not exact: {eye} eye ({sf.way}): {m.message() if m else froxels}",
                  file=sys.stderr)
        elif technique.role == "sampler":
            verdict = sampling_check.check(_EyeRenderer(renderer, kw), t, opts, ref, args.frame,
                                           args.frames)
            failed |= not verdict.passed
            print(f"{'exact support' if verdict.passed else 'not unbiased'}: {eye} eye "
                  f"({sf.way}): {verdict.message()}", file=sys.stderr)
        else:
            print(f"exact: {eye} eye ({sf.way}): {technique.name}'s equals {ref_t.name} "
                  f"at every pixel" + (" and every froxel" if result.froxel_count is not None
                                       else ""), file=sys.stderr)
    if failed:
        raise SystemExit(1)
