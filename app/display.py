"""The display's own options (exposure, ambient, the heat scale, the split, the target frame
rate), declared once: the window's panel and the command lines of the window and capture
take the same ranges.  No GL, nothing of the window."""
from __future__ import annotations


# the target frame rate of the window's dynamic resolution (app.window.scale), declared here
# with the display's other options
DEFAULT_FPS = 10.0


def _display_specs():
    from . import images
    from .techniques.options import OptionSpec
    return {s.name: s for s in (
        # a factor on the radiance (the panel's slider shows it as EV, log2 of it); the
        # range is the one automatic exposure keeps to
        OptionSpec("exposure", float, 1.0, "a factor on the radiance ('auto' on the command "
                   "line: the lit pixels' luminance percentile maps to a target)",
                   lo=images.EXPOSURE_RANGE[0], hi=images.EXPOSURE_RANGE[1]),
        OptionSpec("ambient", float, images.AMBIENT,
                   "display only: ambient x albedo added after the exposure, so geometry shows "
                   "with few lights (0: none)", lo=0.0, hi=1.0),
        OptionSpec("heat_max", float, 0.0, "top of the heat scale; 0: the frame's largest count "
                   "(fix it so two runs compare)", lo=0.0, hi=1e7),
        OptionSpec("split_at", float, 0.0, "where the split is, a fraction of the width (0: the "
                   "middle of what the panel leaves visible)", lo=0.0, hi=0.95),
        # dynamic resolution (app.window.scale): the window's own, not capture's
        OptionSpec("target_fps", float, DEFAULT_FPS, "while the camera moves, render at the "
                   "scale that holds this frame rate (full size at rest; the shaded view only); "
                   "0: always full size", lo=0.0, hi=240.0),
    )}


# {name: OptionSpec}: the display's options, read by the panel (app.window.panel) and, for
# exposure, ambient and heat_max, the command lines of the window and capture
# (app.cli.add_display_args)
DISPLAY = _display_specs()
DISPLAY_FLAGS = ("exposure", "ambient", "heat_max")      # the ones the command lines take
