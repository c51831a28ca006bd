"""Camera matrices, named destination_from_source.  View space is right-handed, the camera
looks down -Z; `depth` everywhere means linear view depth = -z_view (> 0 in front)."""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np


@dataclass(frozen=True)
class FrameCamera:
    view_from_world: np.ndarray   # (4,4) float64
    clip_from_view: np.ndarray    # (4,4) float64, OpenGL convention
    width: int
    height: int
    near: float
    far: float
    tan_half_y: float

    @property
    def tan_half_x(self) -> float:
        return self.tan_half_y * self.width / self.height


def look_at(position, target, up) -> np.ndarray:
    eye, tgt, up = (np.asarray(v, np.float64) for v in (position, target, up))
    f = tgt - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    t = 1.0 / math.tan(math.radians(fov_y_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = t / aspect, t
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def frame_camera(cam, width: int, height: int) -> FrameCamera:
    """FrameCamera from a scenes.model.Camera-like object (position, target, up, fov_y_deg, near, far)."""
    return FrameCamera(
        view_from_world=look_at(cam.position, cam.target, cam.up),
        clip_from_view=perspective(cam.fov_y_deg, width / height, cam.near, cam.far),
        width=int(width), height=int(height), near=float(cam.near), far=float(cam.far),
        tan_half_y=math.tan(math.radians(cam.fov_y_deg) / 2))
