"""The frame graph's vocabulary: what a technique (or the frame itself) declares, and what
the renderer executes from those declarations alone.

    FrameInput --technique.build()--> Build (numpy arrays, CPU stage timed by step)
    Build --technique.passes()--> [Pass | HostStep, ...]   (the shading pass last)

A Pass is one GPU step: a compute dispatch or a raster draw, its shader and defines, the
buffers it reads and the buffers it writes (size, element struct, cleared before the pass
or not), and whether it is timed.  Binding points are not written anywhere: the renderer
numbers the buffers a pass declares, per program, and defines `B_<SLOT>` for each; a shader
that binds a buffer its pass did not declare fails to compile with one line naming the
pass, the buffer and the file.

A compute pass may dispatch indirectly (`indirect`): its group counts are read at dispatch
time from a buffer an earlier pass wrote (glDispatchComputeIndirect), e.g. one feature
variant's tiles counted on the GPU (app/techniques/variants.py); `groups` is then the most
it may dispatch, which the frame graph checks against the driver's limit.  A pass may also
bring generated files of its own (`virtual`, over the frame's), e.g. the features.glsl of
its variant.

A HostStep runs on the CPU between passes (untimed): it reads buffers back and returns
arrays to upload and further steps to run (the perfect culler plans its bands this way).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, layouts
from cpu_prep.arena import Arena
from cpu_prep.camera import FrameCamera

if TYPE_CHECKING:                 # the CPU stage's users (bench cpu) load no GL
    from .gl import Limits

# The frame's outputs, written by every technique's shading pass and read back by capture,
# the benchmark and the window: per pixel (GL row order) and per 8x8 group.
OUT_COLOR, OUT_STATS, WAVE_STATS = "out_color", "out_stats", "wave_stats"
# out_cell: per pixel, the cell of its technique's structure that the shading pass read (a
# tile, a 2.5D cell, a z-bin): the key of the wave replay (app.model.waves), so that the
# replay never re-derives a pixel's cell from floats the GPU rounds differently
OUT_CELL = "out_cell"
FRAME_OUTPUTS = (OUT_COLOR, OUT_STATS, WAVE_STATS, OUT_CELL)
WAVE_DIM = 8          # one emulated 64-lane wave = one 8x8 group (cpu_prep.limits.WAVE_DIM)


@dataclass
class FrameInput:
    """What the CPU stage of a frame sees: world-space lights, the camera, the depth worth
    slicing, and the arena its outputs reuse from frame to frame (None: fresh arrays)."""
    lights: np.ndarray        # scenes LIGHT_DTYPE, world space
    camera: FrameCamera
    max_depth: float
    arena: Arena | None = None
    loop_budget: int | None = None   # the driver's loop limit per invocation (None: none)
    loop_lanes: int = 1              # ... shared by this many lanes in lockstep (gl.Limits)
    context_limits: Limits | None = None   # the renderer's; None: the process's, on use
    specular: bool = False           # some surface of the scene is specular (features.py)
    # the visible lights already culled and sorted (cpu_prep.lights.sort_ids' keys) for this
    # frame, e.g. over the union of two eyes' frusta (app.stereo): prepare() packs them only
    presorted: np.ndarray | None = None
    fog: object | None = None        # the scene's medium (scenes.model.Fog; app/pipeline/fog.py)

    @property
    def limits(self) -> Limits:
        """The GL limits the frame renders under (e.g. sample_positions for MSAA culling);
        a CPU-only frame reads them, and so makes the context, only if it asks."""
        from . import gl
        return self.context_limits or gl.limits()

    @property
    def size(self) -> tuple[int, int]:
        return self.camera.width, self.camera.height


@dataclass
class Build:
    """What a technique's CPU stage hands the renderer: arrays to upload (by buffer name),
    the visible lights, timings by step, figures for the meta, the grid, and what its passes
    read: `longest_list` (the longest cell list of a CSR binning, a windowed loop's bound;
    None until a GPU build has read it back), `bin_scale` (the Z-bin LUT's depth scale,
    zbin's and raster's), `own` (the technique's own frozen dataclass, e.g. fptl.FptlData).
    `steps`: a build made on the GPU (app/gpu_build) brings its passes, ending in the
    technique's, which the renderer runs in place of technique.passes(); `capped_ids`: the
    scene ids of the lights a cap policy dropped (None: no cap), which the exactness check
    renders without."""
    frame: FrameInput
    lights: cpuframe.PreparedLights
    buffers: dict[str, np.ndarray] = field(default_factory=dict)
    times: cpuframe.StageTimes = field(default_factory=cpuframe.StageTimes)
    stats: dict[str, object] = field(default_factory=dict)
    grid: gridmod.Grid | None = None
    longest_list: int | None = None
    bin_scale: float = 0.0
    own: object | None = None
    steps: list | None = None
    capped_ids: np.ndarray | None = None


@dataclass(frozen=True)
class Buffer:
    """A buffer a pass writes: its size, the struct of its elements (a cpu_prep.layouts
    dtype; None: uint32 words) and whether it is zeroed before the pass."""
    nbytes: int
    struct: np.dtype | None = None
    cleared: bool = False


@dataclass(frozen=True)
class Target:
    """A depth (+ stencil) render target a technique owns, kept by the renderer by name and
    resized with the frame: the frame's size divided by `scale` (rounded up), `samples` per
    pixel (0: single-sampled), with an 8-bit stencil or without.  What a pass draws into it
    persists for the later passes of the frame (a pass fills it, later ones test against
    it); at the frame's start its contents are undefined."""
    name: str
    scale: int = 1
    samples: int = 0
    stencil: bool = False


@dataclass(frozen=True)
class StencilStep:
    """One draw of a per-instance stencil sequence (Draw.stencil): its face culling, depth
    test, stencil test (func against ref) and the stencil ops on stencil fail / depth fail /
    depth pass ("keep" | "zero" | "replace").  ref 0 means: the instance's own reference,
    instance % 255 + 1 (so successive instances need no clear between them)."""
    cull: str | None = None
    depth_test: str | None = None
    func: str = "always"                  # "always" | "equal" | "notequal"
    ref: int = 0
    ops: tuple[str, str, str] = ("keep", "keep", "keep")


# Draw's names for moderngl's depth functions and primitive modes (GL enums, which
# moderngl's constants are)
DEPTH_FUNCS = {"less": "<", "less_equal": "<=", "greater": ">", "greater_equal": ">=",
               "always": "1"}
DRAW_MODES = {"triangles": 0x0004, "triangle_strip": 0x0005}     # GL_TRIANGLES, GL_TRIANGLE_STRIP


@dataclass(frozen=True)
class Draw:
    """A raster pass's draw.  Vertex attributes come from `vertices` ((V, n) float32, laid
    out by `format`, named by `attributes`), or from gl_VertexID alone (vertices None).

    target: "gbuffer"        the G-buffer's colour targets and depth
            "gbuffer_depth"  the G-buffer's depth only (test it; colour writes go nowhere)
            "none"           no colour or depth target, only storage writes (frame size)
            a Target         the technique's own depth (+ stencil) target (MSAA, scaled)
            a moderngl Framebuffer (the window's screen)
    stencil: a per-instance sequence: for each instance in turn, one draw per StencilStep
             (its cull and depth test replace the Draw's), the uniforms u_instance (the
             instance; gl_InstanceID is 0) and u_step (the step) set for each; with the
             stencil test on.  Empty: one instanced draw, no stencil test."""
    vertices: np.ndarray | None = None
    format: str = ""
    attributes: tuple[str, ...] = ()
    count: int | None = None              # vertices per instance (default: all of them)
    instances: int = 1
    mode: str = "triangles"               # "triangles" | "triangle_strip"
    target: object = "none"
    depth_test: str | None = None         # "less" | "less_equal" | "greater" | "greater_equal" | "always" | None
    depth_write: bool = False
    cull: str | None = None               # "back" | "front" | None
    clear: bool = False
    blend: bool = False
    viewport: tuple[int, int, int, int] | None = None   # default: the whole target
    stencil: tuple[StencilStep, ...] = ()


@dataclass(frozen=True)
class Pass:
    """One GPU step.  `reads` and `writes` name the shader's buffer slots (its B_<SLOT>
    bindings); `sources` backs a slot with a differently named frame buffer (e.g. one band's
    list).  Compute passes give `groups`, raster passes a `draw`."""
    name: str
    shader: str | tuple[str, str]                  # compute file, or (vertex, fragment)
    reads: tuple[str, ...] = ()
    writes: Mapping[str, Buffer] = field(default_factory=dict)
    groups: tuple[int, int, int] | None = None
    draw: Draw | None = None
    defines: Mapping[str, object] = field(default_factory=dict)
    uniforms: Mapping[str, object] = field(default_factory=dict)
    timed: bool = True
    native_wave: bool = False                      # ask for native subgroup ops (WAVE_NATIVE)
    sources: Mapping[str, str] = field(default_factory=dict)
    figures: bool = False                          # only counts figures (see HostStep)
    # (buffer, byte offset) of three uint group counts (DispatchIndirectCommand) read at
    # dispatch time; `groups` is then the most it can dispatch
    indirect: tuple[str, int] | None = None
    virtual: Mapping[str, str] = field(default_factory=dict)   # generated files over the frame's

    def __post_init__(self):
        if (self.groups is None) == (self.draw is None):
            raise ValueError(f"pass '{self.name}': give exactly one of groups (compute) or draw (raster)")
        clash = set(self.reads) & set(self.writes)
        if clash:
            raise ValueError(f"pass '{self.name}': {sorted(clash)} both read and written: "
                             f"declare a read-modify-write buffer in writes only")
        if self.indirect is not None and self.draw is not None:
            raise ValueError(f"pass '{self.name}': only a compute pass dispatches indirectly")

    @property
    def kind(self) -> str:
        return "compute" if self.draw is None else "raster"

    def slots(self) -> tuple[str, ...]:
        return tuple(self.reads) + tuple(self.writes)

    def buffer_of(self, slot: str) -> str:
        return self.sources.get(slot, slot)

    def files(self, virtual: Mapping[str, str]) -> dict[str, str]:
        """The generated files this pass compiles with: the frame's, then its own."""
        return dict(virtual, **self.virtual) if self.virtual else dict(virtual)


@dataclass(frozen=True)
class HostStep:
    """A CPU step between passes (untimed): `run({buffer: array read back})` returns
    ({buffer: array to upload}, [further Pass | HostStep to run next])."""
    name: str
    reads: tuple[str, ...]
    run: Callable[[dict[str, np.ndarray]], tuple[dict[str, np.ndarray], list]]
    figures: bool = False                          # only counts figures (see HostStep)


# A step with figures=True only adds figures (meta stats, per-tile counts) and feeds nothing
# the frame's image or counters need: the renderer runs it only when the caller wants the
# frame's figures (render(figures=...), by default when it reads the frame back), not on the
# window's frames or the benchmark's timing samples.


def frame_outputs(width: int, height: int, waves_cleared: bool = True) -> dict[str, Buffer]:
    """The writes every shading pass declares: colour, counters and the cell read per pixel,
    wave statistics per 8x8 group (zeroed: the shaders accumulate them with atomics, unless
    a pass stores them and says waves_cleared=False)."""
    groups = -(-width // WAVE_DIM) * -(-height // WAVE_DIM)
    return {OUT_COLOR: Buffer(width * height * 16, np.dtype((np.float32, 4))),
            OUT_STATS: Buffer(width * height * layouts.PIXEL_STATS.itemsize, layouts.PIXEL_STATS),
            OUT_CELL: Buffer(width * height * 4, np.dtype(np.uint32)),
            WAVE_STATS: Buffer(groups * layouts.WAVE_STATS.itemsize, layouts.WAVE_STATS,
                               cleared=waves_cleared)}


def image_groups(width: int, height: int) -> tuple[int, int, int]:
    """Dispatch of one 8x8 group per image block."""
    return -(-width // WAVE_DIM), -(-height // WAVE_DIM), 1
