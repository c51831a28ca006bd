"""One frame of the pipeline, executed from declarations alone (the renderer draws to no
window and knows no technique by name):

    gbuffer (raster pass of the frame) -> technique.build (CPU stage, timed by step)
      -> upload -> technique.passes(): compute / raster passes and host steps, in order
      -> read back (optional)

Each pass binds only the buffers it declares, at binding points numbered per program; a pass
that reads a buffer nothing in this frame provided (an upload of the build or an earlier
pass's write) is an error, so no pass can read a previous frame's or technique's data.
Storage buffers are kept by name and grown only when a frame needs more, so long runs
allocate nothing per frame.

`render(..., samples=N)` measures N samples of one frame: the CPU stage, the upload and every
timed pass run N times; untimed passes and host steps (set-up outside the measured cost, such
as the perfect culler's list building) run once, and a timed pass may not write what an
untimed one wrote.

`render(..., keep_setup=True)` is for a frame rendered again later (the benchmark's interleaved
timing samples, app/bench/sweep.py): a frame whose steps all ran records its untimed set-up
(the buffers its untimed passes and host steps wrote, its timed passes); a later render of
the same frame (the same technique, options, switches, camera, size and CPU-stage uploads,
byte for byte) whose set-up buffers no step has written since runs the G-buffer, the CPU
stage, the upload and the timed passes alone, as render(samples=N)'s later samples do.  The
set-up's outputs are a function of those inputs, so the timed passes read what they would
have read; a set-up that another frame overwrote meanwhile runs again.

`render(..., deadline=T)` (a time.perf_counter() value) stops the frame between two of its
steps (a pass, a dispatch window, a host step; never inside a dispatch) once T has passed,
raising FrameTimeout; the next render starts a new frame record, so the renderer is usable as
before.  What the deadline covers is the technique's per-frame GPU work: the clock that T is
read on is held back by everything before the technique's first pass (the G-buffer, the CPU
build and upload: a cold numba cache compiles kernels there, seconds, which the window pays
once) and by each pass that built a new GL program (a software GL compiles on the first
dispatch, so that pass is compile plus one dispatch window).  A caller's deadline thus
measures what a later frame of the technique would cost, not its first frame's set-up.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import time

import moderngl
import numpy as np

import cpu_prep
from cpu_prep.arena import Arena
from cpu_prep.camera import frame_camera
from cpu_prep.limits import WINDOW_ALL, LimitError
from . import features as feat, fog as fogmod, gl, rawgl
from . import phases
from ..errors import FrameTimeout, UserError
from .gbuffer import GBuffer, TEXTURE_UNITS
from .passes import (DEPTH_FUNCS, DRAW_MODES, FRAME_OUTPUTS, OUT_CELL, OUT_STATS, Buffer, Build,
                     FrameInput, HostStep, Pass, Target, WAVE_DIM)
from .shaders import ProgramCache
from .validate import check_steps

DEBUG_SLOT = "debug_lights"    # pixel.glsl DEBUG_PIXEL: ids of the lights affecting one pixel
DEBUG_MAX_IDS = 1 << 16


@dataclass
class FrameResult:
    """A rendered frame: its figures (meta), the technique's Build, and, when read back, the
    per-pixel outputs in image order (row 0 = top)."""
    meta: dict
    build: Build | None = None
    image: np.ndarray | None = None          # (H,W,3) float32 linear radiance
    depth: np.ndarray | None = None          # (H,W) float32 linear view depth, 0 = no geometry
    evaluated: np.ndarray | None = None      # (H,W) uint32
    contrib_count: np.ndarray | None = None  # (H,W) uint32
    contrib_hash: np.ndarray | None = None   # (H,W) uint32
    nodes: np.ndarray | None = None          # (H,W) uint32 tree nodes visited
    wave: np.ndarray | None = None           # (GH,GW) WAVE_STATS per 8x8 group, image order
    cell: np.ndarray | None = None           # (H,W) uint32 the structure cell each pixel read
    debug_lights: np.ndarray | None = None   # render(debug_pixel=...): ids affecting that pixel
    # a scene with transparent surfaces (app/pipeline/transparent.py): per layer (L, H, W), 0 where
    # a layer has no fragment
    contrib_count_t: np.ndarray | None = None
    contrib_hash_t: np.ndarray | None = None
    depth_t: np.ndarray | None = None
    evaluated_t: np.ndarray | None = None
    froxel_count: np.ndarray | None = None   # (D,H,W) uint32 a fog scene's froxel light sets
    froxel_hash: np.ndarray | None = None    # (D,H,W) uint32 (app/pipeline/fog.py)
    froxel_sets: object | None = None        # cpu_prep.froxels.FroxelSets of the frame
    froxel_grid: object | None = None        # ... and its cpu_prep.froxels.FroxelGrid


@dataclass
class _Frame:
    """What the steps run so far in this frame have provided: buffer -> (bytes, dtype)."""
    provided: dict = field(default_factory=dict)
    untimed_writes: set = field(default_factory=set)
    bytes: dict = field(default_factory=dict)      # culling buffers the passes bound
    setup_ms: dict = field(default_factory=dict)
    timed: list = field(default_factory=list)      # timed passes, in order, for later samples
    native: bool = False
    debug_pixel: tuple | None = None               # GL coordinates of the explained pixel
    figures: bool = True                           # run the figures-only steps (passes.py)
    deadline: float | None = None                  # render(deadline=): perf_counter value
    begun_s: float = 0.0                           # when render() began (perf_counter)
    held_s: float = 0.0                            # time not counted against the deadline
    counting_from: float | None = None             # this sample's start, until its first step
    technique: str = ""
    programs: dict = field(default_factory=dict)   # pass name -> [ProgramKey] it ran (the cost model's counts)


@dataclass
class _SetUp:
    """A frame's untimed set-up, kept for a later render of the same frame (keep_setup):
    the write serial and provided entry of every buffer its untimed steps wrote that its
    timed passes bind, its timed passes in order, and the frame's record beside them."""
    written: dict          # buffer name -> (serial of the write, provided entry)
    timed: list
    setup_ms: dict
    stats: dict
    programs: dict


