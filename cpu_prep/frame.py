"""The CPU stage of one frame, as timed steps shared by every technique (tree paper 4.1:
cull, sort, bin, build, pack; upload is timed by the app).

    prepare_lights():  view transform + frustum cull -> depth sort -> GPU_LIGHT / GPU_BOUND
    prepare_capped_lights():  the same with an engine's view-level light cap after the cull
    bin_cells():       conservative cell boxes -> CSR per-cell lists (depth-sorted)
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
import time

import numpy as np

from . import caps, grid as gridmod, lights as lightsmod
from .arena import Arena
from .camera import FrameCamera
from .lights import PreparedLights
from .limits import check_buffer

__all__ = ["StageTimes", "PreparedLights", "prepare_lights", "prepare_capped_lights", "bin_cells",
           "check_buffer"]


@dataclass
class StageTimes:
    ms: dict[str, float] = field(default_factory=dict)

    @contextmanager
    def stage(self, name: str):
        t0 = time.perf_counter()
        yield
        self.ms[name] = self.ms.get(name, 0.0) + (time.perf_counter() - t0) * 1e3


def prepare_lights(scene_lights: np.ndarray, cam: FrameCamera, times: StageTimes,
                   sort_buckets: int = 0, arena: Arena | None = None) -> PreparedLights:
    return prepare_capped_lights(scene_lights, cam, times, sort_buckets, arena)[0]


def prepare_capped_lights(scene_lights: np.ndarray, cam: FrameCamera, times: StageTimes,
                          sort_buckets: int = 0, arena: Arena | None = None,
                          cap_policy: str = caps.NONE):
    """(PreparedLights, dropped scene ids uint32): prepare_lights() with the cap policy
    `cap_policy` (cpu_prep.caps) choosing among the visible lights before the sort, timed
    with the cull; caps.NONE drops nothing."""
    with times.stage("cull"):
        keyed, depth = lightsmod.cull(scene_lights, cam, arena)
        keyed, depth, dropped = caps.apply(cap_policy, scene_lights, cam.view_from_world,
                                           keyed, depth)
    with times.stage("sort"):
        keys = lightsmod.sort_ids(keyed, depth, sort_buckets, arena)
    with times.stage("pack"):
        pl = lightsmod.pack(scene_lights, cam, keys, arena)
    check_buffer("light buffer", pl.gpu.nbytes)
    return pl, dropped


def bin_cells(pl: PreparedLights, cam: FrameCamera, grid: gridmod.Grid, times: StageTimes,
              arena: Arena | None = None):
    """CSR (offsets, entries) of the depth-sorted visible lights over the grid's cells."""
    with times.stage("bin"):
        offsets, entries, _ = gridmod.bin_rects(grid, pl.rect, pl.depth_lo, pl.depth_hi, arena)
    return offsets, entries

