"""The GPU build's first steps, shared by every technique that takes --build gpu: the frame's
cull, compaction, depth sort and pack as compute passes, each bit for bit the CPU stage's
(cpu_prep.lights: cull, sort_ids, pack; tests/app/gpu_build).

    scene lights (LIGHT_DTYPE words, uploaded)
      build_cull  flags[N], cull_keys[N]  --scan-->  places[N], visible -> counters[VISIBLE],
                  their shapes -> counters[TYPES] (a bit a light type)
                  compact: sort_in (key, scene id) of the visible lights, in scene order
      build_sort  4 digits of 8 bits (steps.sort): sorted_ids, in depth order, ties in scene order
                  (host step: the visible count and shapes read back, 8 bytes: the pack's
                   buffers and the technique's sizes follow from the count)
      build_pack  each visible light in that order (build_pack.comp): its record (`lights`),
                  sphere (gb_light_bounds, gb_light_spheres), screen rectangle (gb_light_rect)
                  and depth range (light_depth); then the technique's own steps, `then(b)`

`counters` (COUNTER_WORDS uint words, cleared by the first pass) holds every count a build
makes on the GPU: the visible lights, the list entries, the longest list, the tree nodes ...
A count that sizes a later buffer or dispatch is read back by a host step (4 bytes).  Until
the figures read the pack's buffers back (readback_lights), the frame's lights are a stand-in
that knows their count and shapes (PackedLights).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpu_prep import bounds as boundsmod, layouts, lights as lightsmod, limits
from cpu_prep.bounds import F32_EPS, HALF_SQRT2
from scenes.model import LIGHT_DTYPE

from ..errors import UserError
from ..pipeline.passes import Build, Buffer, FrameInput, HostStep, Pass
from . import steps

COUNTERS = "gb_counters"
# counter words: each count one pass makes for the next (SCRATCH: a scan's unkept total;
# TREES / LISTS: cells of more than one leaf / of one; CHOSEN_TREES, LISTS_AS_TREES: the
# hybrid's listing 2 choices, and its lists stored as trees of lists)
COUNTER_NAMES = ("visible", "entries", "longest", "scratch", "nodes", "max_leaves", "trees",
                 "lists", "chosen_trees", "lists_as_trees", "types")
(VISIBLE, ENTRIES, LONGEST, SCRATCH, NODES, MAX_LEAVES, TREES, LISTS, CHOSEN_TREES,
 LISTS_AS_TREES, TYPES) = range(len(COUNTER_NAMES))
COUNTER_WORDS = steps.COUNTER_WORDS
assert len(COUNTER_NAMES) <= COUNTER_WORDS
# the build shaders' names of those words, generated (build_counters.glsl, a pass's virtual file)
COUNTER_FILES = {"build_counters.glsl": layouts.glsl_defines(
    {f"COUNTER_{name.upper()}": k for k, name in enumerate(COUNTER_NAMES)})}
CULL_KEY_BITS = 32
# the scene record's fields as 4-byte words (LIGHT_DTYPE: type is its first byte)
_SL = {f"SL_{n.upper()}": LIGHT_DTYPE.fields[n][1] // 4 for n in LIGHT_DTYPE.names}
SCENE_DEFINES = dict(_SL, SL_WORDS=LIGHT_DTYPE.itemsize // 4)
assert LIGHT_DTYPE.itemsize % 4 == 0 and LIGHT_DTYPE.fields["type"][1] == 0
# the GPU_LIGHT row's fields as word offsets (layouts: the one declaration of the row)
ROW_DEFINES = {"LW_POS": layouts.LIGHT_POS_RADIUS, "LW_COLOR": layouts.LIGHT_COLOR_COS_INNER,
               "LW_DIR": layouts.LIGHT_DIR_COS_OUTER, "LW_ID": layouts.LIGHT_ID_TYPE,
               "LW_EXT": layouts.LIGHT_EXTENT_LENGTH, "LW_RIGHT": layouts.LIGHT_RIGHT,
               "LW_WORDS": layouts.LIGHT_WORDS}
# the pack's outputs beside `lights` and `light_depth`
BOUNDS, SPHERES, RECTS = "gb_light_bounds", "gb_light_spheres", "gb_light_rect"
F64 = np.dtype(np.float64)


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


# the largest per-item buffers of the build: what the storage-block limit caps first
SCENE_ITEM_BYTES = LIGHT_DTYPE.itemsize             # scene_lights: a record a scene light
VISIBLE_ITEM_BYTES = layouts.GPU_LIGHT.itemsize     # `lights`: a row a visible light


def check_items(frame: FrameInput, what: str, item_bytes: int, count: int, unit: str) -> None:
    """Refuse in one line (LimitError) a buffer of `count` items of `item_bytes` past the
    driver's storage-block limit, naming it, the limit and the most items it holds."""
    limit = frame.limits.max_storage_block
    if item_bytes * count > limit:
        raise limits.LimitError(
            f"--build gpu: {what} of {count:,} {unit} needs {item_bytes * count / 2**20:.4g} MiB, "
            f"over this driver's {limit / 2**20:.4g} MiB storage-block limit (at most "
            f"{limit // item_bytes:,} {unit})")


