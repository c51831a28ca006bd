"""The perfect culler: the physical limit on every cost plot of the benchmark.

Outside the timed region it builds, for every pixel, the exact list of the lights that affect
it; then it times the same shading loop every technique runs (evaluate_light) over exactly
those lists.  Its shading time is the floor no culling structure can beat with this shading
loop, and its culling waste (evaluated / contrib_count) is exactly 1.0.

    untimed:  perfect_count.comp  G-buffer x lights[] -> perfect_counts[pixel]
              CPU prefix sum      -> perfect_ranges[pixel] = (first entry, count), per band
              perfect_fill.comp   -> perfect_entries[] (light indices, depth order)
    timed:    shade_perfect.comp  perfect_ranges -> perfect_entries -> lights[]

Both set-up passes decide "affects" with evaluate_light itself, so the lists are exact by
construction (the same float32 function on the same inputs).  The image is cut into bands of
whole 8x8 groups when the entries of the whole image would not fit one storage block (e.g.
65,536 lights at 1920x1080: ~50 lights a pixel = 400 MiB); the shading time is then the sum
of the bands' dispatches.

It is not a technique of the registry (it needs the G-buffer before its "CPU stage" and its
structure is never shippable); app.bench runs it beside them.  It drives the Renderer's
G-buffer, program cache, timer and named buffers, and its buffers are the renderer's named ones (bindings in app.features).
"""
from __future__ import annotations

import hashlib
import math
import time

import numpy as np

from . import features as feat
from .errors import UserError
from .techniques import Options
from .techniques.base import prepare

NAME = "perfect"


