"""sample-list: its shading pass as the wave replay's segments (app.model.waves).  The draws
are the GPU's own, made again on the CPU bit for bit (cpu_prep.sampling's twin of the PCG
streams and of draw_entry), so the replay walks the lights the shader shaded:

    step 0                  the cell record (ranges[cell])
    per sample k, per probe j of its binary search:  a CDF word (kind word), lanes whose
                            search ended earlier masked (lockstep: the k-th sample's j-th
                            probe of every lane together)
    per sample k            its drawn light (kind light): one list position, entries[e]

The two CDF words of the drawn entry's probability are priced with the light iteration's
code; their loads are not counted apart (the search's last probe read one of them)."""
from __future__ import annotations

import numpy as np

from cpu_prep import sampling

from ..blocks import cell_ranges
from ..replay_walks import cell_head, entry_list


def wave_program(technique, frame, width):
    from ...model import waves
    prog = waves.Program(frame, width)
    add_sample_lists(prog, frame, frame.opts.light_samples)
    return prog


def add_sample_lists(prog, frame, samples: int, entry_buf: str = "entries") -> None:
    """The cell record, then `samples` draws (search probes, one light) per shading lane
    whose cell lists a light."""
    b, opts = frame.build, frame.opts
    ranges = cell_ranges(b)
    lanes = np.nonzero(frame.shading)[0]
    if frame.live is not None:
        lanes = lanes[frame.live[lanes]]
    prog.add(lanes, step=0, head=cell_head(prog, lanes))
    first, count = ranges[frame.cell[lanes], 0], ranges[frame.cell[lanes], 1]
    lanes, first, count = lanes[count > 0], first[count > 0], count[count > 0]
    if not len(lanes):
        return
    cdf = b.buffers["sample_cdf"]
    lid = entry_list(prog, b.buffers["entries"], False, entry_buf)
    state = sampling.pixel_streams(lanes, opts.sample_seed, opts.sample_frame)
    draws = []
    for _ in range(samples):
        state, u = sampling.next_mass(state)
        draws.append(sampling.draw_entries(cdf, first, count, u))
    depth = max((len(p) for _, p in draws), default=0)     # the longest search of the frame
    for k, (entry, probes) in enumerate(draws):
        base = 1 + k * (depth + 1)
        for j, probe in enumerate(probes):
            on = probe >= 0
            prog.add(lanes[on], step=base + j, head=("word", "sample_cdf", 4 * probe[on], 4, False))
        prog.add(lanes, step=base + depth, lights=(lid, entry, 1, False))
