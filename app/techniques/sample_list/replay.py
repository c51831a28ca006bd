"""sample-list: its shading pass as the wave replay's segments (app.model.waves).  The draws
are the GPU's own, made again on the CPU bit for bit (cpu_prep.sampling's twin of the PCG
streams and of draw_entry), so the replay walks the lights the shader shaded:

    step 0                  the cell record (ranges[cell])
    per sample, per probe of its binary search:  a CDF word (kind word)
    per sample              its drawn light (kind light): one list position, entries[e]

(replay_walks.add_cdf_draws).  The two CDF words of the drawn entry's probability are priced
with the light iteration's code; their loads are not counted apart (the search's last probe
read one of them)."""
from __future__ import annotations

from cpu_prep import sampling

from ..replay_walks import add_cdf_draws, entry_list, listed_lanes


def wave_program(technique, frame, width):
    from ...model import waves
    prog = waves.Program(frame, width)
    opts = frame.opts
    lanes, first, count = listed_lanes(prog, frame)

    def masses():
        state, out = sampling.pixel_streams(lanes, opts.sample_seed, opts.sample_frame), []
        for _ in range(opts.light_samples):
            state, u = sampling.next_mass(state)
            out.append(u)
        return out
    add_cdf_draws(prog, lanes, first, count, masses, entry_list(prog, frame.build.buffers["entries"]),
                  step0=1, key="sample-list")
    return prog

