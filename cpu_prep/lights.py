"""Per-frame light preparation: view transform, frustum cull, depth sort, GPU packing.

    scene lights (LIGHT_DTYPE, world)  --view_lights-->  ViewLights (float32 view space)
      --frustum_cull--> visible ids --depth_sort--> order --pack_lights--> GPU_LIGHT[], GPU_BOUND[]
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bounds, layouts
from .camera import FrameCamera
from .limits import PIXEL_MARGIN, RADIUS_REL_MARGIN

SPOT = 1


@dataclass
class ViewLights:
    """Lights in view space, float32 as the GPU will see them, plus float64 culling spheres."""
    ids: np.ndarray          # (N,) uint32 light id (scene order)
    type: np.ndarray         # (N,) uint8
    pos: np.ndarray          # (N,3) float32
    radius: np.ndarray       # (N,) float32
    direction: np.ndarray    # (N,3) float32
    color: np.ndarray        # (N,3) float32 (color * intensity)
    cos_inner: np.ndarray
    cos_outer: np.ndarray
    center: np.ndarray       # (N,3) float64 culling sphere, margins included
    bound_radius: np.ndarray # (N,) float64

    def __len__(self):
        return len(self.ids)

    def take(self, idx) -> "ViewLights":
        return ViewLights(**{k: v[idx] for k, v in self.__dict__.items()})

    @property
    def depth(self) -> np.ndarray:
        """Depth (distance to the camera plane) of each culling sphere's centre."""
        return -self.center[:, 2]

    @property
    def depth_range(self) -> tuple[np.ndarray, np.ndarray]:
        return self.depth - self.bound_radius, self.depth + self.bound_radius


def view_lights(lights: np.ndarray, cam: FrameCamera) -> ViewLights:
    m = cam.view_from_world
    pos = (lights["position"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    d = lights["direction"].astype(np.float64) @ m[:3, :3].T
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-30)
    d = d.astype(np.float32)
    is_spot = lights["type"] == SPOT
    center, rad = bounds.culling_spheres(pos, lights["radius"], is_spot, d, lights["cos_outer"])
    return ViewLights(
        ids=np.arange(len(lights), dtype=np.uint32), type=lights["type"].copy(), pos=pos,
        radius=lights["radius"].astype(np.float32), direction=d,
        color=(lights["color"] * lights["intensity"][:, None]).astype(np.float32),
        cos_inner=lights["cos_inner"].astype(np.float32), cos_outer=lights["cos_outer"].astype(np.float32),
        center=center, bound_radius=rad)


def frustum_cull(vl: ViewLights, cam: FrameCamera) -> np.ndarray:
    """Indices of lights whose culling sphere may touch a visible point: in front of the
    near plane, before the far plane, inside the four side planes widened by PIXEL_MARGIN."""
    c, r = vl.center, vl.bound_radius
    d = -c[:, 2]
    keep = (d + r >= cam.near * (1 - RADIUS_REL_MARGIN)) & (d - r <= cam.far * (1 + RADIUS_REL_MARGIN))
    for axis, tan_half, size in ((0, cam.tan_half_x, cam.width), (1, cam.tan_half_y, cam.height)):
        t = tan_half * (1.0 + 2.0 * PIXEL_MARGIN / size)
        norm = np.sqrt(1.0 + t * t)
        # inside iff +-a + t*d >= 0; outside the widened plane by more than r -> culled
        keep &= (c[:, axis] + t * d) / norm >= -r
        keep &= (-c[:, axis] + t * d) / norm >= -r
    return np.flatnonzero(keep)


def depth_sort(depth: np.ndarray, buckets: int = 0) -> np.ndarray:
    """Order of lights by distance to the camera plane, ties broken by index (stable).

    buckets > 0 gives the approximate sort of the first author's testbed: a counting sort
    into that many depth buckets (order within a bucket is the input order).  Trees stay
    exact either way (node bounds are min/max over their lights), only less tight."""
    if buckets <= 0 or len(depth) == 0:
        return np.argsort(depth, kind="stable")
    lo, hi = float(depth.min()), float(depth.max())
    key = ((depth - lo) * (buckets / max(hi - lo, 1e-30))).astype(np.int64).clip(0, buckets - 1)
    return np.argsort(key.astype(np.int16), kind="stable")  # radix sort for 16-bit keys


def pack_lights(vl: ViewLights) -> tuple[np.ndarray, np.ndarray]:
    """GPU_LIGHT and GPU_BOUND arrays, in the order of `vl`."""
    g = np.zeros(len(vl), layouts.GPU_LIGHT)
    g["pos_radius"][:, :3], g["pos_radius"][:, 3] = vl.pos, vl.radius
    g["color_cos_inner"][:, :3], g["color_cos_inner"][:, 3] = vl.color, vl.cos_inner
    g["dir_cos_outer"][:, :3], g["dir_cos_outer"][:, 3] = vl.direction, vl.cos_outer
    g["id_type"][:, 0], g["id_type"][:, 1] = vl.ids, vl.type
    b = np.zeros(len(vl), layouts.GPU_BOUND)
    b["center_radius"][:, :3] = vl.center
    # float32 rounding of the centre is covered by the 4-eps term of culling_spheres;
    # round the radius up so the stored value never shrinks.
    b["center_radius"][:, 3] = np.nextafter(vl.bound_radius.astype(np.float32), np.float32(np.inf))
    return g, b
