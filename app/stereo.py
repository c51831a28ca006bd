"""Two eyes (`--views stereo`): a frame rendered from two eye cameras, and a technique's
structure built for them in one of two ways.

    eyes        the centre camera (the scene's, at the frame) moved by -sep/2 and +sep/2
                along its right vector: same orientation, same projection (eye_cameras)
    per-view    the technique's structure built once per eye, each from its own camera
    union       ONE CPU stage over the union of the two eyes' frusta, shading both eyes:
                the union camera is the centre camera pulled back along its forward axis
                by (sep/2) / tan(fov_x/2) (and UNION_MARGIN more), near plane at the eyes'
                near plane, far at theirs, so that its frustum holds both eyes' frusta
                (union_camera, contains).  What it shares is the technique's declaration
                (Technique.stereo_union):
                  "structure"  the structure itself (a 2.5D grid of index lists or trees,
                               the samplers' CDF words over it):
                               built once over the union camera; each eye's shading maps its
                               view-space position into the union camera's cells and depth (a
                               translation, the orientation being the same: STEREO_UNION in
                               glsl/cells.glsl, cell_of and cell_depth); only the light records
                               are packed per eye
                  "cull-sort"  a structure made per pixel of a view (screen tiles, per-tile
                               trees, z-bins over tiles, rasterized tiles): only the CPU
                               cull and depth sort are made once over the union camera; each
                               eye packs that order in its own camera and builds the rest
Both ways are exact in each eye: every light that affects a pixel of an eye is in the union
camera's cull (its frustum holds the eye's) and in the cell the pixel maps to (the CPU bounds'
pixel and depth margins hold the mapping's float error); each eye's light records are that
eye's own, so every eye evaluates the same float32 numbers as `brute` rendered per eye.

The union way refuses, in one line, the options it cannot honour: a GPU-built structure
(built from the view on the GPU), an engine's cap policy (a view's visible set decides what
it drops) and stochastic culling (ranges drawn from the eye's position).

No technique is named here: the declaration says what each shares.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
import math
import weakref

import numpy as np

from cpu_prep import frame as cpuframe, lights as lightsmod
from cpu_prep.arena import Arena
from cpu_prep.camera import FrameCamera, perspective

from .errors import UserError

VIEWS = ("mono", "stereo")
WAYS = ("per-view", "union")
EYES = ("left", "right")
DEFAULT_SEPARATION = 0.064      # metres, a typical interpupillary distance
MAX_SEPARATION = 10.0
# the union camera is pulled back this much further (relative), so that its side planes lie
# strictly outside the eyes' (exactly (sep/2)/tan(fov_x/2) makes them coincide) and its
# near plane strictly before theirs
UNION_MARGIN = 1e-3
STRUCTURE, CULL_SORT = "structure", "cull-sort"
SHARES = (STRUCTURE, CULL_SORT)
UNION_DEFINE = "STEREO_UNION"
# what each declaration shares in the union way, for the technique pages (app.reference)
SHARE_DOCS = {
    STRUCTURE: "its structure itself, built once over the union camera's frustum; each eye's "
               "shading maps its pixels into the union camera's cells and depth (STEREO_UNION, "
               "glsl/cells.glsl) and only the light records are packed per eye",
    CULL_SORT: "only the CPU cull and depth sort (view-independent work), made once over the "
               "union camera's frustum; each eye packs that order in its own camera and builds "
               "the rest of its CPU stage itself (a structure made per pixel of a view, where "
               "it has one, cannot be shared by pixel)",
}
# the buffers of a structure-sharing build that hold the lights themselves (view space):
# packed per eye; every other buffer is the shared structure
EYE_BUFFERS = ("lights", "dup_lights")


# ---- cameras ------------------------------------------------------------------------------

def moved(cam: FrameCamera, origin, near: float | None = None, far: float | None = None) -> FrameCamera:
    """`cam` moved to `origin` (a point in cam's view space), same orientation; its
    projection with `near` / `far` (default cam's)."""
    v = np.array(cam.view_from_world, np.float64)
    v[:3, 3] -= np.asarray(origin, np.float64)
    near = cam.near if near is None else float(near)
    far = cam.far if far is None else float(far)
    fov_y = math.degrees(2.0 * math.atan(cam.tan_half_y))
    clip = cam.clip_from_view if (near, far) == (cam.near, cam.far) else \
        perspective(fov_y, cam.width / cam.height, near, far)
    return replace(cam, view_from_world=v, clip_from_view=clip, near=near, far=far)


def eye_cameras(center: FrameCamera, separation: float) -> tuple[FrameCamera, FrameCamera]:
    """(left, right): the centre camera at -sep/2 and +sep/2 along its right vector."""
    h = 0.5 * float(separation)
    return moved(center, (-h, 0.0, 0.0)), moved(center, (h, 0.0, 0.0))


def pullback(center: FrameCamera, separation: float) -> float:
    """How far behind the centre the union camera stands: (sep/2) / tan(fov_x/2), exactly
    (its side planes then pass through the eyes' outer ones)."""
    return 0.5 * float(separation) / center.tan_half_x


def union_camera(center: FrameCamera, separation: float) -> FrameCamera:
    """The centre camera pulled back by pullback() x (1 + UNION_MARGIN): its near plane just
    before the eyes' (at their depth near + pullback in its view), its far plane just past
    theirs; same orientation and projection angles, so its frustum holds both eyes'."""
    d0 = pullback(center, separation)
    d = d0 * (1.0 + UNION_MARGIN)
    return moved(center, (0.0, 0.0, d), near=center.near + d0, far=center.far + d + UNION_MARGIN * d0)


def offset_into(outer: FrameCamera, inner: FrameCamera) -> tuple[float, float, float]:
    """inner's view-space origin in outer's view space (the two share their orientation, so
    a point's outer coordinates are its inner ones plus this)."""
    m = np.asarray(outer.view_from_world) @ np.linalg.inv(np.asarray(inner.view_from_world))
    return tuple(float(v) for v in m[:3, 3])


def frustum_corners(cam: FrameCamera, near: float | None = None, far: float | None = None) -> np.ndarray:
    """(8, 3) world-space corners of cam's frustum between `near` and `far` (default its own)."""
    inv = np.linalg.inv(np.asarray(cam.view_from_world, np.float64))
    out = []
    for z in (cam.near if near is None else near, cam.far if far is None else far):
        for sx in (-1, 1):
            for sy in (-1, 1):
                p = np.array([sx * z * cam.tan_half_x, sy * z * cam.tan_half_y, -z, 1.0])
                out.append((inv @ p)[:3])
    return np.array(out)


def inside(cam: FrameCamera, points: np.ndarray) -> np.ndarray:
    """Whether each world point lies inside cam's frustum, its planes included (bool (N,))."""
    p = np.c_[points, np.ones(len(points))] @ np.asarray(cam.view_from_world, np.float64).T
    z = -p[:, 2]
    return ((z >= cam.near) & (z <= cam.far) & (np.abs(p[:, 0]) <= z * cam.tan_half_x)
            & (np.abs(p[:, 1]) <= z * cam.tan_half_y))


def contains(outer: FrameCamera, inner: FrameCamera) -> bool:
    """outer's frustum holds inner's, near plane to far plane (frusta are convex: their
    corners tell)."""
    return bool(inside(outer, frustum_corners(inner)).all())


# ---- refusals -----------------------------------------------------------------------------

def check_separation(sep: float) -> float:
    if not (isinstance(sep, (int, float)) and math.isfinite(sep) and 0.0 < sep <= MAX_SEPARATION):
        raise UserError(f"--eye-separation {sep}: expected metres in (0, {MAX_SEPARATION:g}]")
    return float(sep)


def refusal(technique, opts, way: str) -> str | None:
    """Why `technique` with `opts` cannot be rendered in `way`, in one line, else None."""
    from .techniques.gpu_build import on_gpu
    from .techniques.options import cap_policy, stochastic
    from cpu_prep import caps
    if way not in WAYS:
        return f"--stereo-way {way}: expected one of {', '.join(WAYS)}"
    if way == "per-view":
        return None
    share = getattr(technique, "stereo_union", CULL_SORT)
    if share not in SHARES:
        return f"technique {technique.name}: stereo_union {share!r} not in {SHARES}"
    why = ("--build gpu (the GPU builds the structure from one view's camera)" if on_gpu(opts) else
           f"--cap-policy {cap_policy(opts)} (a view's own visible lights decide what it drops)"
           if cap_policy(opts) != caps.NONE else
           "--stochastic (each light's range is drawn from one eye's position)"
           if stochastic(opts) is not None else None)
    return None if why is None else f"--stereo-way union: {technique.name} cannot share {why}"


def refuse(technique, opts, way: str) -> None:
    why = refusal(technique, opts, way)
    if why:
        raise UserError(why)


# ---- one stereo frame ---------------------------------------------------------------------

@dataclass
class StereoFrame:
    """Both eyes of one frame in one way: each eye's FrameResult (its meta adds eye, way,
    separation and share), and the shared CPU stage's timing samples (the union way: one
    {stage: ms} a sample; per-view: none) and its build (the structure way)."""
    way: str
    separation: float
    share: str | None                      # the union way's declaration; None per view
    results: dict                          # eye -> FrameResult
    shared_ms: list = field(default_factory=list)
    shared_build: object | None = None
    shared_buffers: tuple = ()             # buffers both eyes bind, counted once
    # eye -> what renders it again (the exactness check's explanation): the technique as
    # the renderer saw it, and renderer.render's camera and defines
    renders: dict = field(default_factory=dict)

    def samples(self) -> list[dict]:
        """One {"cpu_ms", "gpu_ms"} a timing sample of the two-eye frame: the shared
        stage's ms and each eye's added by stage and by pass."""
        per_eye = [self.results[e].meta.get("samples") or
                   [{"cpu_ms": self.results[e].meta["cpu_ms"], "gpu_ms": self.results[e].meta["gpu_ms"]}]
                   for e in EYES]
        out = []
        for k in range(min(len(s) for s in per_eye)):
            cpu, gpu = {}, {}
            parts = [s[k] for s in per_eye]
            for stage, v in (self.shared_ms[k] if k < len(self.shared_ms) else {}).items():
                cpu[stage] = cpu.get(stage, 0.0) + v
            for p in parts:
                for stage, v in p["cpu_ms"].items():
                    cpu[stage] = cpu.get(stage, 0.0) + v
                for name, v in p["gpu_ms"].items():
                    gpu[name] = gpu.get(name, 0.0) + v
            out.append({"cpu_ms": cpu, "gpu_ms": gpu})
        return out

    def bytes(self) -> int:
        """Culling bytes of the two-eye frame: each eye's buffers, the shared ones once."""
        total, seen = 0, set()
        for e in EYES:
            for name, n in self.results[e].meta["bytes"].items():
                if name in self.shared_buffers:
                    if name in seen:
                        continue
                    seen.add(name)
                total += int(n)
        return total

    def entries(self) -> int | None:
        """Structure entries (list entries: the stats' list_entries) of the two-eye frame:
        the shared structure's once, else each eye's summed; None where it has none."""
        if self.share == STRUCTURE:
            n = self.shared_build.stats.get("list_entries")
            return None if n is None else int(n)
        got = [self.results[e].meta["stats"].get("list_entries") for e in EYES]
        return None if any(n is None for n in got) else int(sum(got))


class _Shared:
    """The union way's shared CPU stage over the union camera's input `fin`: the structure
    (STRUCTURE) or the cull and sort's keys (CULL_SORT), made again by make() (one timing
    sample each: `ms`)."""

    def __init__(self, technique, fin, opts, share: str):
        self.t, self.fin, self.opts, self.share = technique, fin, opts, share
        self.build, self.keys, self.ms = None, None, []

    def make(self) -> None:
        if self.share == STRUCTURE:
            self.build = self.t.build(self.fin, self.opts)
            self.ms.append(dict(self.build.times.ms))
            return
        times = cpuframe.StageTimes()
        with times.stage("cull"):
            keyed, depth = lightsmod.cull(self.fin.lights, self.fin.camera, self.fin.arena)
        with times.stage("sort"):
            self.keys = lightsmod.sort_ids(keyed, depth, getattr(self.opts, "sort_buckets", 0),
                                           self.fin.arena)
        self.ms.append(times.ms)


class _Eye:
    """A technique as the renderer sees it for one eye of the union way: its own options,
    passes and shaders; its build either the shared structure with this eye's light records
    (STRUCTURE) or its own build from the shared cull and sort (CULL_SORT).  The leading
    eye (the left) makes the shared stage in its build, after its G-buffer as a per-view
    eye builds its own (on a software GL the G-buffer's raster runs on the same cores), so
    that both ways' CPU ms are measured in the same place of the frame."""

    def __init__(self, technique, eye: FrameCamera, shared: _Shared, leads: bool):
        self.t, self.eye, self.shared, self.leads = technique, eye, shared, leads
        self.union = shared.fin.camera
        self.name, self.role, self.summary = technique.name, technique.role, technique.summary
        self.glsl = getattr(technique, "glsl", {})

    def resolve_options(self, opts=None):
        return self.t.resolve_options(opts)

    def build(self, fin, opts):
        if self.leads:
            self.shared.make()
        if self.shared.share == CULL_SORT:
            return self.t.build(replace(fin, presorted=self.shared.keys), opts)
        b = self.shared.build
        times = cpuframe.StageTimes()
        with times.stage("pack"):          # this eye's light records, in the shared order
            pl = lightsmod.pack(fin.lights, fin.camera, b.lights.ids.astype(np.uint64), fin.arena)
            buffers = dict(b.buffers, lights=pl.gpu)
            if "dup_lights" in buffers:
                buffers["dup_lights"] = pl.gpu[b.buffers["entries"]]
        return replace(b, lights=pl, buffers=buffers, times=times, stats=dict(b.stats))

    def passes(self, build, opts):
        steps = self.t.passes(build, opts)
        if self.shared.share == CULL_SORT:
            return steps
        return [_with_union_uniforms(s, self.glsl, self.eye, self.union) for s in steps]


def _with_union_uniforms(step, glsl: dict, eye: FrameCamera, union: FrameCamera):
    """A pass whose shaders declare the union mapping's uniforms (glsl/cells.glsl) with them
    set for this eye; a host step whose further steps get them so (the feature variants'
    shading dispatches); any other step as it is."""
    from .pipeline import features as feat
    from .pipeline.passes import HostStep, Pass
    from .pipeline.validate import declared_uniforms
    if isinstance(step, HostStep):
        run = step.run

        def mapped(got):
            uploads, more = run(got)
            return uploads, [_with_union_uniforms(s, glsl, eye, union) for s in more]
        return replace(step, run=mapped)
    if not isinstance(step, Pass):
        return step
    names = (step.shader,) if isinstance(step.shader, str) else tuple(step.shader)
    virtual = step.files(dict(feat.virtual_files(("point",)), **glsl))
    if "u_union_offset" not in declared_uniforms(names, virtual):
        return step
    return replace(step, uniforms=dict(step.uniforms, u_union_offset=offset_into(union, eye),
                                       u_union_tan=(union.tan_half_x, union.tan_half_y)))


# each renderer's arena for the union camera's shared build: the shared structure outlives
# the renders after it (its eyes', a check's references), which reuse the renderer's own
_UNION_ARENAS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def union_input(renderer, frame: int, frames: int, separation: float):
    """The CPU stage's input over the union camera of `frame`: its lights, the union camera,
    the depth worth slicing moved back with it, an arena of its own (reused frame to frame)."""
    center = renderer.camera(frame, frames)
    union = union_camera(center, separation)
    fin = renderer.frame_input(frame, frames, camera=union)
    arena = _UNION_ARENAS.setdefault(renderer, Arena())
    return replace(fin, arena=arena,
                   max_depth=(renderer.scene.max_depth or center.far) + (union.far - center.far))


def render(renderer, technique, opts, way: str, separation: float, frame: int = 0,
           frames: int = 64, samples: int = 1, readback: bool = True, on_eye=None) -> StereoFrame:
    """Both eyes of `frame` rendered with `technique` in `way` (module docstring); `samples`
    timing samples of each eye and of the shared stage; `on_eye(eye, result)` called after
    each eye's render (the renderer still holds that eye's G-buffer)."""
    def rendered(e, t, **kw):
        r = renderer.render(t, frame, opts, frames, samples=samples, readback=readback, **kw)
        if on_eye is not None:
            on_eye(e, r)
        return r

    opts = technique.resolve_options(opts)
    refuse(technique, opts, way)
    separation = check_separation(separation)
    center = renderer.camera(frame, frames)
    cams = dict(zip(EYES, eye_cameras(center, separation)))
    meta = {"way": way, "separation": separation}
    if way == "per-view":
        results = {e: rendered(e, technique, camera=c) for e, c in cams.items()}
        renders = {e: (technique, {"camera": c}) for e, c in cams.items()}
        return _finish(StereoFrame(way, separation, None, results, renders=renders), meta)
    share = getattr(technique, "stereo_union", CULL_SORT)
    shared = _Shared(technique, union_input(renderer, frame, frames, separation), opts, share)
    defines = {UNION_DEFINE: 1} if share == STRUCTURE else None
    renders = {e: (_Eye(technique, c, shared, leads=e == EYES[0]), {"camera": c, "defines": defines})
               for e, c in cams.items()}
    results = {e: rendered(e, t, **kw) for e, (t, kw) in renders.items()}
    sf = StereoFrame(way, separation, share, results, list(shared.ms), shared.build,
                     tuple(n for n in (shared.build.buffers if shared.build is not None else ())
                           if n not in EYE_BUFFERS), renders)
    meta["share"] = share
    meta["shared_cpu_ms"] = shared.ms[-1]
    return _finish(sf, meta)


def _finish(sf: StereoFrame, meta: dict) -> StereoFrame:
    for e, r in sf.results.items():
        r.meta.update(meta, eye=e)
    return sf


def reference(renderer, separation: float, frame: int = 0, frames: int = 64) -> StereoFrame:
    """The reference technique (brute) rendered per eye: what each eye is held to."""
    from .techniques import with_role
    return render(renderer, with_role("reference"), None, "per-view", separation, frame, frames)


def mismatches(sf: StereoFrame, ref: StereoFrame) -> dict[str, tuple[int, int]]:
    """{eye: (pixels whose contrib_count differs, pixels whose contrib_hash differs)}."""
    from .dump import exactness
    return {e: exactness(sf.results[e], ref.results[e]) for e in EYES}


__all__ = ["VIEWS", "WAYS", "EYES", "DEFAULT_SEPARATION", "UNION_MARGIN", "STRUCTURE", "CULL_SORT",
           "eye_cameras", "union_camera", "pullback", "offset_into", "contains", "inside",
           "frustum_corners", "refusal", "refuse", "render", "reference", "mismatches",
           "StereoFrame", "union_input", "check_separation"]
