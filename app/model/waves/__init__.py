"""Per-wave execution figures of a shading pass: a lockstep replay of what every lane of the
technique's shading pass does, over the technique's own built structure.

A GPU runs each 8x8 group of a shading pass (glsl/pixel.glsl) as 64 / W waves of W
consecutive invocations (W = 32: NVIDIA, RDNA wave32; 64: GCN; 8: llvmpipe's native
subgroup), and the lanes of a wave execute each instruction together, idle ones masked.
A technique describes its shading pass (its folder's replay.py: wave_program, found through
app.techniques.parts) as *segments*, one per lane and step:

    segment = (lane, branch, step, head fetch, list of lights)

    step    the alignment key: the segments of one wave with the same (branch, step) run as
            one issued iteration of their loop, lanes without one masked.  A per-lane list
            loop is one step; a tree traversal one step per node visit (a lane's k-th visit
            runs with the other lanes' k-th: lockstep, no re-synchronisation); a scalarized
            loop gives the lanes of one round the same step.
    branch  sides of a divergent if/else that a wave runs one after the other (the hybrid's
            mixed path: its list lanes, then its tree lanes).
    head    the fetch of the step itself (a cell record, a tree node, a bit-array word, a node
            from shared memory): its kind, buffer, byte offset and size, and whether its
            address is wave-uniform by construction (a scalar load where the GPU has a
            scalar unit).
    list    the lights the step evaluates in order, (list, first, count): an inner loop of
            max(count) issued iterations over the step's lanes, each fetching the entry
            (an index list's word, if any) and the light (96 B), then evaluating it.

    wave:   step 0 | cell | light light light          (lanes 0..W-1 in lockstep)
            step 1 | node | light light
            step 2 | node |                             issued = per step 1 + max(count)

Per issued iteration the replay counts the active lanes, the load instructions (vector or
scalar), the distinct 64-byte lines they touch, and, for light iterations, the light shapes
tested and shaded (a shape's code runs when any active lane needs it) and whether an affected
lane is specular (GGX).  Two loops are walked by the replay itself rather than given as
segments, which would cost more than the loops: a lane's tree traversal (Program.add_tree:
one segment a lane, the kernel steps the lanes' traversals in lockstep, a node visit a
step) and a bit-array technique's word loop (Program.bit_words: zbin, raster).  A list
walked as evaluate_all_lights walks every light (LightList.runs: brute, overflowed tiles)
is tested light by light as one list, and each run of 32 lights then issues its set-bit
loop: as many iterations as the run's busiest lane has affecting lights (set_bit).

Per pixel it adds up what the lane evaluated, visited and found affecting, so a test can hold
the replay to the shader's own counters (PixelStats.evaluated, .nodes; contrib_count up to
the float32 rounding of the CPU's copy of the affects test).  Whether a light affects a
lane is decided by a float32 copy of glsl's light_affects_as (affects() below): it only
steers which iterations pay for the shading code, never a count the tests compare exactly.
"""
from __future__ import annotations

from .kinds import (CELL, FIELDS, GROUP, ISSUED, KINDS, LANES, LDS, LDS_NODE, LIGHT, LIGHT_BYTES,
                    LINE, LOAD, MASK_LIGHT, NODE, NTYPES, RUN, SET_BIT, SHARED, SLINES, SLOADS,
                    VLINES, VLOADS, WIDTHS, WORD)
from .program import FrameData, LightList, Program, frame_data, lanes, rounds, sampled
from .figures import Figures, analytic, per_tile
from .lights import affects, light_bounds
from .driver import Replay, replay, tree_visits

__all__ = [
    "WIDTHS", "GROUP", "LINE", "LIGHT_BYTES", "KINDS", "CELL", "NODE", "LDS_NODE", "WORD", "LOAD",
    "LIGHT", "SET_BIT", "MASK_LIGHT", "RUN", "FIELDS", "ISSUED", "LANES", "VLOADS", "SLOADS",
    "VLINES", "SLINES", "LDS", "NTYPES", "SHARED",
    "FrameData", "LightList", "Program", "frame_data", "lanes", "rounds", "sampled",
    "Figures", "analytic", "per_tile", "affects", "light_bounds", "Replay", "replay", "tree_visits",
]
