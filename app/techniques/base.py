"""The technique interface: what every culling technique module provides.

    name          id used by capture, the window, the benchmark and the tests
    summary       one line for --list and the report
    role          "technique"; "reference" (brute: the exactness check's reference),
                  "floor" (perfect: the shading floor no technique can beat) or "sampler"
                  (a fixed budget of light samples a pixel, unbiased: app.sampling_check)
    Options       its own frozen dataclass of declared options (app.techniques.options)
    views         the window's views it has (app.views): every technique has shaded,
                  heat, diff and split; one with that structure adds tiles, slices, classes
    glsl          shader texts of its own by file name, beside glsl/: its structs and
                  constants generated from Python (fptl_structs.glsl); usually empty
    evaluates_per_wave  per-pixel `evaluated` depends on the wave width (scalarized loops)
    stereo_union  what `--views stereo --stereo-way union` shares between the eyes
                  (app.stereo): "structure" (a 2.5D grid: the structure itself) or
                  "cull-sort" (the default: only the CPU cull and sort)
    maps()        optional per-tile or per-pixel maps of its own structure for a rendered
                  frame (capture --maps, the report's technique maps)
    refusal()     why it would refuse a frame (a limit its build meets), from counts and
                  options alone: the window's probe asks before building
    build()       the CPU stage: numpy in, GPU-layout arrays out, timed by step
    passes()      its GPU passes in order, the shading pass last (app.pipeline.passes)

Beside its frame (the folder's __init__.py, which never imports app.model) a technique's
folder may hold (found by app.techniques.parts, not imported by the frame):

    replay.py     wave_program(technique, frame, width): its shading pass as the wave
                  replay's segments over the frame's own buffers (app.model.waves), and
                  optionally cull_figures(technique, frame, width): the passes before it
    paper.py      report_notes(technique, rows): its paper's figures beside a benchmark
                  run's (app.report.notes); none without it
    *.comp, ...   its own shaders (app.pipeline.shaders looks there, then in glsl/)

A technique is one folder under app/techniques/ and nothing else: its class registers one
instance, at its place in the registry, when its package is imported,

    class Tiled(Technique, register_at=20): ...

and the package imports every module and folder it holds (app/techniques/__init__.py), so the
renderer, capture, window, benchmark, report and registry need no edit for it.  The
registry's order (register_at: brute 10 ... perfect 90) is the order reports and tests
list the techniques in.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import (caps, frame as cpuframe, grid as gridmod, layouts, lights as lightsmod,
                      limits, stochastic as stochmod)

from ..errors import UserError
from ..pipeline.passes import Build, FrameInput, Pass, frame_outputs, image_groups
from .options import TechniqueOptions, cap_policy, stochastic

ROLES = ("technique", "reference", "floor", "sampler")

# Technique.transparent: a structure of the lights alone serves a transparent fragment's
# view-space point as it serves the opaque surface's; one bounded by the depth its GPU passes
# read is built again over each layer's fragments (app/pipeline/transparent.py).
TRANSPARENT_LOOKUP = ("served by lookup: its structure, built from the lights alone, holds "
                      "any view-space point, and each layer's fragments read their own cells "
                      "of it (the CPU build is not redone).")
TRANSPARENT_REBUILT = ("built again per layer: {what} made by GPU passes from the G-buffer "
                       "they read, so those passes run again over each layer's fragments before "
                       "it is shaded (a tile's depth range is then its layer's fragments', so a "
                       "pane nearer than the tile's opaque minimum depth lies inside it).")

# The one registry: capture, the window, the benchmark, the report and the tests iterate it.
REGISTRY: dict[str, "Technique"] = {}
_PLACES: dict[str, float] = {}      # name -> register_at (techniques registered by hand: last)


def register(technique: "Technique", at: float = float("inf")) -> "Technique":
    """Add a technique (its name unique, its role known) at its place `at` in the
    registry's order (ties and unplaced ones in registration order); returns it."""
    if not technique.name or technique.name in REGISTRY:
        raise ValueError(f"technique name {technique.name!r} is empty or taken")
    if technique.role not in ROLES:
        raise ValueError(f"technique {technique.name}: role {technique.role!r} not in {ROLES}")
    REGISTRY[technique.name] = technique
    _PLACES[technique.name] = at
    ordered = sorted(REGISTRY.items(), key=lambda kv: _PLACES[kv[0]])     # stable
    REGISTRY.clear()
    REGISTRY.update(ordered)
    return technique


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)
    _PLACES.pop(name, None)


