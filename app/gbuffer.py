"""G-buffer raster pass: depth, view-space position, normal, albedo of the scene geometry."""
from __future__ import annotations

import numpy as np

from cpu_prep.camera import FrameCamera


def triangle_soup(meshes) -> np.ndarray:
    """(T*3, 9) float32: position, flat face normal, albedo per vertex."""
    parts = []
    for m in meshes:
        tri = np.asarray(m.vertices, np.float64)[np.asarray(m.faces)]        # (F,3,3)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        f = len(tri)
        parts.append(np.concatenate([tri.reshape(-1, 3), np.repeat(n, 3, 0),
                                     np.tile(np.asarray(m.albedo, np.float64), (3 * f, 1))], 1))
    if not parts:
        return np.zeros((0, 9), np.float32)
    return np.concatenate(parts).astype(np.float32)


class GBuffer:
    def __init__(self, ctx, programs, meshes, size: tuple[int, int]):
        self.ctx = ctx
        self.program = programs.program("gbuffer.vert", "gbuffer.frag")   # owned by the cache
        soup = triangle_soup(meshes)
        self.vertices = len(soup)
        self.vbo = ctx.buffer(soup.tobytes() if len(soup) else b"\0" * 36)
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "3f 3f 3f", "in_position", "in_normal", "in_albedo")])
        self.size = None
        self.resize(size)

    def resize(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self.release_targets()
        self.size = size
        ctx = self.ctx
        self.position = ctx.texture(size, 4, dtype="f4")
        self.normal = ctx.texture(size, 4, dtype="f4")
        self.albedo = ctx.texture(size, 4, dtype="f1")
        self.depth = ctx.depth_texture(size)
        for t in (self.position, self.normal, self.albedo):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.position, self.normal, self.albedo], self.depth)

    def draw(self, cam: FrameCamera) -> None:
        ctx = self.ctx
        self.fbo.use()
        ctx.viewport = (0, 0, *self.size)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE)
        self.program["u_view_from_world"].write(cam.view_from_world.T.astype("f4").tobytes())
        self.program["u_clip_from_view"].write(cam.clip_from_view.T.astype("f4").tobytes())
        if self.vertices:
            self.vao.render(vertices=self.vertices)

    def bind(self) -> None:
        self.position.use(0)
        self.normal.use(1)
        self.albedo.use(2)

    def read_position(self) -> np.ndarray:
        """(H, W, 4) float32, GL row order (row 0 = bottom)."""
        w, h = self.size
        return np.frombuffer(self.position.read(), np.float32).reshape(h, w, 4)

    def release_targets(self) -> None:
        if self.size is not None:
            for o in (self.fbo, self.position, self.normal, self.albedo, self.depth):
                o.release()

    def release(self) -> None:
        self.release_targets()
        self.vao.release()
        self.vbo.release()
