"""What a technique would cost on a GPU, without one.

    waves/       per-wave execution figures: a lockstep replay of the technique's own built
                 structure (its wave_program), for waves of 32 and 64 lanes
    cost.py      the GPU cost model: figures -> milliseconds for named GPUs, from their
                 public specifications alone (equations in its docstring)

The replay reads what the shaders read (the frame's buffers, the G-buffer, the cell each
pixel's shading pass recorded in out_cell), never a re-derivation of it, and a test holds
the per-pixel work it implies to the shaders' own counters.
"""