class Technique:
    name: str = ""
    summary: str = ""
    role: str = "technique"
    Options: type[TechniqueOptions] = TechniqueOptions
    # shader texts of its own by file name, e.g. its structs generated from their dtypes
    glsl: dict[str, str] = {}
    views: tuple[str, ...] = ("shaded", "heat", "diff", "split")
    # A scalarized loop evaluates the union of its wave's lights: per-pixel `evaluated`
    # then depends on the wave width (native subgroup or emulated 64-lane group); counts,
    # hashes and images never do (tests compare `evaluated` across widths only without it).
    evaluates_per_wave: bool = False
    # How it shades the transparent layers (app/pipeline/transparent.py: its steps run again
    # over each layer's fragments): docs/techniques.md's "Transparent layers" line.
    transparent: str = TRANSPARENT_LOOKUP
    # What stereo's union way (app.stereo) shares between the two eyes: "structure" (the
    # culling structure itself, built once over the union camera's frustum; each eye's
    # shading maps its pixels into the union camera's cells, STEREO_UNION in
    # glsl/cells.glsl) or "cull-sort" (a structure made per pixel of a view, e.g. screen
    # tiles: only the CPU cull and sort are shared, the rest is built per eye)
    stereo_union: str = "cull-sort"
    # How it serves a fog scene's froxels (app/pipeline/fog.py FROXEL_SOURCES: "all",
    # "cells", "trees"); None: it refuses a fog scene in one line.
    froxels: str | None = None

    def __init_subclass__(cls, register_at: float | None = None, **kw) -> None:
        """`class X(Technique, register_at=N)`: one instance of X joins the registry at
        place N when its module is imported (a subclass without it, e.g. a test's, does not)."""
        super().__init_subclass__(**kw)
        if register_at is not None:
            register(cls(), register_at)

    def resolve_options(self, opts=None) -> TechniqueOptions:
        """This technique's Options from None (defaults), a dict {name: value} (checked,
        unknown names an error) or an Options instance of this technique."""
        if opts is None:
            return self.Options()
        if isinstance(opts, dict):
            return self.Options.make(opts, self.name)
        if type(opts) is not self.Options:
            raise TypeError(f"{self.name}: options of type {type(opts).__name__}, "
                            f"expected {self.name}'s own ({self.Options.__qualname__})")
        return opts

    def maps(self, result, read) -> dict[str, tuple[np.ndarray, str]]:
        """{name: (2D array in image order, what a value counts)} of this technique's own
        structure for a rendered frame (`read(name)`: a buffer of that frame read back)."""
        return {}

    def refusal(self, frame: FrameInput, opts, visible: int) -> str | None:
        """Why this technique refuses `frame` with `opts` when `visible` lights pass the cull
        (visible_lights()), in the one line its build raises, else None: from counts and
        options alone, no build, so the window's probe leaves a refusing technique out
        unbuilt.  Every technique meets the light rows' limit (light_rows_refusal); one with
        limits of its own adds them here and its build raises them through refuse().  A fog
        scene's frame (frame.fog) also meets whether it serves froxels (pipeline/fog.py)."""
        rows = light_rows_refusal(frame, opts, visible)
        if rows or getattr(frame, "fog", None) is None:
            return rows
        from ..pipeline.fog import refusal as fog_refusal
        return fog_refusal(self, opts)

    def build(self, frame: FrameInput, opts) -> Build:
        raise NotImplementedError

    def passes(self, build: Build, opts) -> list:
        raise NotImplementedError


# ---- refusals: the limits a frame meets, asked before and in the build --------------------

def visible_lights(frame: FrameInput, opts=None) -> int:
    """How many lights prepare() packs for `frame` with `opts`, counted without sorting or
    packing them: the stochastic draw's survivors (if on) through the cull, then the cap
    policy's (tests hold it to len(prepare().lights)); the GPU build culls the same ones."""
    lights, drawn = frame.lights, stochastic(opts)
    if drawn is not None:
        lights, _, _ = stochastic_ranges(frame, *drawn)
    keyed, depth = lightsmod.cull(lights, frame.camera, frame.arena)
    keyed, _, _ = caps.apply(cap_policy(opts), lights, frame.camera.view_from_world, keyed, depth)
    return len(keyed)


