"""Every bit width, cap and float margin of the culling structures, with its reason.

One module so that the GLSL defines (app.shaders emits them) and the CPU packers read the
same numbers.  Exceeding a bit width raises LimitError or takes a documented fallback;
nothing is ever wrapped.
"""


class LimitError(ValueError):
    """A structure would exceed a bit width or a buffer limit."""


# Light tree node (O'Donnell & Chajdas, listing 1): isLeaf:1 | lightCount:16 | skipCount:15.
NODE_COUNT_BITS = 16
NODE_SKIP_BITS = 15
NODE_MAX_LIGHTS = (1 << NODE_COUNT_BITS) - 1     # 65,535 lights in one leaf
NODE_MAX_SKIP = (1 << NODE_SKIP_BITS) - 1        # 32,767 nodes in one subtree

# Shading workgroup: the emulated 64-lane wave is one 8x8 workgroup (docs/platform.md "Subgroup-style").
WAVE_SIZE = 64
WAVE_DIM = 8

# A software rasterizer (Mesa llvmpipe) silently stops every loop of a shader invocation once
# their iterations together pass 65,535 (LP_MAX_TGSI_LOOP_ITERATIONS; measured here: the
# budget is shared by all loops of the invocation, nested iterations counted).  On such a
# driver a pass whose pixels may meet more lights runs as dispatch windows of DISPATCH_WINDOW
# lights each (glsl/pixel.glsl), leaving room for a tree's nodes (at most 32,767 = 15 bits).
# A loop of k iterations counts k + 1 (its exit runs the body once more, masked: measured).
# evaluate_all_lights (brute, overflowed tiles and cells) spends up to 2 + 3/32 iterations a
# light: per run of 32 the mask loop's 32 + 1, the set-bit loop's at most 32 + 1 and one of
# the run loop (measured: 67 a run with every light affecting, 35 with none), so 34,305 a
# window; beside a list loop of the same window in other lanes of the vector (tiled, fptl:
# 16,385), 50,690 plus fptl's few list-state and spill-scan rounds: in the budget
# (tests/app/techniques/test_loop_budget.py holds both cases with every light affecting).
SOFTWARE_LOOP_BUDGET = 65535
DISPATCH_WINDOW = 16384
WINDOW_ALL = 0xFFFFFFFF            # one window holding every position

# Largest storage block a buffer may be (GL_MAX_SHADER_STORAGE_BLOCK_SIZE on llvmpipe: 128 MiB;
# the app also checks the context's own value before allocating).
MAX_STORAGE_BYTES = 128 << 20



def check_buffer(name: str, nbytes: int) -> None:
    """Refuse a buffer past the storage-block limit, naming it."""
    if nbytes > MAX_STORAGE_BYTES:
        raise LimitError(f"{name} needs {nbytes / 2**20:.0f} MiB, over the "
                         f"{MAX_STORAGE_BYTES >> 20} MiB storage-block limit")


# ---- Float margins: CPU bounds are conservative with respect to the float32 GPU test. ----
# The GPU decides "affects" as dot(P-L, P-L) < r*r in float32.  P-L is correctly rounded per
# component and the dot product adds at most ~5 ulp, so the GPU can accept a point whose true
# distance is up to r * (1 + 3e-7).  CPU bounds use r * (1 + RADIUS_REL_MARGIN): 30x that.
RADIUS_REL_MARGIN = 1e-5
# Pixel positions are interpolated by the rasterizer; a view position stored for a pixel
# projects to within a small fraction of a pixel of its centre.  Screen rectangles grow by this.
PIXEL_MARGIN = 1.0
# Depth-slice boundaries: the GPU computes log(depth) in float32 (error ~1e-6 in slice units);
# the CPU widens a light's depth range by this relative amount before slicing (~2.5e-4 slices).
SLICE_DEPTH_REL_MARGIN = 1e-4

# Paper defaults (tree paper 4 and the first author's testbed): 48-pixel tiles, 16 depth
# slices, a near slice ending at 5 m, ~6 lights per leaf, at most 64 leaves (127 nodes).
DEFAULT_TILE = 48
DEFAULT_SLICES = 16
DEFAULT_NEAR_SLICE_DEPTH = 5.0
DEFAULT_LIGHTS_PER_LEAF = 6
DEFAULT_MAX_LEAVES = 64
