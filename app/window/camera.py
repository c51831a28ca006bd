"""The fly camera: position + yaw/pitch around the scene camera's up axis (PyGLM)."""
from __future__ import annotations

import math


class FlyCamera:
    """Starts as the scene camera, returned as is until it moves (so frame 0 is capture's
    frame 0 exactly); move() and turn() fly it."""

    def __init__(self, cam):
        from pyglm import glm
        self.glm = glm
        self.base = cam
        self.set_from(cam)

    def set_from(self, cam) -> None:
        glm = self.glm
        self.source = cam
        self.up = glm.normalize(glm.vec3(*cam.up))
        self.pos = glm.vec3(*cam.position)
        f = glm.normalize(glm.vec3(*cam.target) - self.pos)
        # frame: yaw about up, pitch towards up
        self.pitch = math.asin(max(-1.0, min(1.0, glm.dot(f, self.up))))
        ref = self._reference()
        side = glm.normalize(glm.cross(ref, self.up))
        flat = f - self.up * glm.dot(f, self.up)
        self.yaw = math.atan2(glm.dot(flat, side), glm.dot(flat, ref)) if glm.length(flat) > 1e-9 else 0.0

    def _reference(self):
        glm = self.glm
        ref = glm.vec3(0, 0, -1) if abs(self.up.z) < 0.9 else glm.vec3(1, 0, 0)
        return glm.normalize(ref - self.up * glm.dot(ref, self.up))

    def forward(self):
        glm = self.glm
        ref = self._reference()
        side = glm.normalize(glm.cross(ref, self.up))
        flat = ref * math.cos(self.yaw) + side * math.sin(self.yaw)
        return glm.normalize(flat * math.cos(self.pitch) + self.up * math.sin(self.pitch))

    def move(self, fwd: float, right: float, up: float) -> None:
        glm = self.glm
        f = self.forward()
        r = glm.normalize(glm.cross(f, self.up))
        self.pos += f * fwd + r * right + self.up * up
        self.source = None

    def turn(self, dyaw: float, dpitch: float) -> None:
        self.yaw += dyaw
        self.pitch = max(-1.55, min(1.55, self.pitch + dpitch))
        self.source = None

    def camera(self):
        from scenes.model import Camera
        if self.source is not None:
            return self.source
        b = self.base
        t = self.pos + self.forward()
        return Camera(tuple(map(float, self.pos)), tuple(map(float, t)), tuple(map(float, self.up)),
                      b.fov_y_deg, b.near, b.far)
