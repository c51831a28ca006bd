"""predict.frame_figures(segments=N): a shading program of more than N segments is replayed
over a sparser sample of 8x8 groups, for every width, and scaled like any sampled replay."""
import pytest

from app.model import predict
from app.model.waves import program as wp
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes import load_scene


def test_a_program_past_the_segment_limit_is_replayed_sparser(gl, monkeypatch):
    walked = []
    segments = wp.Program.segments

    def spy(self):
        walked.append(self.segment_count())
        return segments(self)
    monkeypatch.setattr(wp.Program, "segments", spy)
    t = REGISTRY["sample-ris"]
    with Renderer(load_scene("arena", lights=1024, seed=0), (128, 72)) as r:
        res = r.render(t, 0)
        whole = predict.frame_figures(r, t, res)
        full, walked[:] = list(walked), []
        limited = predict.frame_figures(r, t, res, segments=full[0] // 3)
        sparse, walked[:] = list(walked), []
        assert predict.frame_figures(r, t, res, segments=full[0]) and walked == full  # not past it
    assert len(full) == len(sparse) == len(whole)              # one program a width
    assert all(s <= f // 3 + f // 10 for s, f in zip(sparse, full)), (sparse, full)
    for w in whole:
        a, b = whole[w][predict.SHADE], limited[w][predict.SHADE]
        assert b.shading_pixels == a.shading_pixels            # scaled back to the whole frame
        assert b.loops[:, 0].sum() == pytest.approx(a.loops[:, 0].sum(), rel=0.15)
