"""The sweep's CPU-only series (tree paper figure 4): technique.build alone at cpu_size for
every technique over the CPU light counts, and every option study's values at that size
where it is not the rendered one (cpu_<option>, never summed with GPU times of the rendered
resolution); the upload timed into GL buffers of the process's context, as the renderer
does.  Rows of results.csv (studies "cpu", "cpu_<option>"; the report's CPU page)."""
from __future__ import annotations

from dataclasses import dataclass
import time

import numpy as np

from ..results import CPU_PREFIX, STAGES, option_studies, stats
from ..techniques import REGISTRY
from . import measure
from .cpu import cpu_stage_samples
from .plan import study_scene
from .study import Shared, Study


@dataclass(frozen=True)
class CpuConfig:
    """The series in `scene` at `size` over `lights`, `repeat` builds each; the option
    studies' scenes and counts are the rendered ones (shared)."""
    shared: Shared
    scene: str
    lights: tuple[int, ...]
    size: tuple[int, int]         # the paper's resolution even in --quick
    repeat: int


class CpuStudy(Study):
    name = "cpu"
    sections = ("cpu",)
    Config = CpuConfig

    def jobs(self, sweep) -> list[tuple[str, str, int, str, object]]:
        """(study, scene, lights, technique, options) of the series (module docstring)."""
        c, p = self.config, self.config.shared
        out = [("cpu", c.scene, n, t, REGISTRY[t].Options())
               for n in sweep.light_counts(c.scene, c.lights) for t in REGISTRY]
        if tuple(c.size) != tuple(p.size) and p.study_scene in p.scenes and p.option_studies:
            for study, (spec, techs) in option_studies().items():
                scene = study_scene(p, spec)
                n = sweep.light_counts(scene, (p.study_lights,))[0]
                out += [(CPU_PREFIX + study, scene, n, t, REGISTRY[t].Options().with_(**{study: v}))
                        for v in spec.study for t in techs]
        return out

    def run(self, out, sweep) -> list[dict]:
        from ..pipeline import gl
        c = self.config
        ctx = gl.context()
        scratch: dict[str, object] = {}

        def upload(b) -> float:
            t0 = time.perf_counter()
            for k, a in b.buffers.items():
                buf = scratch.get(k)
                if buf is None or buf.size < a.nbytes:
                    if buf is not None:
                        buf.release()
                    buf = scratch[k] = ctx.buffer(reserve=max(a.nbytes, 16))
                if a.nbytes:
                    buf.write(np.ascontiguousarray(a).tobytes())
            ctx.finish()
            return (time.perf_counter() - t0) * 1e3

        series = self.jobs(sweep)
        rows = []
        try:
            for i, (study, scene, n, name, opts) in enumerate(series, 1):
                tech = REGISTRY[name]
                sc = sweep.scene(scene, n)
                what = "" if study == "cpu" else f" {study[len(CPU_PREFIX):]}=" \
                                                 f"{getattr(opts, study[len(CPU_PREFIX):])}"
                sweep.progress(i, len(series), f"{study} {scene} {n} lights {name}{what} "
                                               f"at {c.size[0]}x{c.size[1]}")
                s = cpu_stage_samples(tech, sc, c.size, opts, c.repeat, 0, c.shared.frames,
                                      upload=upload)
                r = {"study": study, "scene": scene, "lights": n, "visible": s["visible"],
                     "width": c.size[0], "height": c.size[1], "frame": 0,
                     "frames": c.shared.frames, "technique": name, "role": tech.role,
                     "cutoff": 0, "samples": c.repeat}
                r.update(measure.option_cells(opts))
                for k in STAGES:
                    r[f"cpu_{k}_ms"] = stats(s[k])[0]
                r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = stats(s["total"])
                rows.append(r)
        finally:
            for b in scratch.values():
                b.release()
        return rows


__all__ = ["CpuConfig", "CpuStudy"]