class PerfectCuller:
    name = NAME
    summary = "exact per-pixel light lists built untimed (the shading floor)"
    shader = "shade_perfect.comp"

    def __init__(self, renderer, max_band_bytes: int | None = None):
        self.r = renderer
        self.max_band_bytes = int(max_band_bytes or renderer.limits.max_storage_block)
        self.last_setup_ms: dict[str, float] = {}
        self._lists_key = None      # the frame whose lists the buffers hold (one band only)

    def _buffer(self, name: str, nbytes: int):
        """One of the renderer's named buffers, bound at its point of features.BINDINGS."""
        buf = self.r.buffer(name, nbytes)
        buf.bind_to_storage_buffer(feat.BINDINGS[name])
        return buf

    def bands(self, counts: np.ndarray) -> list[tuple[int, int, int]]:
        """(first row, end row, entries) of each band, GL row order; rows in whole groups of
        8 so that a band's dispatch lines up with the 8x8 waves."""
        h = counts.shape[0]
        per_group_row = [int(counts[y:y + 8].sum()) for y in range(0, h, 8)]
        cap = self.max_band_bytes // 4
        out, start, total = [], 0, 0
        for g, n in enumerate(per_group_row):
            if n > cap:
                raise UserError(f"perfect culler: 8 image rows need {n * 4 / 2**20:.2f} MiB of light "
                                f"indices, over the {self.max_band_bytes / 2**20:.2f} MiB limit of "
                                f"a storage block")
            if total + n > cap:
                out.append((start * 8, g * 8, total))
                start, total = g, 0
            total += n
        out.append((start * 8, h, total))
        return out

    def render(self, frame: int = 0, opts: Options | None = None, frames: int = 64,
               lights: np.ndarray | None = None, readback: bool = True, camera=None,
               extra_defines: dict | None = None):
        """One frame, as Renderer.render: a FrameResult (or None, figures in last_meta) whose
        gpu_ms holds gbuffer and shade only; the untimed set-up is in meta['setup_ms']."""
        r = self.r
        opts = opts or Options()
        fin = r.frame_input(frame, frames, lights, camera)
        cam = fin.camera
        w, h = r.size

        r.timer.run("gbuffer", lambda: r.gbuffer.draw(cam))
        build = prepare(fin, opts)   # cull, sort, pack: timed
        t0 = time.perf_counter()
        r.upload("lights", build.buffers["lights"])
        upload_ms = (time.perf_counter() - t0) * 1e3
        gpu_ms = r.timer.take()

        features = feat.feature_set(build.lights.gpu["id_type"][:, 1])   # GPU layout: y = type
        virtual = feat.virtual_files(features)
        defines = dict(LIGHTS_DUPLICATED=0, WAVE_NATIVE=0, **(extra_defines or {}))
        n_lights = len(build.lights.gpu)
        r.gbuffer.bind()
        groups_x = math.ceil(w / 8)
        r.buffer("out_color", w * h * 16)
        r.buffer("out_stats", w * h * 16)
        r.buffer("wave_stats", groups_x * math.ceil(h / 8) * 16).clear()   # atomics accumulate
        r.bind(("lights", "out_color", "out_stats", "wave_stats"))

        def program(name):
            prog = self.r.programs.compute(name, defines, virtual)
            for k, v in dict(u_size=(w, h), u_light_count=n_lights, u_row0=0).items():
                if k in prog:
                    prog[k].value = v
            return prog

        # ---- untimed set-up: count, prefix sum, fill (per band) --------------------------
        # A repeat of the same frame (same G-buffer camera, lights, defines) whose lists fit
        # one band reuses them: the set-up costs about two brute-force passes.
        key = hashlib.sha1(b"".join([
            np.ascontiguousarray(build.buffers["lights"]).tobytes(),
            np.asarray(cam.view_from_world, np.float64).tobytes(),
            np.asarray(cam.clip_from_view, np.float64).tobytes(),
            repr((w, h, self.max_band_bytes, sorted(defines.items()),
                  sorted(virtual.items()))).encode()])).hexdigest()
        setup = {}
        fill, shade = program("perfect_fill.comp"), program(self.shader)
        if key == self._lists_key:
            bands, reuse = self._lists_bands, True
        else:
            self._lists_key, reuse = None, False
            t0 = time.perf_counter()
            counts_buf = self._buffer("perfect_counts", w * h * 4)
            program("perfect_count.comp").run(groups_x, math.ceil(h / 8), 1)
            counts = np.frombuffer(counts_buf.read(size=w * h * 4), np.uint32).reshape(h, w)
            setup["count"] = (time.perf_counter() - t0) * 1e3
            bands = self.bands(counts)
        fill_ms = 0.0
        entries_total = 0
        for y0, y1, n in bands:
            t0 = time.perf_counter()
            band_groups = (groups_x, math.ceil((y1 - y0) / 8), 1)
            for p in (fill, shade):
                if "u_row0" in p:
                    p["u_row0"].value = y0
            entries_total += n
            if reuse:
                r.bind(("perfect_ranges", "perfect_entries"))
                r.timer.run("shade", lambda: shade.run(*band_groups))
                continue
            c = counts[y0:y1].ravel().astype(np.uint64)
            ranges = np.zeros((len(c), 2), np.uint32)
            ranges[1:, 0] = np.cumsum(c)[:-1]
            ranges[:, 1] = c
            self._buffer("perfect_ranges", ranges.nbytes).write(ranges.tobytes())
            self._buffer("perfect_entries", n * 4)
            fill.run(*band_groups)
            r.ctx.finish()
            fill_ms += (time.perf_counter() - t0) * 1e3
            r.timer.run("shade", lambda: shade.run(*band_groups))   # the timed region
        if not reuse:
            setup["fill"] = fill_ms
            if len(bands) == 1:
                self._lists_key, self._lists_bands = key, bands
        self.last_setup_ms = setup
        gpu_ms.update(r.timer.take())

        meta = {
            "technique": NAME, "options": opts.as_dict(), "features": list(features),
            "wave": "emulated-64", "cpu_ms": dict(build.times.ms, upload=upload_ms),
            "gpu_ms": gpu_ms, "setup_ms": setup,
            "bytes": {"lights": int(build.buffers["lights"].nbytes),
                      "perfect_ranges": int(w * h * 8), "perfect_entries": int(entries_total * 4)},
            "stats": dict(build.stats, bands=len(bands), list_entries=entries_total,
                          lists_reused=reuse),
            "resolution": [w, h], "frame": frame, "renderer": r.limits.renderer,
        }
        r.last_meta = meta
        if not readback:
            return None
        return r.read_outputs(meta, (groups_x, math.ceil(h / 8)))

    def release(self) -> None:
        """Nothing of its own: its buffers are the renderer's, released with it."""
