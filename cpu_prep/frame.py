"""The CPU stage of one frame, as timed steps shared by every technique (tree paper 4.1:
cull, sort, bin, build, pack; upload is timed by the app).

    prepare_lights():  view transform + frustum cull  ->  depth sort  ->  GPU_LIGHT / GPU_BOUND
    bin_cells():       conservative cell boxes -> CSR per-cell lists (depth-sorted)
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
import time

import numpy as np

from . import bounds, grid as gridmod, lights as lightsmod
from .camera import FrameCamera
from .limits import MAX_STORAGE_BYTES, LimitError


@dataclass
class StageTimes:
    ms: dict[str, float] = field(default_factory=dict)

    @contextmanager
    def stage(self, name: str):
        t0 = time.perf_counter()
        yield
        self.ms[name] = self.ms.get(name, 0.0) + (time.perf_counter() - t0) * 1e3


@dataclass
class PreparedLights:
    view: lightsmod.ViewLights   # visible lights, depth-sorted
    gpu: np.ndarray              # GPU_LIGHT, same order
    bounds: np.ndarray           # GPU_BOUND, same order
    depth_lo: np.ndarray         # float32, rounded down: conservative depth range per light
    depth_hi: np.ndarray         # float32, rounded up


def prepare_lights(scene_lights: np.ndarray, cam: FrameCamera, times: StageTimes,
                   sort_buckets: int = 0) -> PreparedLights:
    with times.stage("cull"):
        vl = lightsmod.view_lights(scene_lights, cam)
        vl = vl.take(lightsmod.frustum_cull(vl, cam))
    with times.stage("sort"):
        vl = vl.take(lightsmod.depth_sort(vl.depth, sort_buckets))
    with times.stage("pack"):
        gpu, bnd = lightsmod.pack_lights(vl)
        lo, hi = vl.depth_range
        # round outwards to float32 so the GPU's float32 depth comparisons stay conservative
        lo32 = np.nextafter(lo.astype(np.float32), np.float32(-np.inf))
        hi32 = np.nextafter(hi.astype(np.float32), np.float32(np.inf))
    return PreparedLights(vl, gpu, bnd, lo32, hi32)


def bin_cells(pl: PreparedLights, cam: FrameCamera, grid: gridmod.Grid, times: StageTimes):
    """CSR (offsets, entries) of the depth-sorted visible lights over the grid's cells."""
    with times.stage("bin"):
        rect = bounds.screen_rects(pl.view.center, pl.view.bound_radius, cam)
        lo, hi = pl.view.depth_range
        boxes = gridmod.cell_boxes(grid, rect, lo, hi)
        offsets, entries = gridmod.scatter(grid, boxes)
    check_buffer("light index list", entries.nbytes)
    return offsets, entries


def check_buffer(name: str, nbytes: int) -> None:
    if nbytes > MAX_STORAGE_BYTES:
        raise LimitError(f"{name} needs {nbytes / 2**20:.0f} MiB, over the "
                         f"{MAX_STORAGE_BYTES >> 20} MiB storage-block limit")
