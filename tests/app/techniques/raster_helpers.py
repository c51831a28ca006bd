"""Helpers of the raster tests: the proxies' vertices placed in view space as
app/techniques/raster/raster_proxy.vert places them (cpu_prep/raster_proxies.py builds the meshes and the
per-light records), so tests can hold a proxy's convexity and containment on the CPU."""
from __future__ import annotations

import numpy as np

from cpu_prep import raster_proxies as rp


def basis(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) with (e1, e2, f) right-handed orthonormal (Duff et al. 2017), as the vertex
    shader builds it."""
    s = np.where(f[..., 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + f[..., 2])
    b = f[..., 0] * f[..., 1] * a
    e1 = np.stack([1.0 + s * f[..., 0] ** 2 * a, s * b, -s * f[..., 0]], -1)
    e2 = np.stack([b, s + f[..., 1] ** 2 * a, -f[..., 1]], -1)
    return e1, e2


def proxy_vertices(light, proxy) -> np.ndarray:
    """(V, 3) float64 view-space vertices of one light's proxy (GPU_LIGHT and RASTER_PROXY
    records), as app/techniques/raster/raster_proxy.vert places them."""
    shape = int(proxy["shape"])
    mesh = rp.MESHES[shape].astype(np.float64)
    p = light["pos_radius"][:3].astype(np.float64)
    f = light["dir_cos_outer"][:3].astype(np.float64)
    M, r = float(proxy["margin"]), float(proxy["radius"])
    if shape == rp.PROXY_SPHERE:
        return p + r * mesh[:, :3]
    e1, e2 = basis(f)
    if shape == rp.PROXY_CAPSULE:
        half = 0.5 * float(light["extent_length"][3])
        local = mesh[:, 0:1] * e1 + mesh[:, 1:2] * e2 + mesh[:, 2:3] * f
        return p + f * (mesh[:, 3:4] * half) + r * local
    if shape == rp.PROXY_CONE:
        th = mesh[:, 2:3] * float(proxy["cap_angle"])
        local = np.sin(th) * (mesh[:, 0:1] * e1 + mesh[:, 1:2] * e2) + np.cos(th) * f
        return np.where(mesh[:, 3:4] > 0.5, p - f * float(proxy["apex_back"]), p + r * local)
    right = light["right"][:3].astype(np.float64)
    upp = np.cross(right, f)
    e = light["extent_length"][:3].astype(np.float64) + M
    return p + mesh[:, 0:1] * e[0] * right + mesh[:, 1:2] * e[1] * upp + mesh[:, 2:3] * e[2] * f
