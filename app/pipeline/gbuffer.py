"""The G-buffer: the frame's first pass, a raster pass declared like any technique's.

    gbuffer.vert/.frag -> position (xyz view space, w linear depth; 0 = sky),
                          normal (xyz, w roughness: 0 matte), albedo (rgb, a metallic),
                          depth; every later pass samples them at the TEXTURE_UNITS,
                          which generated.glsl gives the shaders as G_POSITION_UNIT, ...
"""
from __future__ import annotations

import numpy as np

from cpu_prep.camera import FrameCamera
from .passes import Draw, Pass

TEXTURE_UNITS = {"g_position": 0, "g_normal": 1, "g_albedo": 2}


def unit_defines() -> dict[str, int]:
    """{G_POSITION_UNIT: 0, ...}: the units as generated.glsl defines them."""
    return {f"{name.upper()}_UNIT": unit for name, unit in TEXTURE_UNITS.items()}


def triangle_soup(meshes) -> np.ndarray:
    """(T*3, 11) float32: position, flat face normal, albedo, roughness, metallic per vertex."""
    parts = []
    for m in meshes:
        tri = np.asarray(m.vertices, np.float64)[np.asarray(m.faces)]        # (F,3,3)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        f = len(tri)
        material = np.asarray(tuple(m.albedo) + (m.roughness, m.metallic), np.float64)
        parts.append(np.concatenate([tri.reshape(-1, 3), np.repeat(n, 3, 0),
                                     np.tile(material, (3 * f, 1))], 1))
    if not parts:
        return np.zeros((0, 11), np.float32)
    return np.concatenate(parts).astype(np.float32)


def column_major(m: np.ndarray) -> np.ndarray:
    """A row-major numpy matrix as the float32 column-major data of a GLSL mat4."""
    return np.ascontiguousarray(np.asarray(m, np.float64).T, np.float32)


class GBuffer:
    """The G-buffer's render targets (resized with the frame) and its pass."""

    def __init__(self, ctx, meshes, size: tuple[int, int]):
        self.ctx = ctx
        # opaque surfaces only: transparent ones are the layers' (app/pipeline/transparent.py)
        self.soup = triangle_soup([m for m in meshes if not m.transparent])
        self.specular = any(m.roughness > 0 for m in meshes)   # compile GGX only then
        self.size = None
        self.resize(size)

    def resize(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self.release()
        self.size = tuple(size)
        ctx = self.ctx
        self.position = ctx.texture(self.size, 4, dtype="f4")
        self.normal = ctx.texture(self.size, 4, dtype="f4")
        self.albedo = ctx.texture(self.size, 4, dtype="f1")
        self.depth = ctx.depth_texture(self.size)
        for t in (self.position, self.normal, self.albedo):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.position, self.normal, self.albedo], self.depth)
        self.depth_fbo = ctx.framebuffer(depth_attachment=self.depth)

    def pass_for(self, cam: FrameCamera) -> Pass:
        return Pass(
            "gbuffer", ("gbuffer.vert", "gbuffer.frag"),
            draw=Draw(vertices=self.soup, format="3f 3f 3f 2f",
                      attributes=("in_position", "in_normal", "in_albedo", "in_material"),
                      target="gbuffer",
                      depth_test="less", depth_write=True, clear=True),
            uniforms={"u_view_from_world": column_major(cam.view_from_world),
                      "u_clip_from_view": column_major(cam.clip_from_view)})

    def target(self, name: str):
        return {"gbuffer": self.fbo, "gbuffer_depth": self.depth_fbo}[name]

    def bind_textures(self) -> None:
        self.position.use(TEXTURE_UNITS["g_position"])
        self.normal.use(TEXTURE_UNITS["g_normal"])
        self.albedo.use(TEXTURE_UNITS["g_albedo"])

    def read_position(self) -> np.ndarray:
        """(H, W, 4) float32, GL row order (row 0 = bottom)."""
        w, h = self.size
        return np.frombuffer(self.position.read(), np.float32).reshape(h, w, 4)

    def read_normal(self) -> np.ndarray:
        """(H, W, 4) float32 view-space normal, w the GGX roughness (0: matte); GL row order."""
        w, h = self.size
        return np.frombuffer(self.normal.read(), np.float32).reshape(h, w, 4)

    def release(self) -> None:
        if self.size is not None:
            for o in (self.fbo, self.depth_fbo, self.position, self.normal, self.albedo, self.depth):
                o.release()
            self.size = None
