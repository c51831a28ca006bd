"""brute: every frustum-visible light at every pixel; the reference of the exactness check.

    lights[] (GpuLight, visible, depth-sorted)  <-  every pixel loops over all of them
"""
import numpy as np

from ..model import waves
from .base import Technique, add_all_lights, prepare, shading_passes


class Brute(Technique, register_at=10):
    name = "brute"
    summary = "every visible light at every pixel (reference)"
    role = "reference"
    views = ("shaded", "heat", "split")      # no diff: it is the reference

    def build(self, frame, opts):
        return prepare(frame)

    def passes(self, build, opts):
        return shading_passes(build, "shade_brute.comp", longest=len(build.lights))

    def wave_program(self, frame, width):
        prog = waves.Program(frame, width)
        add_all_lights(prog, np.nonzero(frame.shading)[0])     # a wave-uniform loop
        return prog
