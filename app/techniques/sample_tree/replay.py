"""sample-tree: its shading pass as the wave replay's segments (app.model.waves).  The
draws are the GPU's own, made again on the CPU (cpu_prep.sample_tree's float32 twins of the
PCG stream, the descent and the leaf draw), so the replay walks the nodes and lights the
shader did:

    step 0                 the tile record (ranges[cell])
    step 1                 the root's depth pieces (sample_nodes[root]): is a leaf reached?
    per sample k           the root, then per level its two children (kind node; lanes
                           already at their leaf masked: the k-th sample's j-th level of
                           every lane together), then the drawn light (kind light)

The leaf's bound passes over its lights are priced with the light iteration's code (the
sample loop's body), not as loads of their own."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts, sample_tree as st, sampling

from ..blocks import cell_ranges
from ..options import sample_uniforms
from ..replay_walks import cell_head, entry_list, per_frame

NODE, SAMPLE_NODE = layouts.TREE_NODE.itemsize, st.SAMPLE_NODE.itemsize


def wave_program(technique, frame, width):
    from ...model import waves
    prog = waves.Program(frame, width)
    b, opts = frame.build, frame.opts
    lanes = np.nonzero(frame.shading)[0]
    if frame.live is not None:
        lanes = lanes[frame.live[lanes]]
    prog.add(lanes, step=0, head=cell_head(prog, lanes))
    ranges = cell_ranges(b)
    base, count = ranges[frame.cell[lanes], 0], ranges[frame.cell[lanes], 1]
    lanes, base = lanes[count > 0], base[count > 0]
    prog.add(lanes, step=1, head=("node", "sample_nodes", base * SAMPLE_NODE, SAMPLE_NODE, False))
    nodes, sample, pieces = b.buffers["nodes"], b.buffers["sample_nodes"], b.buffers["depth_pieces"]
    P, depth = frame.position[lanes, :3], frame.position[lanes, 3]
    ok = st.enterable(sample, pieces, base, depth) if len(lanes) else np.zeros(0, bool)
    lanes, base, P, depth = lanes[ok], base[ok], P[ok], depth[ok]
    if not len(lanes):
        return prog
    entries = b.buffers["entries"].astype(np.int64)
    lid = entry_list(prog, entries, opts.duplicated)

    def descents():          # the GPU's draws: the same at every wave width (per_frame)
        state, out = sampling.pixel_streams(lanes, opts.sample_seed, opts.sample_frame), []
        for _ in range(sample_uniforms(opts)["u_samples"]):
            leaf, levels = st.descend(nodes, sample, pieces, base, P, depth, state)
            out.append((levels, st.draw_leaf(nodes, entries, b.lights.gpu, leaf, P, state)))
        return out
    draws = per_frame(frame, "sample-tree", descents)
    deepest = max(len(levels) for levels, _ in draws)
    step = 2
    for levels, entry in draws:
        prog.add(lanes, step=step, head=("node", "nodes", base * NODE, NODE, False))
        for j, (act, left, right) in enumerate(levels):
            for side, child in enumerate((left, right)):
                prog.add(lanes[act], step=step + 1 + 2 * j + side,
                         head=("node", "nodes", child[act] * NODE, NODE, False))
        prog.add(lanes, step=step + 1 + 2 * deepest, lights=(lid, entry, 1, False))
        step += 2 + 2 * deepest
    return prog