class Renderer:
    def __init__(self, scene, size: tuple[int, int] | None = None,
                 transparent_layers: int | None = None):
        self.ctx = gl.context()
        self.limits = gl.limits()
        self.scene = scene
        self.programs = ProgramCache(self.ctx)
        self.timer = gl.PassTimer(self.ctx)
        size = tuple(size or scene.resolution)
        self._check_size(size)
        self.gbuffer = GBuffer(self.ctx, scene.meshes, size)
        self.buffers: dict[str, moderngl.Buffer] = {}
        self.arena = Arena()     # CPU-stage outputs, reused frame to frame (uploaded at once)
        self._vbos: dict = {}    # id(vertex array) -> (array, vbo)
        self._vaos: dict = {}
        self._blank = None       # colour target of passes that draw to no target
        self._targets: dict = {}  # Target.name -> ((Target, size), rawgl.DepthTarget)
        self._frame = _Frame()
        self._serial = 0          # write serial: every buffer write (upload, pass) takes the next
        self._written: dict[str, int] = {}     # buffer name -> serial of its last write
        self._setups: dict[bytes, _SetUp] = {}  # what a set-up was made from -> the kept set-up
        from . import transparent      # the scene's transparent layers (None: it has none)
        self.transparent = transparent.for_scene(
            self.ctx, scene, transparent.DEFAULT_LAYERS if transparent_layers is None
            else transparent.check_layers(transparent_layers))
        self.fog_options = None  # a fog scene's grid (app/pipeline/fog.py FogOptions; None: defaults)

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

    def buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        """The named storage buffer, at least nbytes (>= 16), reused across frames."""
        nbytes = max(int(nbytes), 16)
        if nbytes > self.limits.max_storage_block:
            raise UserError(f"buffer '{name}' needs {nbytes / 2**20:.1f} MiB, over the "
                            f"{self.limits.max_storage_block >> 20} MiB storage-block limit")
        buf = self.buffers.get(name)
        if buf is None or buf.size < nbytes:
            if buf is not None:
                buf.release()
            # a power of two, 4 KiB at least: sizes that drift by a few bytes from frame to
            # frame (a light count's arrays) allocate nothing new
            buf = self.ctx.buffer(reserve=max(4096, 1 << (nbytes - 1).bit_length()))
            self.buffers[name] = buf
            self._wrote(name)         # a new buffer holds nothing of the old one
        return buf

    def _wrote(self, name: str) -> None:
        """Record a write of buffer `name` (the set-up a later frame may reuse checks it)."""
        self._serial += 1
        self._written[name] = self._serial

    def upload(self, name: str, array: np.ndarray) -> None:
        buf = self.buffer(name, array.nbytes)
        if array.nbytes:
            buf.write(np.ascontiguousarray(array))     # its memory as it is: no copy
        self._wrote(name)
        self._frame.provided[name] = (int(array.nbytes), array.dtype)

    def output(self, name: str) -> moderngl.Buffer:
        """A buffer this frame provided (e.g. out_stats for the window's views)."""
        if name not in self._frame.provided:
            raise UserError(f"no buffer '{name}' in the last frame "
                            f"(it has: {', '.join(sorted(self._frame.provided))})")
        return self.buffers[name]

    def provided(self) -> list[str]:
        """The buffers this frame provided (uploads and pass writes)."""
        return list(self._frame.provided)

    def nbytes(self, name: str) -> int:
        """Bytes of a buffer this frame provided."""
        return self._frame.provided[name][0]

    def read(self, name: str) -> np.ndarray:
        """A buffer of this frame read back, as its declared element type."""
        nbytes, dtype = self._frame.provided[name]
        dtype = np.dtype(dtype if dtype is not None else np.uint32)
        data = self.buffers[name].read(size=nbytes) if nbytes else b""
        return np.frombuffer(data, dtype, count=len(data) // dtype.itemsize)

    # ---- the frame -----------------------------------------------------------------

    def camera(self, frame: int, frames: int):
        w, h = self.size
        return frame_camera(self.scene.camera_at(frame, frames), w, h)

    def frame_input(self, frame: int, frames: int, lights=None, camera=None) -> FrameInput:
        """The CPU stage's input for a frame: the scene's lights at that frame (moved by
        its motion: Scene.lights_at; or `lights`), the path camera of `frame` (or `camera`),
        the scene's max depth, this renderer's arena."""
        cam = camera or self.camera(frame, frames)
        lights = self.scene.lights_at(frame, frames) if lights is None else lights
        return FrameInput(lights, cam, self.scene.max_depth or cam.far, self.arena,
                          self.limits.loop_budget, self.limits.loop_lanes, self.limits,
                          self.gbuffer.specular, fog=self.scene.fog)

    def render(self, technique, frame: int = 0, opts=None, frames: int = 64,
               lights: np.ndarray | None = None, readback: bool = True, camera=None,
               defines: dict | None = None, samples: int = 1,
               debug_pixel: tuple[int, int] | None = None, figures: bool | None = None,
               deadline: float | None = None, keep_setup: bool = False) -> FrameResult:
        """Render one frame of `technique` (anything with resolve_options, build and
        passes).  `defines` are frame-wide switches that reach every program declaring them
        (e.g. UNBOUNDED_FALLOFF=1).  meta['samples'] holds each sample's CPU and GPU ms;
        meta['cpu_ms'] / ['gpu_ms'] are the last sample's; the result's build and meta's
        features the first sample's, whose steps all ran (host steps included).
        `debug_pixel` (x, row from the top) records the ids of the lights the shading passes find affecting that pixel
        (FrameResult.debug_lights, sorted).  `figures` (default: `readback`) runs the steps
        that only count figures for meta['stats'] and the technique's maps (passes.py).
        `deadline` (a time.perf_counter() value): FrameTimeout between two steps once it
        has passed, counting only the technique's passes (the module's docstring).
        `keep_setup`: keep the frame's untimed set-up for a later render of the same frame,
        and reuse one kept while it is intact (the module's docstring; not with transparent
        layers, fog or a debug pixel, whose frames run whole)."""
        with phases.phase("render" if readback else "timing"):    # app.pipeline.phases: where time goes
            return self._render(technique, frame, opts, frames, lights, readback, camera,
                                defines, samples, debug_pixel, figures, deadline, keep_setup)

    def _render(self, technique, frame, opts, frames, lights, readback, camera, defines,
                samples, debug_pixel, figures, deadline, keep_setup=False) -> FrameResult:
        begun = time.perf_counter()
        opts = technique.resolve_options(opts)
        if self.scene.fog is not None:            # a technique that cannot serve froxels: one line
            fogmod.refuse(technique, opts, self.fog_options)
        fin = self.frame_input(frame, frames, lights, camera)
        self._begin_frame(debug_pixel, readback if figures is None else figures)
        f = self._frame
        f.deadline, f.technique, f.begun_s = deadline, technique.name, begun
        keep = keep_setup and self.transparent is None and self.scene.fog is None and \
            debug_pixel is None
        records, stats, ran = [], None, None
        try:
            for k in range(max(int(samples), 1)):
                build, features, record = self._sample(technique, fin, opts, defines, first=k == 0,
                                                       keep=keep)
                if stats is None:
                    stats = dict(build.stats)       # host steps of the first sample add to them
                    ran = build, features           # the build whose steps (host steps) all ran
                records.append(record)
        finally:
            f.deadline = None                       # run() after the frame (the window's passes): none
        build, features = ran
        missing = [n for n in FRAME_OUTPUTS if n not in self._frame.provided]
        if missing:
            raise UserError(f"technique '{technique.name}': no pass writes {', '.join(missing)}")
        w, h = self.size
        meta = {
            "technique": technique.name, "options": opts.as_dict(), "features": list(features),
            "wave": f"native-{self.limits.native_wave}" if self._frame.native else "emulated-64",
            "cpu_ms": records[-1]["cpu_ms"], "cpu_threads": cpu_prep.threads(),
            "gpu_ms": records[-1]["gpu_ms"], "setup_ms": dict(self._frame.setup_ms), "bytes": dict(self._frame.bytes),
            "stats": stats, "resolution": [w, h], "frame": frame,
            "renderer": self.limits.renderer,
        }
        if samples > 1:
            meta["samples"] = records
        result = FrameResult(meta=meta, build=build)
        if self.scene.fog is not None and debug_pixel is None:   # the medium over the frame
            fogmod.render_fog(self, technique, opts, build, result, self.fog_options, readback)
        if readback:
            self._read_outputs(result)
            if self.transparent is not None:
                self.transparent.read_outputs(result)
        if self.transparent is not None:
            meta["transparent"] = dict(self.transparent.meta)
        if debug_pixel is not None:
            raw = np.frombuffer(self.buffers[DEBUG_SLOT].read(), np.uint32)
            result.debug_lights = np.unique(raw[1:1 + min(int(raw[0]), DEBUG_MAX_IDS)])
        return result

    def _begin_frame(self, debug_pixel, figures: bool) -> None:
        """A new frame record; with a debug pixel (x, row from the top), its id buffer cleared."""
        self._frame = _Frame(figures=figures)
        if debug_pixel is not None:
            x, row = debug_pixel
            self._frame.debug_pixel = (int(x), self.size[1] - 1 - int(row))
            self.buffer(DEBUG_SLOT, 4 + 4 * DEBUG_MAX_IDS).clear()

    def _sample(self, technique, fin, opts, defines, first: bool, keep: bool = False):
        """One sample of the frame: G-buffer, CPU stage, upload, then every step of the
        technique (the first sample: compiles, host steps included; `keep`: its set-up kept,
        or a kept one reused while intact) or its timed passes again.
        -> (build, feature set, {"cpu_ms", "gpu_ms"})."""
        self.timer.take()
        begun = self._frame.begun_s if first else time.perf_counter()   # the first: the frame input too
        virtual = {"generated.glsl": feat.generated_glsl()}
        for p in self._checked([self.gbuffer.pass_for(fin.camera)], virtual, "frame"):
            self._run_pass(p, virtual, {}, {}, record=False)
        self.gbuffer.bind_textures()
        try:
            with phases.phase("build"):
                build = technique.build(fin, opts)
        except LimitError as exc:
            raise UserError(str(exc)) from None
        t0 = time.perf_counter()
        for name, array in build.buffers.items():
            self.upload(name, array)
        cpu_ms = dict(build.times.ms, upload=(time.perf_counter() - t0) * 1e3)
        features = feat.feature_set(build.lights.type, self.gbuffer.specular)
        frame_uniforms = {"u_size": self.size, "u_light_count": len(build.lights.gpu),
                          "u_window": (0, WINDOW_ALL)}
        virtual = dict(feat.virtual_files(features), **getattr(technique, "glsl", {}))
        env = (virtual, dict(defines or {}), frame_uniforms)
        self._frame.counting_from = begun   # the first step's check holds back what came before
        key = self._setup_key(technique, opts, defines, fin, build) if first and keep else None
        kept = self._intact_setup(key)
        if kept is not None:
            self._restore_setup(kept, build)
            for p in kept.timed:
                self._run_pass(p, *env, technique.name)
        elif first:
            # a build made on the GPU (app/gpu_build) brings its passes, ending in the technique's
            steps = build.steps or technique.passes(build, opts)
            if self.transparent is not None:      # the layers first (app/pipeline/transparent.py)
                self.transparent.shade(self, steps, env, technique.name, fin.camera)
            self.run(steps, *env, technique=technique.name)
            # a GPU build knows its visible lights' shapes once its steps ran (app/gpu_build)
            features = feat.feature_set(build.lights.type, self.gbuffer.specular)
            if key is not None:
                self._keep_setup(key, build)
        else:
            for p in self._frame.timed:
                self._check_deadline(p.name)
                self._run_pass(p, *env, technique.name)
        if self.transparent is not None:
            self.transparent.composite(self)
        return build, features, {"cpu_ms": cpu_ms, "gpu_ms": self.timer.take()}

    # ---- a kept set-up (keep_setup) -------------------------------------------------

    def _setup_key(self, technique, opts, defines, fin, build) -> bytes:
        """What a frame's set-up is made from: the technique, its options and switches, the
        camera and size (the G-buffer), and every upload of the CPU stage, byte for byte."""
        import hashlib
        h = hashlib.blake2b(digest_size=20)
        cam = fin.camera
        h.update(repr((technique.name, opts, sorted((defines or {}).items()), self.size,
                       cam.width, cam.height, cam.near, cam.far, cam.tan_half_y)).encode())
        h.update(np.ascontiguousarray(cam.view_from_world).data)
        h.update(np.ascontiguousarray(cam.clip_from_view).data)
        for name, array in build.buffers.items():
            h.update(name.encode())
            h.update(str(array.dtype).encode())
            h.update(np.ascontiguousarray(array).data)
        return h.digest()

    KEPT_SETUPS = 64      # set-ups kept at once (a benchmark group's configurations)

    def _keep_setup(self, key: bytes, build) -> None:
        """Keep the frame just run whole as the set-up made from `key`."""
        f = self._frame
        self._setups.pop(key, None)
        while len(self._setups) >= self.KEPT_SETUPS:
            self._setups.pop(next(iter(self._setups)))         # the oldest
        bound = {p.buffer_of(slot) for p in f.timed for slot in p.slots()}
        self._setups[key] = _SetUp(
            {n: (self._written[n], f.provided[n]) for n in f.untimed_writes & bound
             if n in f.provided}, [p for p in f.timed if not p.figures],   # figures feed nothing
            dict(f.setup_ms), dict(build.stats),
            {k: list(v) for k, v in f.programs.items()})

    def _intact_setup(self, key: bytes | None) -> _SetUp | None:
        """The set-up kept for `key` when no step has written its buffers since; else None
        (the frame runs whole)."""
        kept = self._setups.get(key) if key is not None else None
        if kept is None or any(self._written.get(n) != serial
                               for n, (serial, _) in kept.written.items()):
            return None
        return kept

    def _restore_setup(self, kept: _SetUp, build) -> None:
        """This frame's record as if its set-up had run: its buffers provided, its set-up
        times, the figures its host steps added."""
        f = self._frame
        for name, (_, entry) in kept.written.items():
            f.provided[name] = entry
            f.untimed_writes.add(name)
        f.setup_ms.update(kept.setup_ms)
        f.programs.update({k: list(v) for k, v in kept.programs.items()})
        for k, v in kept.stats.items():
            build.stats.setdefault(k, v)

    # ---- executing steps -----------------------------------------------------------

    def run(self, steps, virtual: dict | None = None, defines: dict | None = None,
            uniforms: dict | None = None, technique: str = "") -> None:
        """Run passes and host steps in order (host steps may add steps after themselves),
        each list checked whole before its first step runs (validate.py).  Also the
        window's way to run its own passes over this frame's buffers."""
        virtual = virtual or {"generated.glsl": feat.generated_glsl()}
        queue = self._checked(steps, virtual, technique)
        while queue:
            step = queue.pop(0)
            self._check_deadline(step.name)
            if isinstance(step, HostStep):
                queue[:0] = self._checked(self._run_host(step), virtual, technique)
            else:
                self._run_pass(step, virtual, defines or {}, uniforms or {}, technique)

    def _hold(self, since: float) -> None:
        """Hold the deadline's clock back by the time since `since` (not the technique's
        per-frame cost: module docstring)."""
        self._frame.held_s += time.perf_counter() - since

    def _check_deadline(self, step: str) -> None:
        """FrameTimeout before `step` when the frame's deadline has passed on the held-back
        clock (module docstring).  Between steps only: a dispatch runs whole."""
        f = self._frame
        if f.deadline is None:
            return
        if f.counting_from is not None:     # the G-buffer, the CPU build (its kernel compiles), the upload
            self._hold(f.counting_from)
            f.counting_from = None
        now = time.perf_counter()
        if now - f.held_s > f.deadline:
            raise FrameTimeout(f"{f.technique}: frame stopped at its deadline after "
                               f"{now - f.begun_s - f.held_s:.1f} s of its passes (compiles not "
                               f"counted), before '{step}'")

    def _checked(self, steps, virtual: dict, technique: str) -> list:
        """The steps this frame runs (figures-only ones when it wants figures), checked
        against what it has provided so far."""
        f = self._frame
        steps = [s for s in steps if f.figures or not getattr(s, "figures", False)]
        check_steps(steps, f.provided, f.untimed_writes, virtual, technique,
                    self.limits.max_work_groups)
        return steps

    def _run_host(self, step: HostStep) -> list:
        t0 = time.perf_counter()
        uploads, more = step.run({n: self.read(n) for n in step.reads})
        for name, array in uploads.items():
            self.upload(name, array)
        self._frame.untimed_writes.update(uploads)
        self._frame.setup_ms[step.name] = self._frame.setup_ms.get(step.name, 0.0) + \
            (time.perf_counter() - t0) * 1e3
        return list(more)

    def _run_pass(self, p: Pass, virtual: dict, defines: dict, uniforms: dict,
                  technique: str = "", record: bool = True) -> None:
        """Bind what the pass declares, compile (cached), set uniforms, run; a timed pass is
        recorded (record=True) for the frame's later samples.  The pass has been checked
        (_checked): its reads are provided and its uniforms declared."""
        where = f"pass '{p.name}'" + (f" of {technique}" if technique else "")
        f = self._frame
        for slot, spec in p.writes.items():
            name = p.buffer_of(slot)
            buf = self.buffer(name, spec.nbytes)
            if spec.cleared:
                buf.clear()
            self._wrote(name)
            f.provided[name] = (int(spec.nbytes), spec.struct)
            if not p.timed:
                f.untimed_writes.add(name)
        bindings = {slot: i for i, slot in enumerate(p.slots())}
        for slot, i in bindings.items():
            name = p.buffer_of(slot)
            self.buffers[name].bind_to_storage_buffer(i)
            if p.timed and name not in FRAME_OUTPUTS:   # the measured technique's data
                f.bytes[name] = f.provided[name][0]
        wave = self.limits.wave_define if p.native_wave else 0   # the loader writes its #extension lines
        f.native |= bool(wave) and not p.figures   # the frame's path: not a counting twin's
        optional = dict(defines, WAVE_NATIVE=wave)
        if f.debug_pixel is not None and OUT_STATS in p.writes:   # shading passes only
            bindings[DEBUG_SLOT] = len(bindings)
            self.buffers[DEBUG_SLOT].bind_to_storage_buffer(bindings[DEBUG_SLOT])
            optional["DEBUG_PIXEL"] = 1
            uniforms = dict(uniforms, u_debug_pixel=f.debug_pixel)
        virtual = p.files(virtual)
        begun, programs, built = time.perf_counter(), len(self.programs.sources), self.programs.built
        if p.kind == "compute":
            prog = self.programs.compute(p.shader, dict(p.defines), virtual, (), bindings, optional, where)
            work = (lambda: prog.run(*p.groups)) if p.indirect is None else \
                (lambda: prog.run_indirect(self.buffers[p.indirect[0]], p.indirect[1]))
        else:
            prog = self.programs.program(*p.shader, dict(p.defines), virtual, bindings, optional, where)
            work = lambda: self._draw(prog, p.draw)
        self._set_uniforms(prog, dict(uniforms, **p.uniforms))
        keys = f.programs.setdefault(p.name, [])
        if self.programs.last_key not in keys:
            keys.append(self.programs.last_key)
        if p.timed:
            self.timer.run(p.name, work)
            if record and not any(q is p for q in f.timed):
                f.timed.append(p)
        else:
            t0 = time.perf_counter()
            work()
            self.ctx.finish()
            f.setup_ms[p.name] = f.setup_ms.get(p.name, 0.0) + (time.perf_counter() - t0) * 1e3
        self.ctx.memory_barrier()   # the next pass reads what this one wrote
        if self.programs.built != built:     # it compiled its program (app.pipeline.phases)
            phases.move("compile", time.perf_counter() - begun)
        if record and len(self.programs.sources) != programs:
            self._hold(begun)       # its program's first use here: a compile (a software GL's at its first dispatch)

    @staticmethod
    def _set_uniforms(prog, uniforms) -> None:
        """Set those the program kept: the checks found every pass uniform in its source, so
        one missing here is one the driver dropped as unused (or a frame-wide one)."""
        for k, v in uniforms.items():
            if k in prog:
                if isinstance(v, np.ndarray):
                    prog[k].write(np.ascontiguousarray(v).tobytes())
                else:
                    prog[k].value = v

    def _target(self, target):
        if isinstance(target, Target):
            return self._own_target(target).fbo
        if not isinstance(target, str):
            return target
        if target != "none":
            return self.gbuffer.target(target)
        if self._blank is None or self._blank.size != self.size:
            if self._blank is not None:
                self._blank.release()
            self._blank = self.ctx.framebuffer(self.ctx.renderbuffer(self.size, 1))
        return self._blank

    def _vertex_array(self, prog, d):
        vbo = None
        if d.vertices is not None:
            key = id(d.vertices)
            if key not in self._vbos:
                data = np.ascontiguousarray(d.vertices, np.float32)
                self._vbos[key] = (d.vertices, self.ctx.buffer(data.tobytes() if data.size else b"\0" * 64))
            vbo = self._vbos[key][1]
        key = (id(prog), id(vbo))
        if key not in self._vaos:
            content = [(vbo, d.format, *d.attributes)] if vbo is not None else []
            self._vaos[key] = self.ctx.vertex_array(prog, content, skip_errors=True)
        return self._vaos[key]

    def _own_target(self, t: Target) -> rawgl.DepthTarget:
        """The technique's Target at this frame's size (made or remade on demand)."""
        w, h = self.size
        spec = (t, (-(-w // t.scale), -(-h // t.scale)))
        held = self._targets.get(t.name)
        if held is None or held[0] != spec:
            if held is not None:
                held[1].release()
            held = self._targets[t.name] = (spec, rawgl.DepthTarget(
                self.ctx, t.name, spec[1], t.samples, t.stencil))
        return held[1]

    def _depth_test(self, test) -> None:
        if test:
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.depth_func = DEPTH_FUNCS[test]
        else:
            self.ctx.disable(moderngl.DEPTH_TEST)

    def _cull(self, cull) -> None:
        if cull:
            self.ctx.enable(moderngl.CULL_FACE)
            self.ctx.cull_face = cull
        else:
            self.ctx.disable(moderngl.CULL_FACE)

    def _draw(self, prog, d) -> None:
        ctx = self.ctx
        fbo = self._target(d.target)
        fbo.use()
        own = self._targets[d.target.name][1] if isinstance(d.target, Target) else None
        ctx.viewport = d.viewport or (0, 0, *(own.size if own else fbo.size))
        if d.clear:
            if own is not None:
                own.clear()
            else:
                fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._depth_test(d.depth_test)
        fbo.depth_mask = d.depth_write
        self._cull(d.cull)
        if d.blend:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        else:
            ctx.disable(moderngl.BLEND)
        count = d.count if d.count is not None else (len(d.vertices) if d.vertices is not None else 0)
        if count and d.instances and d.stencil:
            self._draw_stencil(prog, d, count)
        elif count and d.instances:
            self._vertex_array(prog, d).render(DRAW_MODES[d.mode], vertices=count, instances=d.instances)
        fbo.depth_mask = True
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)

    def _draw_stencil(self, prog, d, count: int) -> None:
        """Draw.stencil: for each instance, one draw per step, the stencil test on."""
        raw = rawgl.lib()
        vao = self._vertex_array(prog, d)
        has_instance, has_step = "u_instance" in prog, "u_step" in prog
        self.ctx.enable_direct(rawgl.STENCIL_TEST)
        raw.glStencilMask(0xFF)
        try:
            for i in range(d.instances):
                if has_instance:
                    prog["u_instance"].value = i
                for k, step in enumerate(d.stencil):
                    if has_step:
                        prog["u_step"].value = k
                    self._cull(step.cull)
                    self._depth_test(step.depth_test)
                    ref = step.ref or (i % 255 + 1)
                    raw.glStencilFunc(rawgl.STENCIL_FUNCS[step.func], ref, 0xFF)
                    raw.glStencilOp(*(rawgl.STENCIL_OPS[o] for o in step.ops))
                    vao.render(DRAW_MODES[d.mode], vertices=count, instances=1)
        finally:
            raw.glStencilFunc(rawgl.STENCIL_FUNCS["always"], 0, 0xFF)
            raw.glStencilOp(*(rawgl.STENCIL_OPS["keep"],) * 3)
            self.ctx.disable_direct(rawgl.STENCIL_TEST)

    # ---- outputs -------------------------------------------------------------------

    def _read_outputs(self, result: FrameResult) -> None:
        w, h = self.size
        flip = lambda a: np.ascontiguousarray(a[::-1])
        color = self.read("out_color").reshape(h, w, 4)
        stats = self.read("out_stats").reshape(h, w)
        wave = self.read("wave_stats").reshape(-(-h // WAVE_DIM), -(-w // WAVE_DIM))
        result.image = flip(color[..., :3])
        result.depth = flip(self.gbuffer.read_position()[..., 3])
        result.evaluated = flip(stats["evaluated"])
        result.contrib_count = flip(stats["contrib_count"])
        result.contrib_hash = flip(stats["contrib_hash"])
        result.nodes = flip(stats["nodes"])
        result.cell = flip(self.read(OUT_CELL).reshape(h, w))
        result.wave = flip(wave)

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()
        self.buffers.clear()
        for vao in self._vaos.values():
            vao.release()
        for _, vbo in self._vbos.values():
            vbo.release()
        self._vaos.clear()
        self._vbos.clear()
        if self._blank is not None:
            self._blank.release()
            self._blank = None
        for _, t in self._targets.values():
            t.release()
        self._targets.clear()
        if self.transparent is not None:
            self.transparent.release()
        self._setups.clear()
        self.programs.release()
        self.gbuffer.release()


__all__ = ["Renderer", "FrameResult", "Buffer", "TEXTURE_UNITS"]