def light_rows_refusal(frame: FrameInput, opts, visible: int) -> str | None:
    """The limit every build meets first, in its own words: the rows of the visible lights,
    checked where the options build them (BuildOptions.check_light_rows: --build gpu's
    scene records and rows), else in the CPU stage (check_cpu_light_rows)."""
    own = getattr(opts, "check_light_rows", None)
    try:
        if own is not None:
            own(frame, visible)
        else:
            check_cpu_light_rows(visible)
    except limits.LimitError as exc:
        return str(exc)
    return None


def check_cpu_light_rows(visible: int) -> None:
    """The CPU stage's light buffer check (cpu_prep.frame.prepare_capped_lights': `visible`
    GPU_LIGHT rows through check_buffer), before the lights are packed."""
    limits.check_buffer("light buffer", visible * layouts.GPU_LIGHT.itemsize)


def refuse(technique: Technique, frame: FrameInput, opts, visible: int) -> None:
    """The build's side of technique.refusal(): its line as a UserError."""
    why = technique.refusal(frame, opts, visible)
    if why:
        raise UserError(why)


# ---- steps and passes several techniques share ------------------------------------------

def prepare(frame: FrameInput, sort_buckets: int = 0, opts=None) -> Build:
    """The steps every technique shares: cull, sort, pack the visible lights.  Options
    with a cap policy (options.CapOptions, not none) drop lights after the cull, as that
    engine does (cpu_prep.caps): the frame differs from brute on purpose, and its stats
    say so (cap_policy, capped_lights; the dropped scene ids in Build.capped_ids, which
    the exactness check reads).  Options with stochastic culling on (options.StochasticOptions)
    draw each light's range first (stochastic_ranges), so every structure is built from it,
    and write each light's alpha into its GPU record (right.w) for the shading's 1/p weight;
    the stats say stochastic_t, _seed, _frame and _dark_lights (reaching nothing this frame)."""
    times = cpuframe.StageTimes()
    policy = cap_policy(opts)
    lights, alpha, drawn = frame.lights, None, stochastic(opts)
    if drawn is not None:
        with times.stage("cull"):          # the range draw: part of the cull step
            lights, alpha, dark = stochastic_ranges(frame, *drawn)
    if getattr(frame, "presorted", None) is not None:   # cull and sort made before (app.stereo)
        pl, dropped = stereo_pack(frame, times), np.zeros(0, np.uint32)
    else:
        pl, dropped = cpuframe.prepare_capped_lights(lights, frame.camera, times, sort_buckets,
                                                     frame.arena, policy)
    if alpha is not None:
        pl.gpu["right"][:, 3] = alpha[pl.ids]        # read by glsl/light_window.glsl lambert
    b = Build(frame=frame, lights=pl, times=times)
    b.buffers["lights"] = pl.gpu
    b.stats["visible_lights"] = len(pl.gpu)
    if drawn is not None:
        b.stats.update(stochastic_t=1.0 / drawn[0], stochastic_seed=drawn[1],
                       stochastic_frame=drawn[2], stochastic_dark_lights=len(dark))
    if policy != caps.NONE:
        b.stats.update(cap_policy=policy, capped_lights=len(dropped))
        b.capped_ids = dropped
    return b


def stereo_pack(frame: FrameInput, times) -> "cpuframe.PreparedLights":
    """The pack step alone, of the lights `frame.presorted` (culled and sorted for a wider
    camera: app.stereo's union of two eyes) in this frame's camera; no cap policy or
    stochastic draw applies (app.stereo refuses them)."""
    with times.stage("pack"):
        pl = lightsmod.pack(frame.lights, frame.camera, frame.presorted, frame.arena)
    cpuframe.check_buffer("light buffer", pl.gpu.nbytes)
    return pl


