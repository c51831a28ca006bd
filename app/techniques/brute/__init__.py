"""brute: every frustum-visible light at every pixel; the reference of the exactness check.

    lights[] (GpuLight, visible, depth-sorted)  <-  every pixel loops over all of them:
                                                    an affects mask per run of 32, then
                                                    the shading of its set bits in order
"""

from ..base import Technique, prepare, shading_passes
from ..options import StochasticOptions


class Brute(Technique, register_at=10):
    name = "brute"
    summary = "every visible light at every pixel (reference)"
    role = "reference"
    views = ("shaded", "heat", "split")      # no diff: it is the reference
    froxels = "all"                          # a fog scene: every visible light a candidate

    # stochastic light culling: the same budget, seed and frame draw the same ranges here,
    # so every technique is checked against brute under its own draw (app.exactness)
    class Options(StochasticOptions):
        pass

    def build(self, frame, opts):
        return prepare(frame, opts=opts)

    def passes(self, build, opts):
        return shading_passes(build, "shade_brute.comp", longest=len(build.lights))

