"""The one GL context of the process (headless EGL), its limits, and pass timing.

Timing: GL timer queries on a real GPU; on llvmpipe they do not time compute dispatches
(docs/platform.md "Platform facts"), so there a pass is wall clock around the dispatch plus finish().
"""
from __future__ import annotations

from dataclasses import dataclass, field
import re
import time

import moderngl

from cpu_prep.limits import SOFTWARE_LOOP_BUDGET

from ..errors import UserError
from . import rawgl

_CTX: moderngl.Context | None = None

# The native wave paths of glsl/wave.glsl, by their value of its WAVE_NATIVE define (0: the
# group emulation), and the #extension lines each needs: the shader loader emits them for a
# stage compiled with that value.
WAVE_ARB, WAVE_KHR = 1, 2
WAVE_EXTENSIONS = {
    WAVE_ARB: ("GL_ARB_shader_ballot", "GL_ARB_gpu_shader_int64"),     # ballotARB is a uint64_t
    WAVE_KHR: ("GL_KHR_shader_subgroup_basic", "GL_KHR_shader_subgroup_vote",
               "GL_KHR_shader_subgroup_ballot", "GL_KHR_shader_subgroup_arithmetic"),
}
WAVE_PATHS = {"": 0, "arb": WAVE_ARB, "khr": WAVE_KHR}     # Limits.native_wave -> WAVE_NATIVE
# The ARB path's (GL and GLSL names agree there), for callers that pass them themselves.
NATIVE_WAVE_EXTENSIONS = WAVE_EXTENSIONS[WAVE_ARB]

# GL_KHR_shader_subgroup's queries and the bits the wave API needs: its four function
# families in the compute stage (shading passes) and the fragment stage (raster's compaction).
GL_SUBGROUP_SIZE_KHR, GL_SUBGROUP_SUPPORTED_STAGES_KHR, GL_SUBGROUP_SUPPORTED_FEATURES_KHR = (
    0x9532, 0x9533, 0x9534)
GL_FRAGMENT_SHADER_BIT, GL_COMPUTE_SHADER_BIT = 0x2, 0x20
KHR_FEATURES = {"basic": 0x1, "vote": 0x2, "arithmetic": 0x4, "ballot": 0x8}
KHR_STAGES = GL_COMPUTE_SHADER_BIT | GL_FRAGMENT_SHADER_BIT
KHR_MAX_SUBGROUP = 128      # a uvec4 ballot (wave.glsl) holds 128 lanes


def native_wave_path(extensions, subgroup_size: int = 0, stages: int = 0, features: int = 0) -> str:
    """The native wave path a context gets: 'khr' where GL_KHR_shader_subgroup has every
    feature the wave API uses in every stage that uses it (and a size its ballots hold),
    else 'arb' where GL_ARB_shader_ballot and 64-bit integers exist, else '' (emulation)."""
    need = sum(KHR_FEATURES.values())
    if ("GL_KHR_shader_subgroup" in extensions and stages & KHR_STAGES == KHR_STAGES
            and features & need == need and 0 < subgroup_size <= KHR_MAX_SUBGROUP):
        return "khr"
    return "arb" if set(WAVE_EXTENSIONS[WAVE_ARB]) <= set(extensions) else ""