def check_lights(frame: FrameInput, visible: int | None = None) -> None:
    """The scene's light records (visible None) or the rows of `visible` lights against the
    storage-block limit (check_items); also what Technique.refusal asks before a build."""
    if visible is None:
        check_items(frame, "the scene's light records", SCENE_ITEM_BYTES, len(frame.lights), "scene lights")
    else:
        check_items(frame, "the visible lights' rows", VISIBLE_ITEM_BYTES, visible, "visible lights")


def scene_words(lights: np.ndarray) -> np.ndarray:
    """The scene's light records as the uint32 words the cull reads."""
    return np.ascontiguousarray(lights).view(np.uint32)


def cull_uniforms(frame: FrameInput) -> dict:
    """The cull's camera and margins, as cpu_prep.lights.cull and _cull_range compute them."""
    cam = frame.camera
    tx = cam.tan_half_x * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.width)      # lights.cull
    ty = cam.tan_half_y * (1.0 + 2.0 * limits.PIXEL_MARGIN / cam.height)
    return dict(light_uniforms(frame), u_near_lo=cam.near * (1 - limits.RADIUS_REL_MARGIN),
                u_far_hi=cam.far * (1 + limits.RADIUS_REL_MARGIN), u_tan_x=tx, u_tan_y=ty,
                u_norm_x=float(np.sqrt(1.0 + tx * tx)), u_norm_y=float(np.sqrt(1.0 + ty * ty)),
                u_n=len(frame.lights))


def light_uniforms(frame: FrameInput) -> dict:
    """build_light.glsl's: the view matrix's rows, bounds.grow's margins."""
    m = np.asarray(frame.camera.view_from_world, np.float64)
    return {"u_view_x": tuple(m[0]), "u_view_y": tuple(m[1]), "u_view_z": tuple(m[2]),
            "u_grow_scale": 1.0 + limits.RADIUS_REL_MARGIN, "u_grow_eps": 4.0 * F32_EPS,
            "u_half_sqrt2": HALF_SQRT2}


def pack_uniforms(frame: FrameInput) -> dict:
    """build_bounds.glsl's: the camera as lights.pack passes it to bounds.shape_bounds."""
    cam = frame.camera
    return dict(light_uniforms(frame), u_near=float(cam.near), u_tan=(cam.tan_half_x, cam.tan_half_y),
                u_size=(float(cam.width), float(cam.height)), u_pixel_margin=float(limits.PIXEL_MARGIN),
                u_pad_scale=limits.RADIUS_REL_MARGIN + 8.0 * F32_EPS,
                u_wide_cone_cos=float(boundsmod.WIDE_CONE_COS))