def stochastic_ranges(frame: FrameInput, budget: int, seed: int, draw_frame: int):
    """(lights, alpha, dark ids): the frame's lights with their stochastic ranges at budget
    t = 1/budget for (seed, frame) (cpu_prep.stochastic); the lights that reach nothing this
    frame culled with their ids kept (caps.without), so scene ids, hashes and draws stay."""
    view = np.asarray(frame.camera.view_from_world, np.float64)
    eye = np.linalg.inv(view)[:3, 3]
    lights, alpha, dark = stochmod.stochastic_lights(frame.lights, 1.0 / budget, seed, draw_frame,
                                                     eye, frame.camera.far)
    if len(dark):
        lights = caps.without(lights, dark, view, copy=False)    # stochastic_lights' own copy
    return lights, alpha, dark


def grid_uniforms(grid: gridmod.Grid) -> dict[str, object]:
    return {"u_tiles": (grid.tiles_x, grid.tiles_y), "u_tile": grid.tile,
            "u_slices": grid.slices, "u_slice_scale": float(grid.slice_scale),
            "u_slice_bias": float(grid.slice_bias)}


def make_grid(frame: FrameInput, opts, slices: int) -> gridmod.Grid:
    """The technique's grid: its tile option, `slices` depth slices (1: 2D tiles)."""
    near = getattr(opts, "near_slice_depth", limits.DEFAULT_NEAR_SLICE_DEPTH)
    return gridmod.make_grid(frame.camera, opts.tile, slices, frame.max_depth, near)


def prepare_binned(frame: FrameInput, opts, slices: int, sort_buckets: int = 0):
    """prepare() plus the grid and the CSR binning of the lights over its cells."""
    b = prepare(frame, sort_buckets, opts)
    b.grid = make_grid(frame, opts, slices)
    offsets, entries = cpuframe.bin_cells(b.lights, frame.camera, b.grid, b.times, frame.arena)
    b.stats["cells"] = b.grid.cells
    return b, offsets, entries


def windows(frame: FrameInput, longest: int, steps: int = 1) -> list[tuple[int, int]]:
    """Dispatch windows [lo, hi) of a pass whose pixels meet at most `longest` lights: one
    window on a driver without a loop limit, else windows of limits.DISPATCH_WINDOW lights
    (glsl/pixel.glsl: the same lights in the same order, carried over between dispatches).
    `steps`: the inner loops a lane's lights may be split over (a tree traversal: one per
    leaf it hits).  The driver counts its lockstep lanes' iterations together, and lanes
    whose inner loops run at different steps add up, so such a pass's windows shrink by
    min(steps, frame.loop_lanes): every lane's in-window part summed stays in the budget."""
    size = limits.DISPATCH_WINDOW // max(1, min(int(steps), frame.loop_lanes))
    if frame.loop_budget is None or longest <= size:
        return [(0, limits.WINDOW_ALL)]
    k = -(-int(longest) // size)
    return [(i * size, (i + 1) * size if i < k - 1 else limits.WINDOW_ALL) for i in range(k)]


def shading_pass(build: Build, shader: str, reads: tuple[str, ...] = (), defines=None,
                 uniforms=None, native_wave: bool = False, name: str = "shade",
                 groups=None, waves_cleared: bool = True, **kw) -> Pass:
    """The technique's shading pass: one 8x8 group per image block (or `groups`), reading
    the lights and `reads`, writing the frame's outputs (colour, per-pixel counters, wave
    statistics)."""
    w, h = build.frame.size
    return Pass(name, shader, reads=("lights",) + tuple(reads),
                writes=frame_outputs(w, h, waves_cleared), groups=groups or image_groups(w, h),
                defines=dict(defines or {}), uniforms=dict(uniforms or {}),
                native_wave=native_wave, **kw)


def shading_passes(build: Build, shader: str, reads: tuple[str, ...] = (), longest: int = 0,
                   uniforms=None, waves_cleared: bool = True, steps: int = 1, **kw) -> list[Pass]:
    """shading_pass() as one dispatch per window of `longest` (the most lights a pixel's
    loops can meet; `steps`: windows()'); later windows carry the earlier ones' outputs over."""
    return [shading_pass(build, shader, reads, uniforms=dict(uniforms or {}, u_window=win),
                         waves_cleared=waves_cleared and k == 0, **kw)
            for k, win in enumerate(windows(build.frame, longest, steps))]
