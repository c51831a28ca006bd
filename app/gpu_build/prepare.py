"""The GPU build's first steps, shared by every technique that takes --build gpu: the frame's
cull, compaction and depth sort as compute passes, then the pack, each bit for bit the CPU
stage's (cpu_prep.lights: cull, sort_ids, pack).

    scene lights (LIGHT_DTYPE words, uploaded)
      build_cull  flags[N], cull_keys[N]  --scan-->  places[N], visible -> counters[VISIBLE]
                  compact: sort_in (key, scene id) of the visible lights, in scene order
      build_sort  4 digits of 8 bits (steps.sort): sorted_ids, in depth order, ties in scene order
      build_pack  (host step) the light records (`lights`), each shape's screen rectangle
                  (gb_light_rect) and depth range (light_depth), on the GPU's order; then
                  the technique's own steps, `then(b)`

`counters` (COUNTER_WORDS uint words, cleared by the first pass) holds every count a build
makes on the GPU: the visible lights, the list entries, the longest list, the tree nodes ...
A count that sizes a later buffer or dispatch is read back by a host step (4 bytes).  The
pack still runs on the CPU: cpu_prep/bounds.py mixes float32 and float64 operations as numba
types them, which a GLSL port must follow op by op to stay bit for bit (docs/cpu_stage.md).
"""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts, lights as lightsmod, limits
from cpu_prep.bounds import F32_EPS, HALF_SQRT2
from scenes.model import LIGHT_DTYPE

from ..errors import UserError
from ..pipeline.passes import Build, Buffer, FrameInput, HostStep, Pass
from . import steps

COUNTERS = "gb_counters"
# Build.data key of a GPU build's steps, run by the renderer in place of technique.passes()
BUILD_STEPS = "build_steps"
# counter words: each count one pass makes for the next (SCRATCH: a scan's unkept total;
# TREES / LISTS: cells of more than one leaf / of one; CHOSEN_TREES, LISTS_AS_TREES: the
# hybrid's listing 2 choices, and its lists stored as trees of lists)
COUNTER_NAMES = ("visible", "entries", "longest", "scratch", "nodes", "max_leaves", "trees",
                 "lists", "chosen_trees", "lists_as_trees")
(VISIBLE, ENTRIES, LONGEST, SCRATCH, NODES, MAX_LEAVES, TREES, LISTS, CHOSEN_TREES,
 LISTS_AS_TREES) = range(len(COUNTER_NAMES))
COUNTER_WORDS = steps.COUNTER_WORDS
assert len(COUNTER_NAMES) <= COUNTER_WORDS
# the build shaders' names of those words, generated (build_counters.glsl, a pass's virtual file)
COUNTER_FILES = {"build_counters.glsl": layouts.glsl_defines(
    {f"COUNTER_{name.upper()}": k for k, name in enumerate(COUNTER_NAMES)})}
CULL_KEY_BITS = 32
# the scene record's fields as 4-byte words (LIGHT_DTYPE: type is its first byte)
_SL = {f"SL_{n.upper()}": LIGHT_DTYPE.fields[n][1] // 4
       for n in ("type", "position", "radius", "direction", "cos_outer", "length", "extent")}
SCENE_DEFINES = dict(_SL, SL_WORDS=LIGHT_DTYPE.itemsize // 4)
assert LIGHT_DTYPE.itemsize % 4 == 0 and LIGHT_DTYPE.fields["type"][1] == 0


def counters() -> Buffer:
    """The counter words as a pass declares them (every pass the same size: a larger
    declaration would reallocate the buffer and lose the counts)."""
    return Buffer(4 * COUNTER_WORDS, steps.U32)


def host(name: str, reads, run, figures: bool = False) -> HostStep:
    """A host step of the GPU build whose limits refuse in one line, as the CPU build's do
    (a LimitError raised after the build's start would otherwise leave the renderer as a
    traceback)."""
    def checked(read):
        try:
            return run(read)
        except limits.LimitError as exc:
            raise UserError(str(exc)) from None
    return HostStep(name, tuple(reads), checked, figures=figures)


def scene_words(lights: np.ndarray) -> np.ndarray:
    """The scene's light records as the uint32 words the cull reads."""
    return np.ascontiguousarray(lights).view(np.uint32)


def cull_uniforms(frame: FrameInput) -> dict:
    """The cull's camera and margins, as cpu_prep.lights.cull and _cull compute them."""
    cam = frame.camera
    m = np.asarray(cam.view_from_world, np.float64)
    tx = cam.tan_half_x * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.width)      # lights.cull
    ty = cam.tan_half_y * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.height)
    return {"u_view_x": tuple(m[0]), "u_view_y": tuple(m[1]), "u_view_z": tuple(m[2]),
            "u_near_lo": cam.near * (1 - limits.RADIUS_REL_MARGIN),
            "u_far_hi": cam.far * (1 + limits.RADIUS_REL_MARGIN),
            "u_tan_x": tx, "u_tan_y": ty,
            "u_norm_x": float(np.sqrt(1.0 + tx * tx)), "u_norm_y": float(np.sqrt(1.0 + ty * ty)),
            "u_grow_scale": 1.0 + limits.RADIUS_REL_MARGIN, "u_grow_eps": 4.0 * F32_EPS,
            "u_half_sqrt2": HALF_SQRT2, "u_n": len(frame.lights)}