def cull_and_sort(frame: FrameInput) -> list[Pass]:
    """The cull, its compaction and the depth sort: gb_sorted_ids[counters[VISIBLE]]."""
    n = len(frame.lights)
    nb = steps.groups(steps.blocks(n))
    u = cull_uniforms(frame)
    cull = Pass("build_cull", "build_cull.comp", reads=("scene_lights",),
                writes={"flags": steps.words(n), "cull_keys": steps.words(n), "counters": counters()},
                groups=nb, defines=dict(SCENE_DEFINES, CULL_STEP=0), uniforms=u,
                sources={"flags": "gb_flags", "cull_keys": "gb_cull_keys", "counters": COUNTERS},
                virtual=COUNTER_FILES)
    compact = Pass("build_cull", "build_cull.comp", reads=("flags", "cull_keys", "places"),
                   writes={"keys": steps.words(n), "values": steps.words(n)}, groups=nb,
                   defines=dict(SCENE_DEFINES, CULL_STEP=1), uniforms={"u_n": n}, virtual=COUNTER_FILES,
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


def pack_pass(frame: FrameInput, n: int) -> Pass:
    """The pack of the n visible lights (read back) in the sort's order (build_pack.comp)."""
    return Pass("build_pack", "build_pack.comp", reads=("counters", "scene_lights", "sorted_ids"),
                writes={"lights": Buffer(max(n, 1) * layouts.GPU_LIGHT.itemsize, layouts.GPU_LIGHT),
                        "bounds": Buffer(max(n, 1) * layouts.GPU_BOUND.itemsize, layouts.GPU_BOUND),
                        "spheres": Buffer(max(n, 1) * 32, F64), "rects": Buffer(max(n, 1) * 32, F64),
                        "depths": Buffer(max(n, 1) * 8, np.dtype(np.float32))},
                groups=steps.groups(steps.blocks(n)), defines=dict(SCENE_DEFINES, **ROW_DEFINES),
                virtual=COUNTER_FILES, uniforms=pack_uniforms(frame),
                sources={"counters": COUNTERS, "sorted_ids": "gb_sorted_ids", "bounds": BOUNDS,
                         "spheres": SPHERES, "rects": RECTS, "depths": "light_depth"})


@dataclass
class PackedLights(lightsmod.PreparedLights):
    """The frame's visible lights as the GPU packed them, before any readback: their count
    and the types among them (counters[VISIBLE], [TYPES]); no arrays (they are on the GPU;
    readback_lights brings them back where the figures want them)."""
    count: int = 0

    def __len__(self):
        return self.count


def packed_lights(frame: FrameInput, count: int, type_bits: int) -> PackedLights:
    empty = lightsmod.pack(frame.lights[:0], frame.camera, np.zeros(0, np.uint64))
    kw = {f: getattr(empty, f) for f in ("ids", "center", "bound_radius", "rect", "gpu", "bounds",
                                         "depth_lo", "depth_hi")}
    types = np.array([t for t in range(32) if type_bits >> t & 1], np.uint8)
    return PackedLights(type=types, count=int(count), **kw)


def visible_step(b: Build, then) -> HostStep:
    """The visible count and shapes read back after the sort; the pack sized by the count;
    b.lights the stand-in that knows both; `then(b)`: the steps after the pack."""
    def run(read):
        c = read[COUNTERS]
        n = int(c[VISIBLE])
        check_lights(b.frame, n)
        b.lights = packed_lights(b.frame, n, int(c[TYPES]))
        b.stats["visible_lights"] = n
        return {}, [pack_pass(b.frame, n)] + list(then(b))
    return host("build_visible", (COUNTERS,), run)


def readback_lights(read, n: int) -> lightsmod.PreparedLights:
    """The pack's buffers read back as the CPU pack's PreparedLights (figures, tests)."""
    rows = read["lights"].view(layouts.GPU_LIGHT)[:n].copy()
    spheres = read[SPHERES].view(np.float64).reshape(-1, 4)[:n].copy()
    depth = read["light_depth"].view(np.float32).reshape(-1, 2)[:n].copy()
    return lightsmod.PreparedLights(
        ids=rows["id_type"][:, 0], type=rows["id_type"][:, 1].astype(np.uint8),
        center=spheres[:, :3], bound_radius=spheres[:, 3],
        rect=read[RECTS].view(np.float64).reshape(-1, 4)[:n].copy(), gpu=rows,
        bounds=read[BOUNDS].view(layouts.GPU_BOUND)[:n].copy(),
        depth_lo=depth[:, 0].copy(), depth_hi=depth[:, 1].copy())


PACK_OUTPUTS = ("lights", BOUNDS, SPHERES, RECTS, "light_depth")


def unbuilt_lights(frame: FrameInput) -> lightsmod.PreparedLights:
    """The frame's lights before the GPU has culled them: no rows yet, and every scene
    light's type, so that the shaders compile each shape the cull may keep (the renderer
    reads the types before the passes run); the visible step replaces it."""
    return packed_lights(frame, 0, int(np.bitwise_or.reduce(1 << frame.lights["type"].astype(np.int64),
                                                            initial=0)))


def start(frame: FrameInput, then, **stats) -> Build:
    """A Build whose lights the GPU culls, sorts and packs (the scene's records go up), then
    `then(b)`'s steps: build.steps, which the renderer runs in place of the
    technique's passes.  stats: the build's own, beside build=gpu."""
    check_lights(frame)
    b = Build(frame=frame, lights=unbuilt_lights(frame))
    b.buffers["scene_lights"] = scene_words(frame.lights)
    b.stats.update(build="gpu", **stats)
    b.steps = cull_and_sort(frame) + [visible_step(b, then)]
    return b
