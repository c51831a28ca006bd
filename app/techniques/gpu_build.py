"""--build cpu|gpu: where a technique's structures are built (issue 23 item 1).

cpu (the default) is the CPU stage (cpu_prep, numba); gpu builds the same buffers, bit for
bit, as compute passes of the frame graph before the shading pass (app/gpu_build), timed
like every pass (meta gpu_ms: build_cull, build_sort, build_bin; the pack, still on the
CPU, in setup_ms build_pack).  The dump's meta says which ran: options.build (the choice's
index) and stats.build (its name).

Built on the GPU so far: clustered (cull, depth sort, binning).  zbin's z-bins and bit
arrays, the tree build with skip counts and listing 2's choice are not yet; those
techniques do not take the option (docs/cpu_stage.md).
"""
from __future__ import annotations

from dataclasses import dataclass

from cpu_prep import caps

from ..errors import UserError
from ..gpu_build import lists as gpulists
from .base import make_grid
from .options import TechniqueOptions, cap_policy, choice, stochastic

CPU, GPU = "cpu", "gpu"


@dataclass(frozen=True)
class BuildOptions(TechniqueOptions):
    build: int = choice(CPU, (CPU, GPU), "where the culling structures are built (cpu: the CPU "
                                         "stage; gpu: compute passes, bit for bit the same buffers)")

    def check_modes(self) -> None:
        super().check_modes()
        if self.choice_name("build") != GPU:
            return
        taken = [flag for flag, on in (("--duplicated", getattr(self, "duplicated", False)),
                                       ("--stochastic", stochastic(self) is not None),
                                       ("--cap-policy", cap_policy(self) != caps.NONE)) if on]
        if taken:
            raise UserError(f"--build gpu with {', '.join(taken)}: not offered together (the GPU "
                            f"build makes index lists of every visible light; use --build cpu)")


def on_gpu(opts) -> bool:
    return isinstance(opts, BuildOptions) and opts.choice_name("build") == GPU


def build_lists(frame, opts, slices: int, shade):
    """A list technique's Build whose cull, sort and binning run on the GPU: the grid and
    the scene's lights go up; its steps (build.data[gpulists.BUILD_STEPS], which the
    renderer runs in place of the technique's passes) end in `shade(b)`: the technique's
    own passes, once the longest list (b.data["longest_list"]) is known."""
    b = gpulists.Build(frame=frame, lights=gpulists.unbuilt_lights(frame))
    b.grid = make_grid(frame, opts, slices)
    b.buffers["scene_lights"] = gpulists.scene_words(frame.lights)
    b.buffers["gb_slice_table"] = gpulists.slice_table(b.grid)     # the grid's, not the lights'
    b.stats.update(build=GPU, cells=b.grid.cells)

    def shading(longest: int):
        b.data["longest_list"] = longest
        return list(shade(b)) + [gpulists.readback_step(b)]
    b.data["shade"] = shading
    b.data[gpulists.BUILD_STEPS] = gpulists.cull_and_sort(frame) + [gpulists.pack_step(b, gpulists.count_cells)]
    return b
