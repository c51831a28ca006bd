"""The one GL context of the process (headless EGL), its limits, and pass timing.

Timing: GL timer queries on a real GPU; on llvmpipe they do not time compute dispatches
(DESIGN "Platform facts"), so there a pass is wall clock around the dispatch plus finish().
"""
from __future__ import annotations

from dataclasses import dataclass
import time

import moderngl

from cpu_prep.limits import SOFTWARE_LOOP_BUDGET

from ..errors import UserError

_CTX: moderngl.Context | None = None

# What the native wave API (glsl/wave.glsl, WAVE_NATIVE) needs: ballotARB returns uint64_t.
NATIVE_WAVE_EXTENSIONS = ("GL_ARB_shader_ballot", "GL_ARB_shader_group_vote", "GL_ARB_gpu_shader_int64")


@dataclass(frozen=True)
class Limits:
    max_storage_block: int
    max_texture_size: int
    max_compute_shared: int
    renderer: str
    version: str
    native_ballot: bool

    @property
    def software(self) -> bool:
        r = self.renderer.lower()
        return "llvmpipe" in r or "softpipe" in r or "swrast" in r

    @property
    def loop_budget(self) -> int | None:
        """Loop iterations one shader invocation may run before the driver silently stops
        its loops (software rasterizers), None where there is no such limit."""
        return SOFTWARE_LOOP_BUDGET if self.software else None


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
        _LIMITS = Limits(
            max_storage_block=int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)),
            max_texture_size=int(ctx.info["GL_MAX_TEXTURE_SIZE"]),
            max_compute_shared=int(ctx.info.get("GL_MAX_COMPUTE_SHARED_MEMORY_SIZE", 32768)),
            renderer=str(ctx.info["GL_RENDERER"]),
            version=str(ctx.info["GL_VERSION"]),
            native_ballot=set(NATIVE_WAVE_EXTENSIONS) <= set(ctx.extensions),
        )
    return _LIMITS


class PassTimer:
    """Times GPU passes by name; ms() returns the last frame's figures."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.use_queries = not limits().software
        self._ms: dict[str, float] = {}

    def run(self, name: str, fn) -> None:
        if self.use_queries:
            q = self.ctx.query(time=True)
            with q:
                fn()
            self._ms[name] = self._ms.get(name, 0.0) + q.elapsed / 1e6
            q.release()
        else:
            self.ctx.finish()
            t0 = time.perf_counter()
            fn()
            self.ctx.finish()
            self._ms[name] = self._ms.get(name, 0.0) + (time.perf_counter() - t0) * 1e3

    def take(self) -> dict[str, float]:
        ms, self._ms = self._ms, {}
        return ms
