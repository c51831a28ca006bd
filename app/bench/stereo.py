"""Two eyes, two ways (app.stereo): `DIR/stereo.csv`.

On frame 0 of each scene, every technique of role "technique" renders both eyes (the
centre camera +-sep/2 along its right vector) in each way:

    per-view   its structure built once per eye
    union      one CPU stage over the union camera's frustum (its declaration says what it
               shares: the structure itself, or the cull and sort alone; app.stereo)

A configuration is rendered once untimed (its compiles; its per-pixel counters held to
brute rendered per eye) and then `repeat` timing samples, each the two eyes' frame: the
shared stage's ms (union) plus each eye's CPU stage, and each eye's timed GPU passes
(measure.timing_cells over those samples: medians with min / max).  A row a configuration:

    entries          structure list entries of the two-eye frame (the shared structure's
                     once; each eye's summed); blank where the structure has no lists
    bytes            culling bytes the timed passes bind, both eyes (shared buffers once)
    cpu_total_ms     CPU stage of both eyes and the shared stage (+ _min / _max); each eye's
                     upload holds the whole build (a shared structure uploaded once an eye)
    gpu_lighting_ms  both eyes' timed passes but the G-buffer (+ _min / _max)
    frame_cost_ms    their sum (+ _min / _max)
    mismatch_count / mismatch_hash   pixels of both eyes whose contrib_count / contrib_hash
                     differ from brute's in that eye: 0
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import sys

from . import measure
from .study import FileStudy, series_files, study_scene, write_series

CSV = "stereo.csv"             # read by app.report.stereo (not imported from there: GL)

COLUMNS = ["study", "scene", "lights", "visible", "width", "height", "frame", "separation",
           "technique", "way", "share", "entries", "bytes", "cpu_total_ms", "cpu_total_min_ms",
           "cpu_total_max_ms", "gpu_lighting_ms", "gpu_lighting_min_ms", "gpu_lighting_max_ms",
           "frame_cost_ms", "frame_cost_min_ms", "frame_cost_max_ms", "samples",
           "mismatch_count", "mismatch_hash"]


@dataclass(frozen=True)
class StereoConfig:
    """The study's settings: frame 0 of each of `scenes` (() none) at `lights` lights and
    `size` an eye, eyes `separation` metres apart, `repeat` timing samples a configuration."""
    scenes: tuple[str, ...]
    lights: int
    size: tuple[int, int]
    separation: float
    repeat: int
    seed: int = 0


def techniques() -> list:
    """The techniques of role "technique", in the registry's order."""
    from ..techniques import REGISTRY
    return [t for t in REGISTRY.values() if t.role == "technique"]


def run_scene(renderer, c: StereoConfig, log=None) -> list[dict]:
    """The rows of one scene's frame 0 (its renderer)."""
    from .. import stereo
    log = log or sys.stderr
    ref = stereo.reference(renderer, c.separation)
    rows = []
    for t in techniques():
        for way in stereo.WAYS:
            if stereo.refusal(t, t.Options(), way):
                continue
            first = stereo.render(renderer, t, None, way, c.separation)      # compiles, checked
            bad = stereo.mismatches(first, ref)
            timed = stereo.render(renderer, t, None, way, c.separation, samples=c.repeat,
                                  readback=False)
            row = dict(study="stereo", width=renderer.size[0], height=renderer.size[1], frame=0,
                       separation=c.separation, technique=t.name, way=way,
                       share=timed.share or "", entries=timed.entries(), bytes=timed.bytes(),
                       visible=max(r.meta["stats"]["visible_lights"] for r in timed.results.values()),
                       mismatch_count=sum(b[0] for b in bad.values()),
                       mismatch_hash=sum(b[1] for b in bad.values()))
            cells = measure.timing_cells(timed.samples())
            row.update({k: cells[k] for k in COLUMNS if k in cells})
            rows.append(row)
            log.write(f"bench: stereo {t.name} {way}: cpu {row['cpu_total_ms']:.2f} ms, gpu "
                      f"{row['gpu_lighting_ms']:.2f} ms, entries {row['entries']}\n")
    return rows


def stereo_series(c: StereoConfig, out: Path, log=None) -> list[dict]:
    """The study of `c` into out/stereo.csv; none without scenes (a stale file removed)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..pipeline.renderer import Renderer
    files = series_files(out, (CSV,), bool(c.scenes) and c.repeat >= 1)
    if files is None:
        return []
    path, = files
    rows: list[dict] = []
    for name in c.scenes:
        scene = study_scene(name, c.lights, c.seed)
        with Renderer(scene, tuple(c.size)) as r:
            got = run_scene(r, c, log)
        for row in got:
            row.update(scene=name, lights=len(scene.lights))
        rows += got
    write_series(rows, path, COLUMNS, log)
    return rows


def add_view_args(p) -> None:
    """The sweep command's two-eye flags: `--views stereo` runs this study alone."""
    from ..stereo import VIEWS
    p.add_argument("--views", choices=VIEWS, default="mono",
                   help="stereo: the two-eye study alone (every culling technique, a structure "
                        "per eye and one over both frusta) at the preset's stereo settings, "
                        "which --size (an eye), --scenes, --lights (the smallest) and --repeat "
                        "override: DIR/stereo.csv and DIR/stereo.md")
    p.add_argument("--eye-separation", type=float, default=None, metavar="M",
                   help="with --views stereo: metres between the eyes (default the preset's)")


def run_views(args, preset) -> None:
    """`bench --views stereo --out DIR`: the preset's stereo study alone, DIR/stereo.csv and
    DIR/stereo.md (the report's section), the table printed."""
    from dataclasses import replace
    from ..errors import UserError
    from ..report.stereo import stereo_section
    from ..results import read_csv
    from ..stereo import check_separation
    c = preset.config("stereo")
    if args.eye_separation is not None:
        c = replace(c, separation=check_separation(args.eye_separation))
    if not c.scenes:
        raise UserError(f"--views stereo: the {preset.name} preset has no stereo study")
    out = Path(args.out)
    stereo_series(replace(c, repeat=max(1, c.repeat)), out)
    _, text, tables = stereo_section(read_csv(out / CSV))
    md = "# Two eyes\n\n" + "\n\n".join(text) + "\n\n" + tables + "\n"
    (out / "stereo.md").write_text(md)
    print(tables)
    print(f"bench: wrote {out / 'stereo.md'}", file=sys.stderr)


class StereoStudy(FileStudy):
    """out/stereo.csv (the report's stereo section reads it), none of results.csv's rows."""
    name = "stereo"
    files = (CSV,)
    sections = ("stereo",)
    Config = StereoConfig
    series = staticmethod(stereo_series)


__all__ = ["add_view_args", "run_views", "StereoConfig", "StereoStudy", "stereo_series", "run_scene", "COLUMNS", "CSV"]
