"""One frame of the pipeline, headless or in a window (the renderer draws to no window):

    G-buffer raster -> technique.build (CPU stage) -> upload -> prepasses -> shade -> read back

Buffers are bound by name (app.features.BINDINGS).  Storage buffers are reused between
frames and grown only when a frame needs more, so long runs allocate nothing per frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
import time

import numpy as np

from cpu_prep.arena import Arena
from cpu_prep.camera import frame_camera
from cpu_prep.limits import LimitError
from . import features as feat, gl
from .errors import UserError
from .gbuffer import GBuffer
from .shaders import ProgramCache
from .techniques import FrameInput, Options, Technique


@dataclass
class FrameResult:
    """Per-pixel outputs in image order (row 0 = top), plus figures for the meta."""
    image: np.ndarray           # (H,W,3) float32 linear radiance
    depth: np.ndarray           # (H,W) float32 linear view depth, 0 = no geometry
    evaluated: np.ndarray       # (H,W) uint32
    contrib_count: np.ndarray   # (H,W) uint32
    contrib_hash: np.ndarray    # (H,W) uint32
    nodes: np.ndarray           # (H,W) uint32 tree nodes visited
    wave: np.ndarray            # (GH,GW,4) uint32 per 8x8 group: longest loop, case bits
    meta: dict = field(default_factory=dict)


class Renderer:
    def __init__(self, scene, size: tuple[int, int] | None = None):
        self.ctx = gl.context()
        self.limits = gl.limits()
        self.scene = scene
        self.programs = ProgramCache(self.ctx)
        self.timer = gl.PassTimer(self.ctx)
        size = tuple(size or scene.resolution)
        self._check_size(size)
        self.gbuffer = GBuffer(self.ctx, self.programs, scene.meshes, size)
        self.buffers: dict[str, object] = {}
        self.last_meta: dict | None = None
        self.arena = Arena()     # CPU-stage outputs, reused frame to frame (uploaded at once)

    @property
    def size(self) -> tuple[int, int]:
        return self.gbuffer.size

    def _check_size(self, size) -> None:
        w, h = size
        m = self.limits.max_texture_size
        if not (1 <= w <= m and 1 <= h <= m):
            raise UserError(f"resolution {w}x{h} is outside 1..{m} (GL_MAX_TEXTURE_SIZE)")
        if w * h * 16 > self.limits.max_storage_block:
            raise UserError(f"resolution {w}x{h} needs {w * h * 16 >> 20} MiB output buffers, over "
                            f"the {self.limits.max_storage_block >> 20} MiB storage-block limit")

    def resize(self, size) -> None:
        self._check_size(size)
        self.gbuffer.resize(tuple(size))

    # ---- buffers -------------------------------------------------------------------

    def buffer(self, name: str, nbytes: int):
        """The named storage buffer, at least nbytes (>= 16), reused across frames."""
        nbytes = max(int(nbytes), 16)
        if nbytes > self.limits.max_storage_block:
            raise UserError(f"buffer '{name}' needs {nbytes / 2**20:.1f} MiB, over the "
                            f"{self.limits.max_storage_block >> 20} MiB storage-block limit")
        buf = self.buffers.get(name)
        if buf is None or buf.size < nbytes:
            if buf is not None:
                buf.release()
            buf = self.ctx.buffer(reserve=max(nbytes, 1 << (nbytes - 1).bit_length()) if nbytes > 4096 else nbytes)
            self.buffers[name] = buf
        return buf

    def upload(self, name: str, array: np.ndarray):
        buf = self.buffer(name, array.nbytes)
        if array.nbytes:
            buf.write(np.ascontiguousarray(array).tobytes())
        return buf

    def bind(self, names) -> None:
        for n in names:
            if n in self.buffers:
                self.buffers[n].bind_to_storage_buffer(feat.BINDINGS[n])

    # ---- the frame -----------------------------------------------------------------

    def camera(self, frame: int, frames: int):
        w, h = self.size
        return frame_camera(self.scene.camera_at(frame, frames), w, h)

    def frame_input(self, frame: int, frames: int, lights=None, camera=None) -> FrameInput:
        """The CPU stage's input for a frame: the scene's lights (or `lights`), the path
        camera of `frame` (or `camera`), the scene's max depth, this renderer's arena."""
        cam = camera or self.camera(frame, frames)
        lights = self.scene.lights if lights is None else lights
        return FrameInput(lights, cam, self.scene.max_depth or cam.far, self.arena)

    def render(self, technique: Technique, frame: int = 0, opts: Options | None = None,
               frames: int = 64, lights: np.ndarray | None = None, readback: bool = True,
               camera=None, extra_defines: dict | None = None) -> FrameResult | None:
        """Render one frame.  readback=False leaves the outputs on the GPU (buffers
        out_color, out_stats, wave_stats) and the figures in self.last_meta.
        extra_defines reach the shading program (e.g. UNBOUNDED_FALLOFF=1)."""
        opts = opts or Options()
        fin = self.frame_input(frame, frames, lights, camera)
        w, h = self.size

        self.timer.run("gbuffer", lambda: self.gbuffer.draw(fin.camera))
        try:
            build = technique.build(fin, opts)
        except LimitError as exc:
            raise UserError(str(exc)) from None
        features = feat.feature_set(build.lights.type)

        t0 = time.perf_counter()
        for name, array in build.buffers.items():
            self.upload(name, array)
        upload_ms = (time.perf_counter() - t0) * 1e3

        uniforms = dict(build.uniforms, u_size=(w, h), u_light_count=len(build.lights.gpu))
        virtual = feat.virtual_files(features)
        native = opts.native_wave and self.limits.native_ballot
        self.gbuffer.bind()
        culling_bytes = {k: int(v.nbytes) for k, v in build.buffers.items()}
        for p in technique.prepasses:
            outputs = p.outputs(build)
            culling_bytes.update(outputs)
            for name, nbytes in outputs.items():
                buf = self.buffer(name, nbytes)
                if name in p.zeroed:
                    buf.clear()
            prog = self.programs.compute(p.shader, {}, virtual)
            self._set_uniforms(prog, uniforms)
            self.bind(list(build.buffers) + list(outputs))
            self.timer.run(p.name, lambda: prog.run(*p.groups(build)))
            self.ctx.memory_barrier()   # the next pass reads what this one wrote

        groups = (math.ceil(w / 8), math.ceil(h / 8))
        self.buffer("out_color", w * h * 16)
        self.buffer("out_stats", w * h * 16)
        self.buffer("wave_stats", groups[0] * groups[1] * 16).clear()   # atomics accumulate
        defines = dict(build.defines, WAVE_NATIVE=int(native), **(extra_defines or {}))
        ext = gl.NATIVE_WAVE_EXTENSIONS if native else ()
        prog = self.programs.compute(technique.shader, defines, virtual, ext)
        self._set_uniforms(prog, uniforms)
        self.bind(self.buffers)
        self.timer.run("shade", lambda: prog.run(*groups, 1))
        self.ctx.memory_barrier()
        gpu_ms = self.timer.take()

        meta = {
            "technique": technique.name, "options": opts.as_dict(), "features": list(features),
            "wave": "native" if native else "emulated-64",
            "cpu_ms": dict(build.times.ms, upload=upload_ms), "gpu_ms": gpu_ms,
            "bytes": culling_bytes,
            "stats": build.stats, "resolution": [w, h], "frame": frame,
            "renderer": self.limits.renderer,
        }
        self.last_meta = meta
        if not readback:
            return None
        return self.read_outputs(meta, groups)

    @staticmethod
    def _set_uniforms(prog, uniforms) -> None:
        for k, v in uniforms.items():
            if k in prog:
                prog[k].value = v

    def read_outputs(self, meta, groups) -> FrameResult:
        w, h = self.size
        color = np.frombuffer(self.buffers["out_color"].read(size=w * h * 16), np.float32).reshape(h, w, 4)
        stats = np.frombuffer(self.buffers["out_stats"].read(size=w * h * 16), np.uint32).reshape(h, w, 4)
        wave = np.frombuffer(self.buffers["wave_stats"].read(size=groups[0] * groups[1] * 16),
                             np.uint32).reshape(groups[1], groups[0], 4)
        depth = self.gbuffer.read_position()[..., 3]
        flip = lambda a: np.ascontiguousarray(a[::-1])
        return FrameResult(
            image=flip(color[..., :3]), depth=flip(depth),
            evaluated=flip(stats[..., 0]), contrib_count=flip(stats[..., 1]),
            contrib_hash=flip(stats[..., 2]), nodes=flip(stats[..., 3]), wave=flip(wave), meta=meta)

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()
        self.buffers.clear()
        self.programs.release()
        self.gbuffer.release()
