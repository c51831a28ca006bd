"""The technique interface: what every culling technique module provides.

    name        id used by capture, the window, the benchmark and the tests
    shader      the shading compute pass (glsl/), 8x8 groups over the image
    prepasses   GPU passes that run before shading (name, shader, output buffers)
    build()     the CPU stage: numpy in, numpy GPU-layout buffers out, timed by stage

The renderer binds every buffer by its name in app.features.BINDINGS.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from cpu_prep import frame as cpuframe, grid as gridmod, limits
from cpu_prep.arena import Arena
from cpu_prep.camera import FrameCamera


@dataclass
class Options:
    """Knobs of the CPU stage and the shaders; every field is recorded in the dump's meta."""
    tile: int = limits.DEFAULT_TILE
    slices: int = limits.DEFAULT_SLICES
    near_slice_depth: float = limits.DEFAULT_NEAR_SLICE_DEPTH
    lights_per_leaf: int = limits.DEFAULT_LIGHTS_PER_LEAF
    max_leaves: int = limits.DEFAULT_MAX_LEAVES
    sort_buckets: int = 0          # 0: exact sort; >0: approximate bucket sort (testbed: 512)
    radius_scale: float = 1.0      # hybrid: cell.radius = radius_scale * half the cell depth
    duplicated: bool = False       # lists hold copies of the light data (paper figure 5)
    native_wave: bool = False      # native subgroup ops where the driver has them

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass
class FrameInput:
    lights: np.ndarray        # scenes LIGHT_DTYPE, world space
    camera: FrameCamera
    max_depth: float
    arena: Arena | None = None   # reuse output arrays across frames (None: fresh arrays)


@dataclass
class Build:
    """What a technique's CPU stage hands the renderer."""
    lights: cpuframe.PreparedLights
    buffers: dict[str, np.ndarray] = field(default_factory=dict)
    uniforms: dict[str, object] = field(default_factory=dict)
    defines: dict[str, object] = field(default_factory=dict)
    times: cpuframe.StageTimes = field(default_factory=cpuframe.StageTimes)
    stats: dict[str, object] = field(default_factory=dict)
    grid: gridmod.Grid | None = None


@dataclass(frozen=True)
class PrePass:
    name: str
    shader: str
    groups: object               # callable(build) -> (x, y, z)
    outputs: object              # callable(build) -> {buffer name: bytes}
    zeroed: tuple[str, ...] = ()  # outputs cleared to zero before the pass


class Technique:
    name: str = ""
    summary: str = ""
    shader: str = ""
    prepasses: tuple[PrePass, ...] = ()
    shader_defines: tuple[str, ...] = ()   # defines this technique's shader declares

    def build(self, frame: FrameInput, opts: Options) -> Build:
        raise NotImplementedError


def grid_uniforms(grid: gridmod.Grid) -> dict[str, object]:
    return {"u_tiles": (grid.tiles_x, grid.tiles_y), "u_tile": grid.tile,
            "u_slices": grid.slices, "u_slice_scale": float(grid.slice_scale),
            "u_slice_bias": float(grid.slice_bias)}


def prepare_binned(frame: FrameInput, opts: Options, slices: int):
    """prepare() plus the grid (slices = 1: 2D tiles) and the CSR binning of the lights."""
    b = prepare(frame, opts)
    cam = frame.camera
    b.grid = gridmod.make_grid(cam, opts.tile, slices, frame.max_depth, opts.near_slice_depth)
    offsets, entries = cpuframe.bin_cells(b.lights, cam, b.grid, b.times, frame.arena)
    b.uniforms.update(grid_uniforms(b.grid))
    b.stats["cells"] = b.grid.cells
    return b, offsets, entries


def prepare(frame: FrameInput, opts: Options) -> Build:
    """The steps every technique shares: cull, sort, pack the visible lights."""
    times = cpuframe.StageTimes()
    pl = cpuframe.prepare_lights(frame.lights, frame.camera, times, opts.sort_buckets, frame.arena)
    b = Build(lights=pl, times=times)
    b.buffers["lights"] = pl.gpu
    b.buffers["bounds"] = pl.bounds
    b.stats["visible_lights"] = len(pl.gpu)
    return b