def cull_and_sort(frame: FrameInput) -> list[Pass]:
    """The cull, its compaction and the depth sort: gb_sorted_ids[counters[VISIBLE]]."""
    n = len(frame.lights)
    nb = steps.groups(steps.blocks(n))
    u = cull_uniforms(frame)
    cull = Pass("build_cull", "build_cull.comp", reads=("scene_lights",),
                writes={"flags": steps.words(n), "cull_keys": steps.words(n)}, groups=nb,
                defines=dict(SCENE_DEFINES, CULL_STEP=0), uniforms=u,
                sources={"flags": "gb_flags", "cull_keys": "gb_cull_keys"})
    compact = Pass("build_cull", "build_cull.comp", reads=("flags", "cull_keys", "places"),
                   writes={"keys": steps.words(n), "values": steps.words(n)}, groups=nb,
                   defines=dict(SCENE_DEFINES, CULL_STEP=1), uniforms={"u_n": n},
                   sources={"flags": "gb_flags", "cull_keys": "gb_cull_keys", "places": "gb_places",
                            "keys": "gb_sort_in_keys", "values": "gb_sort_in_ids"})
    clear = Pass("build_cull", "build_scan.comp",
                 writes={"sums": steps.words(1),
                         "counters": Buffer(4 * COUNTER_WORDS, steps.U32, cleared=True)},
                 groups=(1, 1, 1), defines={"SCAN_STEP": 1},
                 uniforms={"u_n": 0, "u_blocks": 0, "u_total_word": SCRATCH},
                 sources={"sums": "gb_scan_sums", "counters": COUNTERS})
    return ([clear, cull] + steps.scan("build_cull", "gb_flags", "gb_places", n, COUNTERS, VISIBLE)
            + [compact]
            + steps.sort("build_sort", "gb_sort_in_keys", "gb_sort_in_ids", "gb_sorted_keys",
                         "gb_sorted_ids", n, CULL_KEY_BITS, COUNTERS, VISIBLE))


def pack_step(b: Build, then) -> HostStep:
    """The CPU pack on the GPU's depth order: the light records (uploaded as `lights`), the
    rectangles and depth ranges the binning reads; b.lights becomes the frame's lights.
    `then(b)`: the steps after it."""
    def run(read):
        visible = int(read[COUNTERS][VISIBLE])
        ids = read["gb_sorted_ids"][:visible].astype(np.uint64)
        # the frame's arena, as the CPU stage's pack: its arrays reused from frame to frame
        pl = lightsmod.pack(b.frame.lights, b.frame.camera, ids, b.frame.arena)
        b.lights = pl
        b.buffers["lights"] = pl.gpu
        b.buffers["light_depth"] = np.column_stack([pl.depth_lo, pl.depth_hi])
        b.stats["visible_lights"] = visible
        uploads = {"lights": pl.gpu, "gb_light_rect": pl.rect, "light_depth": b.buffers["light_depth"]}
        return uploads, then(b)
    return host("build_pack", (COUNTERS, "gb_sorted_ids"), run)


def unbuilt_lights(frame: FrameInput) -> lightsmod.PreparedLights:
    """The frame's lights before the GPU has culled them: no rows yet, and every scene
    light's type, so that the shaders compile each shape the cull may keep (the renderer
    reads the types before the passes run); the pack step replaces it."""
    empty = lightsmod.pack(frame.lights[:0], frame.camera, np.zeros(0, np.uint64))
    empty.type = np.unique(frame.lights["type"]).astype(np.uint8)
    return empty


def start(frame: FrameInput, then, **stats) -> Build:
    """A Build whose lights the GPU culls and sorts (the scene's records go up), packed on
    its order, then `then(b)`'s steps: build.data[BUILD_STEPS], which the renderer runs in
    place of the technique's passes.  stats: the build's own, beside build=gpu."""
    b = Build(frame=frame, lights=unbuilt_lights(frame))
    b.buffers["scene_lights"] = scene_words(frame.lights)
    b.stats.update(build="gpu", **stats)
    b.data[BUILD_STEPS] = cull_and_sort(frame) + [pack_step(b, then)]
    return b