@dataclass(frozen=True)
class Limits:
    max_storage_block: int
    max_texture_size: int
    max_compute_shared: int
    renderer: str
    version: str
    native_ballot: bool        # the ARB path's extensions (WAVE_NATIVE = WAVE_ARB compiles)
    native_wave: str = ""      # the selected path: "khr", "arb" or "" (the emulation only)
    subgroup_size: int = 0     # GL_SUBGROUP_SIZE_KHR; 0 without KHR (ARB tells shaders only)
    max_work_groups: tuple[int, int, int] = (65535, 65535, 65535)   # GL's minimum, per axis
    # glDispatchComputeIndirect (core since 4.3) as moderngl offers it (run_indirect, 5.9+):
    # without it feature variants fall back to the general shading program
    indirect_dispatch: bool = True
    # samples -> the driver's sample positions, queried on first use (sample_positions)
    _positions: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def sample_positions(self, samples: int) -> tuple[tuple[float, float], ...]:
        """The driver's positions (within the pixel, 0..1) of the samples of a
        `samples`-sample target, queried once per count on the process's context (MSAA
        culling places its dilation by them)."""
        if samples not in self._positions:
            self._positions[samples] = rawgl.sample_positions(context(), samples)
        return self._positions[samples]

    @property
    def wave_define(self) -> int:
        """WAVE_NATIVE for a pass that asks for native waves (0: the emulation)."""
        return WAVE_PATHS[self.native_wave]

    @property
    def software(self) -> bool:
        r = self.renderer.lower()
        return "llvmpipe" in r or "softpipe" in r or "swrast" in r

    @property
    def loop_budget(self) -> int | None:
        """Loop iterations one shader invocation may run before the driver silently stops
        its loops (software rasterizers), None where there is no such limit."""
        return SOFTWARE_LOOP_BUDGET if self.software else None

    @property
    def loop_lanes(self) -> int:
        """Invocations whose loop iterations share that budget: llvmpipe runs 8 (256-bit
        vectors of 32-bit lanes, its renderer string's "256 bits") in lockstep, and counts
        the vector's iterations, so lanes whose loops run at different steps (tree leaves)
        add up (measured: city, 1M lights, a tree pixel lost 8,708 of 42,779 lights in
        16,384-light windows).  1 where there is no budget."""
        if not self.software:
            return 1
        m = re.search(r"(\d+) bits", self.renderer)
        return max(1, int(m.group(1)) // 32) if m else 8


def context() -> moderngl.Context:
    """The process's EGL context (OpenGL 4.3 core or newer), created on first use."""
    global _CTX
    if _CTX is None:
        try:
            _CTX = moderngl.create_context(standalone=True, backend="egl", require=430)
        except Exception as exc:  # moderngl raises plain Exception subclasses here
            raise UserError(
                "no OpenGL 4.3 context through EGL "
                f"({' '.join(str(exc).split())[:160]}); on Debian install libegl1 libegl-mesa0 "
                "libgl1-mesa-dri, or run the README's set-up") from None
    return _CTX


def use_context(ctx: moderngl.Context) -> None:
    """Adopt a context made elsewhere (a window's) as the process's one context."""
    global _CTX, _LIMITS
    _CTX, _LIMITS = ctx, None


_LIMITS: Limits | None = None


def limits() -> Limits:
    """GL limits, read once."""
    global _LIMITS
    if _LIMITS is None:
        ctx = context()
        exts = set(ctx.extensions)
        khr = (gl_integers(GL_SUBGROUP_SIZE_KHR, GL_SUBGROUP_SUPPORTED_STAGES_KHR,
                           GL_SUBGROUP_SUPPORTED_FEATURES_KHR)
               if "GL_KHR_shader_subgroup" in exts else (0, 0, 0))
        _LIMITS = Limits(
            max_storage_block=int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)),
            max_texture_size=int(ctx.info["GL_MAX_TEXTURE_SIZE"]),
            max_compute_shared=int(ctx.info.get("GL_MAX_COMPUTE_SHARED_MEMORY_SIZE", 32768)),
            renderer=str(ctx.info["GL_RENDERER"]),
            version=str(ctx.info["GL_VERSION"]),
            native_ballot=set(NATIVE_WAVE_EXTENSIONS) <= exts,
            native_wave=native_wave_path(exts, *khr),
            subgroup_size=khr[0],
            max_work_groups=tuple(int(n) for n in ctx.info.get(
                "GL_MAX_COMPUTE_WORK_GROUP_COUNT", (65535,) * 3)),
            indirect_dispatch=hasattr(moderngl.ComputeShader, "run_indirect"),
        )
    return _LIMITS


# glGetIntegerv for the names ctx.info lacks (the raw GL module's; tests and callers use this name)
gl_integers = rawgl.get_integers


class PassTimer:
    """Times GPU passes by name; ms() returns the last frame's figures."""

    def __init__(self, ctx: moderngl.Context, use_queries: bool | None = None):
        self.ctx = ctx
        self.use_queries = not limits().software if use_queries is None else use_queries
        # one GL_TIME_ELAPSED query, reused: its result is read (blocking) before the next pass
        # begins it again, and moderngl's Query has no release of its own
        self._query = ctx.query(time=True) if self.use_queries else None
        self._ms: dict[str, float] = {}

    def run(self, name: str, fn) -> None:
        if self.use_queries:
            with self._query:
                fn()
            self._ms[name] = self._ms.get(name, 0.0) + self._query.elapsed / 1e6
        else:
            self.ctx.finish()
            t0 = time.perf_counter()
            fn()
            self.ctx.finish()
            self._ms[name] = self._ms.get(name, 0.0) + (time.perf_counter() - t0) * 1e3

    def take(self) -> dict[str, float]:
        ms, self._ms = self._ms, {}
        return ms
