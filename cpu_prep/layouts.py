"""GPU struct layouts: one numpy dtype per struct, and the GLSL text generated from it.

The dtype is the single source of truth.  `glsl_struct()` writes the GLSL declaration, and
`std430_offsets()` computes where std430 would place each member, so a test can hold the
two to each other (and a GL test round-trips a buffer through a shader).

    lights (GpuLight, 96 B, visible lights sorted by depth)  <- light index lists (uint)
    bounds (vec4, 16 B per light: culling sphere, view space, margins included)
    tree nodes (TreeNode, 16 B)  -> firstLightIndex into the index list
    out_stats (PixelStats, 16 B per pixel), wave_stats (WaveStats, 16 B per 8x8 group),
    view_stats (ViewStats, 32 B: the window's frame sums)

numba kernels write rows of these structs as flat float32/uint32 words; they index them
through the word offsets generated here from the dtype (`words()`), never by hand, so that
reordering a dtype moves the kernels' writes with it.
"""
from __future__ import annotations

import numba
import numpy as np

from scenes.model import LIGHT_TYPES

from . import limits


def mix(x: np.ndarray) -> np.ndarray:
    """The contract's hash of a light id (uint32 arithmetic, wrapping; pixel.glsl's mix_hash): a
    pixel's or froxel's contrib_hash is the XOR of its lights' mix(id)."""
    x = np.asarray(x, np.uint32).copy()
    x ^= x >> np.uint32(16)
    x *= np.uint32(0x7FEB352D)
    x ^= x >> np.uint32(15)
    x *= np.uint32(0x846CA68B)
    x ^= x >> np.uint32(16)
    return x

# numpy field type -> (GLSL type, std430 base alignment, size)
_GLSL_TYPES = {
    (np.dtype(np.float32), ()): ("float", 4, 4),
    (np.dtype(np.uint32), ()): ("uint", 4, 4),
    (np.dtype(np.int32), ()): ("int", 4, 4),
    (np.dtype(np.float32), (2,)): ("vec2", 8, 8),
    (np.dtype(np.uint32), (2,)): ("uvec2", 8, 8),
    (np.dtype(np.float32), (4,)): ("vec4", 16, 16),
    (np.dtype(np.uint32), (4,)): ("uvec4", 16, 16),
}


def _uints(*names: str) -> list:
    """dtype fields of one uint32 each (counters, whose names say what they count)."""
    return [(n, np.uint32) for n in names]


# One visible light, as the shading loop reads it (view space).
GPU_LIGHT = np.dtype([
    ("pos_radius", np.float32, 4),       # xyz view-space position, w influence radius
    ("color_cos_inner", np.float32, 4),  # rgb color * intensity, w cos(inner angle)
    ("dir_cos_outer", np.float32, 4),    # xyz view-space unit direction, w cos(outer angle)
    ("id_type", np.uint32, 4),           # x light id (scene order), y type, zw unused
    ("extent_length", np.float32, 4),    # xyz box half extents, w capsule segment length
    ("right", np.float32, 4),            # xyz box right axis (view space), w unused
])
assert GPU_LIGHT.itemsize == 96

# Culling bound of one light: bounding sphere of its volume (spot: of the cone), view space,
# radius already grown by limits.RADIUS_REL_MARGIN.
GPU_BOUND = np.dtype([("center_radius", np.float32, 4)])
assert GPU_BOUND.itemsize == 16

# Light tree node, tree paper listing 1.  `bits` = isLeaf:1 | lightCount:16 | skipCount:15,
# isLeaf in bit 0 as in the listing's C bit fields (pack_node_bits / unpack_node_bits).
TREE_NODE = np.dtype([
    ("min_depth", np.float32),
    ("max_depth", np.float32),
    ("first_light", np.uint32),
    ("bits", np.uint32),
])
assert TREE_NODE.itemsize == 16

# Per-cell (or per-tile) header: where the cell's nodes / list entries start, and how many.
CELL_RANGE = np.dtype([("offset_count", np.uint32, 2)])
assert CELL_RANGE.itemsize == 8

# Per-pixel counters of a shading pass (the dump contract's evaluated / contrib_count /
# contrib_hash, and the tree nodes visited).
PIXEL_STATS = np.dtype(_uints("evaluated", "contrib_count", "contrib_hash", "nodes"))
assert PIXEL_STATS.itemsize == 16

# Per 8x8 group (one emulated wave): its longest lane loop (the wave's scalar iterations),
# the traversal case bits (CASE_*), and, where a technique has a per-lane loop beside its
# scalar one (zbin), that loop's sum over the lanes and its longest lane.
WAVE_STATS = np.dtype([
    ("iterations", np.uint32),
    ("case_bits", np.uint32),
    ("lane_loops", np.uint32, 2),
])
assert WAVE_STATS.itemsize == 16

# WAVE_STATS.case_bits, OR-ed over a wave's lanes: the traversal case each ran (tree paper
# figure 3: all lists, all trees, mixed; a list-only technique's waves are all lists), and
# whether the group read its one tree from shared memory.  0: no lane shaded.
CASE_LIST, CASE_TREE, CASE_SHARED_TREE = 1, 2, 4
CASE_MIXED = CASE_LIST | CASE_TREE           # also the mask of the case proper
CASES = {CASE_LIST: "list", CASE_TREE: "tree", CASE_MIXED: "mixed"}

# The window's frame sums over covered pixels (64-bit sums as lo/hi words).
VIEW_STATS = np.dtype(_uints("covered", "evaluated_lo", "evaluated_hi", "max_evaluated",
                             "exact_lo", "exact_hi") + [("reserved", np.uint32, 2)])
