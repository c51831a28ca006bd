"""The replay's numbers: the wave widths, the loop kinds and the fields counted per kind
(the rows and columns of Figures.loops), and the fetch sizes they are counted in."""
from __future__ import annotations

from cpu_prep import layouts, limits
from scenes.model import LIGHT_TYPES

WIDTHS = (32, 64)               # the wave widths the model reports (NVIDIA / RDNA, GCN)
GROUP = 8                       # the shading pass's 8x8 groups (pixel.glsl)
LINE = 64                       # bytes of a cache line in the figures
LIGHT_BYTES = layouts.GPU_LIGHT.itemsize

# Loop kinds (rows of Figures.loops): what one issued iteration of that kind does.  The
# shading pass's (the kernels below index the first six by number), then the culling
# passes' (a replay.py's cull_figures: counted from their fixed loops, analytic()).
KINDS = ("cell", "node", "lds_node", "word", "load", "light",
         "depth", "cull_test", "prune", "aabb", "vertex", "fragment", "set_bit", "mask_light")
CELL, NODE, LDS_NODE, WORD, LOAD, LIGHT = range(6)
SET_BIT = KINDS.index("set_bit")   # evaluate_all_lights' set-bit loop (LightList.runs)
MASK_LIGHT = KINDS.index("mask_light")   # ... and its affects-mask loop over a run's lights
RUN = 32                           # its lights a mask (glsl/pixel.glsl LIGHT_RUN)
# Fields per kind: issued iterations, active lane-iterations, vector load instructions,
# scalar load instructions, distinct lines of the vector loads, of the scalar loads, lanes
# reading shared memory (LDS).
FIELDS = ("issued", "lanes", "vector_loads", "scalar_loads", "vector_lines", "scalar_lines",
          "lds_reads")
ISSUED, LANES, VLOADS, SLOADS, VLINES, SLINES, LDS = range(len(FIELDS))
NTYPES = len(LIGHT_TYPES)
SHARED = -2                     # head buffer: shared memory (no global fetch)
_COUNT_BITS = limits.NODE_COUNT_BITS    # tree node bits (layouts.node_bits)
