"""Transparent surfaces: up to L layers of transparent fragments in front of the opaque
surface, each lit by the frame's technique from its own structure, composited over the
opaque image back to front.

A mesh whose opacity is below 1 (scenes.model.Mesh.transparent) is not drawn into the
G-buffer.  After the G-buffer, the layers are peeled (glsl/transparent_peel.*): layer k
holds, per pixel, the nearest transparent fragment strictly in front of the opaque surface
and strictly behind layer k-1's, in the G-buffer's own formats (view-space position with
its linear depth, normal and roughness, albedo and metallic) plus its opacity.  Peeling
stops at the first empty layer or at L (`--transparent-layers`, default DEFAULT_LAYERS):
a pixel with more than L transparent fragments in front of its opaque surface shows the
nearest L.

Every technique shades a layer with its own passes, unchanged: the renderer binds the
layer's textures where the G-buffer's are and runs the technique's steps over them, so a
layer is to a technique exactly a G-buffer whose covered pixels are that layer's
fragments.  What that means per technique is its declaration (Technique.transparent,
docs/techniques.md): a structure built from the lights alone (clustered, hybrid, tree, the
samplers' cells, zbin's bins, brute's list) is looked up at the fragment's view-space
point; a structure its GPU passes bound by the depth they read (tiled's and fptl's tile
depth ranges, zbin's depth-tested tiles, raster's depth-tested proxies, perfect's
per-pixel lists) is built again over the layer's own fragments, so a pane nearer than a
tile's opaque minimum is inside its layer's tile range.  Every layer is therefore held to
brute's layer at every pixel like the opaque frame (`contrib_count_t`, `contrib_hash_t`;
app.exactness).

The layers run before the technique's opaque steps, so that every buffer a frame leaves
behind (the structure, out_stats, the wave statistics the cost model replays and the maps
read) is the opaque frame's, as in a scene without transparent surfaces; the compositing
(glsl/transparent_over.comp) then runs after the opaque shading, from the farthest layer
to the nearest: colour = a * layer + (1 - a) * colour, a the fragment's opacity.  The
layers' pass times are the frame's meta["transparent"]["gpu_ms"] (summed over layers), not
the opaque frame's gpu_ms; later samples of a frame (render(samples=N)) repeat the opaque
passes and the compositing only.

A scene without transparent surfaces has no Layers (for_scene returns None): the renderer
runs exactly the code path, images and dumps it always did.
"""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts

from ..errors import UserError
from .gbuffer import column_major, triangle_soup
from .passes import OUT_COLOR, OUT_STATS

DEFAULT_LAYERS = 4
MAX_LAYERS = 8
OPAQUE_UNIT, FRONT_UNIT = 5, 6     # texture units of the peel and the compositing (past G-buffer's)


def check_layers(n) -> int:
    """The maximum layer count L as given (--transparent-layers): an integer in 1..MAX_LAYERS."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= int(n) <= MAX_LAYERS:
        raise UserError(f"--transparent-layers must be an integer in 1..{MAX_LAYERS} (got {n!r})")
    return int(n)


def add_args(parser) -> None:
    """capture's flag for the layer count."""
    parser.add_argument("--transparent-layers", type=int, default=DEFAULT_LAYERS, metavar="L",
                        help=f"most transparent layers captured and shaded per pixel, 1..{MAX_LAYERS} "
                             f"(scenes with transparent surfaces; default {DEFAULT_LAYERS})")


def for_scene(ctx, scene, layers: int = DEFAULT_LAYERS):
    """The scene's Layers, or None when it has no transparent surface."""
    meshes = scene.transparent_meshes()
    return Layers(ctx, meshes, check_layers(layers)) if meshes else None


def layer_soup(meshes) -> np.ndarray:
    """(T*3, 12) float32: the G-buffer's vertex rows (gbuffer.triangle_soup) and the opacity."""
    soup = triangle_soup(meshes)
    opacity = np.concatenate([np.full(3 * len(m.faces), m.opacity, np.float32) for m in meshes])
    return np.concatenate([soup, opacity[:, None]], 1)


class _Layer:
    """One layer's targets, in the G-buffer's formats, plus its opacity."""

    def __init__(self, ctx, size):
        self.position = ctx.texture(size, 4, dtype="f4")
        self.normal = ctx.texture(size, 4, dtype="f4")
        self.albedo = ctx.texture(size, 4, dtype="f1")
        self.opacity = ctx.texture(size, 1, dtype="f4")
        self.depth = ctx.depth_texture(size)
        for t in (self.position, self.normal, self.albedo, self.opacity):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.position, self.normal, self.albedo, self.opacity], self.depth)

    def release(self) -> None:
        for o in (self.fbo, self.position, self.normal, self.albedo, self.opacity, self.depth):
            o.release()