assert VIEW_STATS.itemsize == 32

STRUCTS = {"GpuLight": GPU_LIGHT, "GpuBound": GPU_BOUND, "TreeNode": TREE_NODE,
           "CellRange": CELL_RANGE, "PixelStats": PIXEL_STATS, "WaveStats": WAVE_STATS,
           "ViewStats": VIEW_STATS}


def words(dtype: np.dtype) -> dict[str, int]:
    """{field: offset in 4-byte words} of a struct of 4-byte scalars, for kernels that write
    its rows as flat float32/uint32 arrays."""
    out = {}
    for f in dtype.names:
        base, offset = dtype.fields[f][:2]
        assert base.base.itemsize == 4 and offset % 4 == 0, f
        out[f] = offset // 4
    return out


# Word offsets of the rows numba kernels write (cpu_prep.lights, cpu_prep.tree).
_L = words(GPU_LIGHT)
LIGHT_POS_RADIUS, LIGHT_COLOR_COS_INNER = _L["pos_radius"], _L["color_cos_inner"]
LIGHT_DIR_COS_OUTER, LIGHT_ID_TYPE = _L["dir_cos_outer"], _L["id_type"]
LIGHT_EXTENT_LENGTH, LIGHT_RIGHT = _L["extent_length"], _L["right"]
LIGHT_WORDS = GPU_LIGHT.itemsize // 4
_N = words(TREE_NODE)
NODE_MIN_DEPTH, NODE_MAX_DEPTH, NODE_FIRST_LIGHT, NODE_BITS = (
    _N["min_depth"], _N["max_depth"], _N["first_light"], _N["bits"])
NODE_WORDS = TREE_NODE.itemsize // 4


def _member(dtype: np.dtype, name: str):
    base, _ = dtype.fields[name]
    key = (base.base, base.shape)
    if key not in _GLSL_TYPES:
        raise TypeError(f"field {name}: no GLSL type for {base}")
    return _GLSL_TYPES[key]


def glsl_struct(name: str, dtype: np.dtype) -> str:
    lines = [f"struct {name} {{"]
    lines += [f"    {_member(dtype, f)[0]} {f};" for f in dtype.names]
    return "\n".join(lines + ["};"])


def std430_offsets(dtype: np.dtype) -> tuple[dict[str, int], int]:
    """Offsets std430 gives each member of the GLSL struct generated from `dtype`, and the
    struct's array stride (size rounded up to its largest member alignment)."""
    offsets, pos, struct_align = {}, 0, 4
    for f in dtype.names:
        _, align, size = _member(dtype, f)
        pos = -(-pos // align) * align
        offsets[f] = pos
        pos += size
        struct_align = max(struct_align, align)
    return offsets, -(-pos // struct_align) * struct_align


def glsl_defines(values: dict[str, int], suffix: str = "u") -> str:
    """`#define NAME 5u` lines of unsigned constants (the shaders' uint arithmetic; suffix
    "": int, e.g. a layout binding)."""
    return "".join(f"#define {k} {int(v)}{suffix}\n" for k, v in values.items())


def glsl_constants() -> dict[str, int]:
    """The constants every shader may read: limits, light type ids, wave case bits."""
    return {"NODE_COUNT_BITS": limits.NODE_COUNT_BITS, "NODE_SKIP_BITS": limits.NODE_SKIP_BITS,
            **{f"LIGHT_{name.upper()}": i for i, name in enumerate(LIGHT_TYPES)},
            "CASE_LIST": CASE_LIST, "CASE_TREE": CASE_TREE, "CASE_MIXED": CASE_MIXED,
            "CASE_SHARED_TREE": CASE_SHARED_TREE}


def glsl_declarations() -> str:
    """All structs plus glsl_constants(), as one GLSL text."""
    structs = "\n".join(glsl_struct(n, d) for n, d in STRUCTS.items())
    return structs + "\n" + glsl_defines(glsl_constants())


# ---- tree node bits, written once ----

@numba.njit(inline="always")
def node_bits(is_leaf, count, skip):
    """isLeaf in bit 0, lightCount in bits 1-16, skipCount in bits 17-31 (listing 1).
    Callers guarantee the widths (tree.leaves_per_cell); pack_node_bits checks them."""
    return np.uint32((is_leaf & 1) | (count << 1) | (skip << (1 + limits.NODE_COUNT_BITS)))


@numba.njit(cache=True)
def _pack_bits(is_leaf, count, skip):
    out = np.empty(is_leaf.shape[0], np.uint32)
    for i in range(out.shape[0]):
        out[i] = node_bits(is_leaf[i], count[i], skip[i])
    return out


def pack_node_bits(is_leaf, count, skip) -> np.ndarray:
    """node_bits for arrays, refusing values that would not fit their bit fields."""
    shape = np.broadcast(is_leaf, count, skip).shape
    is_leaf, count, skip = (np.broadcast_to(np.asarray(a, np.int64), shape).ravel() for a in (is_leaf, count, skip))
    if count.size and (count.min() < 0 or count.max() > limits.NODE_MAX_LIGHTS):
        raise limits.LimitError(f"tree node light count {count.max()} exceeds 16 bits")
    if skip.size and (skip.min() < 0 or skip.max() > limits.NODE_MAX_SKIP):
        raise limits.LimitError(f"tree node skip count {skip.max()} exceeds 15 bits")
    return _pack_bits(is_leaf, count, skip).reshape(shape)


def unpack_node_bits(bits):
    bits = np.asarray(bits, np.uint32).astype(np.int64)
    return (bits & 1).astype(bool), (bits >> 1) & limits.NODE_MAX_LIGHTS, bits >> (1 + limits.NODE_COUNT_BITS)
