"""The window's modelled GPU time (app.model): the frame on screen, replayed on 32- and
64-lane waves and costed on the model's named GPUs, once the view and the configuration have
been still for SETTLE_S (a replay of a window-sized frame takes a few hundred milliseconds,
so flying is not held up; scripted runs model their first still frame).  The HUD shows it
beside the llvmpipe time the frame measured."""
from __future__ import annotations

from ..model import cost, predict

SETTLE_S = 1.0
REPLAY_PIXELS = 1 << 18       # the replay walks about this many pixels (every k-th 8x8 group)


class FrameModel:
    def __init__(self):
        self.key = None
        self.ms: dict[str, dict] = {}

    def update(self, key, still_s: float, scripted: bool, rerender) -> bool:
        """Model the frame of `key` if it is new and has been still long enough: `rerender()`
        renders it once more with its figures (the raster twin's counts) and returns
        (renderer, technique, opts, result)."""
        if key == self.key or (not scripted and still_s < SETTLE_S):
            return False
        renderer, technique, opts, result = rerender()
        w, h = renderer.size
        sample = max(1, round(w * h / REPLAY_PIXELS))
        figures = predict.modelled_or_none(renderer, technique, result, opts, sample=sample)
        self.ms = predict.modelled(figures) if figures is not None else None
        self.key = key
        return True

    def line(self, key) -> str:
        """The HUD's line: modelled lighting ms (culling + shading) per GPU."""
        if self.ms is None:
            return "modelled GPU ms: this technique gives no wave program (app.model)"
        if not self.ms:
            return f"modelled GPU ms (v{cost.MODEL_VERSION}): once the view rests {SETTLE_S:g} s"
        parts = " ".join(f"{g.key} {self.ms[g.key]['cull'] + self.ms[g.key]['shade']:.2g}"
                         for g in cost.GPUS if g.key in self.ms)
        stale = "" if key == self.key else " (before the move)"
        return f"modelled GPU ms (v{cost.MODEL_VERSION}): {parts}{stale}"
