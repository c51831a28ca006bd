"""brute: every frustum-visible light at every pixel; the reference of the exactness check.

    lights[] (GpuLight, visible, depth-sorted)  <-  every pixel loops over all of them
"""
from .base import Technique, prepare


class Brute(Technique):
    name = "brute"
    summary = "every visible light at every pixel (reference)"
    shader = "shade_brute.comp"

    def build(self, frame, opts):
        return prepare(frame, opts)