class Layers:
    """The transparent layers of a renderer's frames (module docstring)."""

    def __init__(self, ctx, meshes, layers: int = DEFAULT_LAYERS):
        self.ctx = ctx
        self.max_layers = check_layers(layers)
        self.soup = layer_soup(meshes)
        self.vbo = ctx.buffer(self.soup.tobytes())
        self.size = None
        self.layers: list[_Layer] = []
        self.used = 0                 # layers with a fragment in the last frame
        self.meta: dict = {}
        self._vao = None
        self.color = self.stats = None
        # render(debug_pixel=...) records the lights of this layer's fragment at that pixel
        # in place of the opaque surface's (the exactness check's explanation of a layer)
        self.debug_layer: int | None = None

    # ---- targets ---------------------------------------------------------------------

    def _resize(self, size) -> None:
        size = tuple(size)
        if size == self.size:
            return
        self._release_targets()
        self.size = size
        self.layers = [_Layer(self.ctx, size) for _ in range(self.max_layers)]
        w, h = size
        self.color = self.ctx.buffer(reserve=self.max_layers * w * h * 16)
        self.stats = self.ctx.buffer(reserve=self.max_layers * w * h * layouts.PIXEL_STATS.itemsize)

    # ---- the frame ---------------------------------------------------------------------

    def peel(self, renderer, camera) -> int:
        """Fill the layers for `camera` over the renderer's opaque G-buffer; -> layers used."""
        import moderngl
        self._resize(renderer.size)
        ctx, gb = self.ctx, renderer.gbuffer
        prog = renderer.programs.program("transparent_peel.vert", "transparent_peel.frag",
                                         context="transparent layers")
        if self._vao is None or self._vao[0] is not prog:
            if self._vao is not None:
                self._vao[1].release()
            self._vao = (prog, ctx.vertex_array(prog, [(self.vbo, "3f 3f 3f 2f 1f", "in_position",
                                                        "in_normal", "in_albedo", "in_material",
                                                        "in_opacity")], skip_errors=True))
        prog["u_view_from_world"].write(column_major(camera.view_from_world).tobytes())
        prog["u_clip_from_view"].write(column_major(camera.clip_from_view).tobytes())
        for name, unit in (("u_opaque", OPAQUE_UNIT), ("u_front", FRONT_UNIT)):
            if name in prog:
                prog[name].value = unit
        gb.position.use(OPAQUE_UNIT)
        self.used = 0
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        try:
            for k, layer in enumerate(self.layers):
                layer.fbo.use()
                ctx.viewport = (0, 0, *self.size)
                layer.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
                if k > 0:
                    self.layers[k - 1].position.use(FRONT_UNIT)
                if "u_layer" in prog:
                    prog["u_layer"].value = k
                q = ctx.query(samples=True)
                with q:
                    self._vao[1].render(moderngl.TRIANGLES)
                drawn = bool(q.samples)
                if not drawn:
                    break
                self.used = k + 1
        finally:
            ctx.disable(moderngl.DEPTH_TEST)
            renderer.gbuffer.bind_textures()
        return self.used

    def shade(self, renderer, steps, env, technique: str, camera) -> None:
        """Peel the layers, then run the technique's `steps` over each, back to front,
        keeping each layer's colour and per-pixel counters (module docstring)."""
        from . import gl
        self.peel(renderer, camera)
        f, gb = renderer._frame, renderer.gbuffer
        held = (gb.position, gb.normal, gb.albedo)
        timer, renderer.timer = renderer.timer, gl.PassTimer(self.ctx)
        timed, setup, debug = len(f.timed), dict(f.setup_ms), f.debug_pixel
        untimed = set(f.untimed_writes)   # each run of the steps starts from the frame's
        f.debug_pixel = None          # the explanation: the opaque surface's, or debug_layer's
        w, h = self.size
        try:
            for k in reversed(range(self.used)):
                layer = self.layers[k]
                gb.position, gb.normal, gb.albedo = layer.position, layer.normal, layer.albedo
                gb.bind_textures()
                f.untimed_writes = set(untimed)
                f.debug_pixel = debug if k == self.debug_layer else None
                renderer.run(steps, *env, technique=technique)
                self.ctx.copy_buffer(self.color, renderer.buffers[OUT_COLOR], w * h * 16,
                                     write_offset=k * w * h * 16)
                n = w * h * layouts.PIXEL_STATS.itemsize
                self.ctx.copy_buffer(self.stats, renderer.buffers[OUT_STATS], n, write_offset=k * n)
        finally:
            gb.position, gb.normal, gb.albedo = held
            gb.bind_textures()
            ms, renderer.timer = renderer.timer.take(), timer
            layer_setup = {k: v - setup.get(k, 0.0) for k, v in f.setup_ms.items()
                           if v != setup.get(k, 0.0)}
            del f.timed[timed:]
            f.setup_ms, f.untimed_writes = setup, untimed
            f.debug_pixel = debug if self.debug_layer is None else None
        self.meta = {"max_layers": self.max_layers, "layers": self.used,
                     "gpu_ms": ms, "setup_ms": layer_setup}

    def composite(self, renderer) -> None:
        """The layers over the frame's colour (out_color), from the farthest to the nearest."""
        if not self.used:
            return
        prog = renderer.programs.compute("transparent_over.comp", bindings={OUT_COLOR: 0, "layer_color": 1},
                                         context="transparent compositing")
        w, h = self.size
        renderer.buffers[OUT_COLOR].bind_to_storage_buffer(0)
        self.color.bind_to_storage_buffer(1)
        for name, v in (("u_size", (w, h)), ("u_opacity", FRONT_UNIT)):
            if name in prog:
                prog[name].value = v
        for k in reversed(range(self.used)):
            self.layers[k].opacity.use(FRONT_UNIT)
            if "u_offset" in prog:
                prog["u_offset"].value = k * w * h
            prog.run(-(-w // 8), -(-h // 8), 1)
            self.ctx.memory_barrier()
        renderer.gbuffer.bind_textures()

    # ---- read back ---------------------------------------------------------------------

    def read_positions(self) -> np.ndarray:
        """(L, H, W, 4) float32 view-space position and depth of each layer's fragments,
        image order (row 0 = top); zeros in the layers past those used."""
        w, h = self.size
        out = np.zeros((self.max_layers, h, w, 4), np.float32)
        for k in range(self.used):
            out[k] = np.frombuffer(self.layers[k].position.read(), np.float32).reshape(h, w, 4)[::-1]
        return out

    def read_outputs(self, result) -> None:
        """The layers' per-pixel figures on the FrameResult (LAYER_FIELDS, (L, H, W), image
        order, 0 where a layer has no fragment)."""
        w, h = self.size
        shape = (self.max_layers, h, w)
        count, hashes, evaluated = (np.zeros(shape, np.uint32) for _ in range(3))
        depth = self.read_positions()[..., 3].copy()
        n = w * h * layouts.PIXEL_STATS.itemsize
        for k in range(self.used):
            st = np.frombuffer(self.stats.read(size=n, offset=k * n), layouts.PIXEL_STATS).reshape(h, w)[::-1]
            covered = depth[k] > 0
            count[k] = np.where(covered, st["contrib_count"], 0)
            hashes[k] = np.where(covered, st["contrib_hash"], 0)
            evaluated[k] = np.where(covered, st["evaluated"], 0)
        result.contrib_count_t, result.contrib_hash_t = count, hashes
        result.depth_t, result.evaluated_t = depth, evaluated
        self.meta["fragments"] = [int(c) for c in (depth > 0).sum((1, 2))]

    def _release_targets(self) -> None:
        for layer in self.layers:
            layer.release()
        self.layers = []
        for b in (self.color, self.stats):
            if b is not None:
                b.release()
        self.color = self.stats = None
        self.size = None

    def release(self) -> None:
        self._release_targets()
        if self._vao is not None:
            self._vao[1].release()
            self._vao = None
        self.vbo.release()


def layer_difference(result, reference):
    """Where the layers of two frames differ (app.exactness holds them to each other): None
    when every layer's count and hash are equal at every pixel (or neither frame has
    layers), else (what differs: "transparent layer K" or the layers' shapes, the (H, W)
    mask of that layer's differing pixels or None, the first differing pixel's count in
    each frame)."""
    mine = getattr(result, "contrib_count_t", None)
    theirs = getattr(reference, "contrib_count_t", None)
    if mine is None and theirs is None:
        return None
    if mine is None or theirs is None or mine.shape != theirs.shape:
        shapes = [None if a is None else a.shape for a in (mine, theirs)]
        return f"transparent layers of shape {shapes[0]} against {shapes[1]}", None, (0, 0)
    for k in range(mine.shape[0]):
        mask = (mine[k] != theirs[k]) | (result.contrib_hash_t[k] != reference.contrib_hash_t[k])
        if mask.any():
            row, x = np.argwhere(mask)[0]
            return f"transparent layer {k}", mask, (int(mine[k, row, x]), int(theirs[k, row, x]))
    return None
