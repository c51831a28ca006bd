"""Indirect dispatch in the frame graph (Pass.indirect, glDispatchComputeIndirect): its
arguments come from a buffer an earlier pass wrote, read at dispatch time; the graph is
checked before the first dispatch, as every pass is."""
import numpy as np
import pytest

from app.pipeline import features as feat
from app.pipeline.passes import Buffer, Draw, Pass, frame_outputs
from app.pipeline.renderer import Renderer
from app.pipeline.validate import GraphError, check_steps
from app.techniques import REGISTRY
from tests.helpers import make_scene, random_lights

FILES = feat.virtual_files(("point",))
PROVIDED = {"tile_masks": (4, None), "lights": (96, None)}

ARGS = Pass("count", "variant_compact.comp", reads=("tile_masks",),
            writes={"variant_args": Buffer(12 * 128, cleared=True), "variant_tiles": Buffer(4 * 128)},
            groups=(1, 1, 1), defines={"VARIANT_TILE": 8},
            uniforms={"u_variant_tiles": 1, "u_variant_tiles_x": 1})


def shade(indirect):
    return Pass("shade", "shade_brute.comp", reads=("lights", "variant_tiles"), groups=(1, 1, 1),
                indirect=indirect, defines={"VARIANT_TILE": 8}, uniforms={"u_variant_base": 0})


@pytest.mark.parametrize("indirect, error", [
    (("nowhere", 0), "dispatches indirectly from buffer 'nowhere'"),
    (("variant_args", 2), "not a multiple of 4"),
    (("variant_args", 12 * 128), "12 bytes of group counts"),
    (("variant_args",), "is not (buffer, byte offset)")])
def test_bad_indirect_arguments_fail_before_any_dispatch(indirect, error):
    with pytest.raises(GraphError, match=error.replace("(", r"\(").replace(")", r"\)")):
        check_steps([ARGS, shade(indirect)], PROVIDED, virtual=FILES)


def test_good_indirect_arguments_pass():
    check_steps([ARGS, shade(("variant_args", 12 * 127))], PROVIDED, virtual=FILES)


def test_raster_passes_do_not_dispatch_indirectly():
    with pytest.raises(ValueError, match="only a compute pass"):
        Pass("p", ("a.vert", "b.frag"), draw=Draw(), indirect=("x", 0))


def test_an_indirect_dispatch_runs_the_groups_its_buffer_holds(gl):
    """The renderer reads the counts from the buffer: x groups of the listed tiles only."""
    scene = make_scene(random_lights(np.random.default_rng(0), 4, (-5, 0, -20), (5, 4, 0)), size=(16, 8))
    with Renderer(scene) as r:
        r.render(REGISTRY["brute"])
        r.upload("args", np.array([1, 1, 1], np.uint32))
        r.upload("variant_tiles", np.array([1], np.uint32))        # tile (1, 0): pixels 8..15
        r.buffer("out_stats", 16 * 8 * 16).write(b"\xff" * (16 * 8 * 16))
        p = Pass("shade", "shade_brute.comp", reads=("lights", "variant_tiles"),
                 writes=frame_outputs(16, 8),
                 groups=(2, 1, 1), indirect=("args", 0), defines={"VARIANT_TILE": 8},
                 uniforms={"u_variant_base": 0})
        r.run([p], FILES, uniforms={"u_size": (16, 8), "u_light_count": 4, "u_window": (0, 0xFFFFFFFF)})
        stats = r.read("out_stats").reshape(8, 16)
    written = stats["evaluated"] != 0xFFFFFFFF
    assert written[:, 8:].all() and not written[:, :8].any()
