"""The CPU stage of one frame, as timed steps shared by every technique (tree paper 4.1:
cull, sort, bin, build, pack; upload is timed by the app).

    prepare_lights():  view transform + frustum cull -> depth sort -> GPU_LIGHT / GPU_BOUND
    bin_cells():       conservative cell boxes -> CSR per-cell lists (depth-sorted)
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
import time

import numpy as np

from . import grid as gridmod, lights as lightsmod
from .arena import Arena
from .camera import FrameCamera
from .lights import PreparedLights
from .limits import MAX_STORAGE_BYTES, LimitError

__all__ = ["StageTimes", "PreparedLights", "prepare_lights", "bin_cells", "check_buffer"]


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
    with times.stage("cull"):
        rows, spheres, shapes = lightsmod.view_and_cull(scene_lights, cam, arena)
    with times.stage("sort"):
        order = lightsmod.depth_order(-spheres[:, 2], sort_buckets)
    with times.stage("pack"):
        pl = lightsmod.pack(rows, spheres, shapes, order, arena)
    check_buffer("light buffer", pl.gpu.nbytes)
    return pl


def bin_cells(pl: PreparedLights, cam: FrameCamera, grid: gridmod.Grid, times: StageTimes,
              arena: Arena | None = None):
    """CSR (offsets, entries) of the depth-sorted visible lights over the grid's cells."""
    with times.stage("bin"):
        boxes = gridmod.rect_boxes(grid, pl.rect, pl.depth_lo, pl.depth_hi, arena)
        offsets, entries = gridmod.scatter(grid, boxes, arena)
    check_buffer("light index list", entries.nbytes)
    return offsets, entries


def check_buffer(name: str, nbytes: int) -> None:
    if nbytes > MAX_STORAGE_BYTES:
        raise LimitError(f"{name} needs {nbytes / 2**20:.0f} MiB, over the "
                         f"{MAX_STORAGE_BYTES >> 20} MiB storage-block limit")
