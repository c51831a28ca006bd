"""The GL that moderngl 5 does not wrap, through ctypes: glGetIntegerv for names ctx.info
lacks, stencil state, depth (+ stencil) renderbuffers with their own framebuffer, and the
driver's sample positions.

The entry points come from the vendor-neutral GL library, which dispatches to whichever
context is current (the headless EGL one or a window's), so nothing here holds a context.
"""
from __future__ import annotations

import ctypes

from ..errors import UserError

STENCIL_TEST = 0x0B90
STENCIL_FUNCS = {"always": 0x0207, "equal": 0x0202, "notequal": 0x0205}
STENCIL_OPS = {"keep": 0x1E00, "zero": 0, "replace": 0x1E01}

_U, _I, _PU = ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)
_SIGNATURES = {
    "glGetIntegerv": (_U, ctypes.POINTER(_I)), "glGetError": (),
    "glStencilFunc": (_U, _I, _U), "glStencilOp": (_U, _U, _U), "glStencilMask": (_U,),
    "glClearStencil": (_I,), "glClearDepth": (ctypes.c_double,),
    "glDepthMask": (ctypes.c_ubyte,), "glClear": (_U,),
    "glGenRenderbuffers": (_I, _PU), "glDeleteRenderbuffers": (_I, _PU),
    "glBindRenderbuffer": (_U, _U), "glRenderbufferStorageMultisample": (_U, _I, _U, _I, _I),
    "glGenFramebuffers": (_I, _PU), "glDeleteFramebuffers": (_I, _PU),
    "glBindFramebuffer": (_U, _U), "glFramebufferRenderbuffer": (_U, _U, _U, _U),
    "glCheckFramebufferStatus": (_U,),
    "glGetMultisamplefv": (_U, _U, ctypes.POINTER(ctypes.c_float)),
}
_RETURNS = {"glGetError": _U, "glCheckFramebufferStatus": _U}
_LIB: list = []      # [the library or None], loaded once


def _library():
    """The GL library with the signatures above, or None where neither name loads."""
    if not _LIB:
        lib = None
        for name in ("libOpenGL.so.0", "libGL.so.1"):
            try:
                lib = ctypes.CDLL(name)
                break
            except OSError:
                continue
        if lib is not None:
            for fn, args in _SIGNATURES.items():
                getattr(lib, fn).argtypes = list(args)
                getattr(lib, fn).restype = _RETURNS.get(fn)
        _LIB.append(lib)
    return _LIB[0]


def lib():
    """The GL library; one line where it is missing (stencil and own targets need it)."""
    found = _library()
    if found is None:
        raise UserError("stencil and own depth targets need libOpenGL.so.0 or libGL.so.1")
    return found


def get_integers(*names: int) -> tuple[int, ...]:
    """glGetIntegerv of the current context for names moderngl's ctx.info lacks; 0 for a
    name the driver refuses (its GL error is taken, so it is not left for later calls; an
    error left by earlier calls is taken first, so it is not read as this one's)."""
    gl = _library()
    if gl is None:
        return (0,) * len(names)
    out = []
    for name in names:
        for _ in range(16):          # GL keeps one flag per kind of error
            if not gl.glGetError():
                break
        v = ctypes.c_int(0)
        gl.glGetIntegerv(name, ctypes.byref(v))
        out.append(0 if gl.glGetError() else v.value)
    return tuple(out)


class DepthTarget:
    """A float depth (+ 8-bit stencil) renderbuffer, `samples` per pixel, in its own
    framebuffer (wrapped for moderngl's use() and depth_mask)."""
    _GL_RB, _GL_FB = 0x8D41, 0x8D40

    def __init__(self, ctx, name: str, size: tuple[int, int], samples: int = 0,
                 stencil: bool = False):
        gl = lib()
        self.size, self.samples, self.stencil = size, int(samples), bool(stencil)
        self.rb, self.fb, self.fbo = ctypes.c_uint(), ctypes.c_uint(), None
        gl.glGenRenderbuffers(1, ctypes.byref(self.rb))
        gl.glBindRenderbuffer(self._GL_RB, self.rb.value)
        fmt = 0x8CAD if stencil else 0x8CAC          # DEPTH32F_STENCIL8 | DEPTH_COMPONENT32F
        gl.glRenderbufferStorageMultisample(self._GL_RB, self.samples, fmt, *size)
        gl.glBindRenderbuffer(self._GL_RB, 0)
        gl.glGenFramebuffers(1, ctypes.byref(self.fb))
        gl.glBindFramebuffer(self._GL_FB, self.fb.value)
        attach = 0x821A if stencil else 0x8D00       # DEPTH_STENCIL_ATTACHMENT | DEPTH_ATTACHMENT
        gl.glFramebufferRenderbuffer(self._GL_FB, attach, self._GL_RB, self.rb.value)
        status = gl.glCheckFramebufferStatus(self._GL_FB)
        gl.glBindFramebuffer(self._GL_FB, 0)
        if status != 0x8CD5:
            self.release()
            raise UserError(f"target '{name}' ({size[0]}x{size[1]}, {samples} samples, "
                            f"stencil {stencil}) is not supported here (status {status:#x})")
        self.fbo = ctx.detect_framebuffer(self.fb.value)

    def clear(self) -> None:
        """Depth 1 and stencil 0 (bound by the caller)."""
        gl = lib()
        gl.glDepthMask(1)
        gl.glStencilMask(0xFF)
        gl.glClearDepth(1.0)
        gl.glClearStencil(0)
        gl.glClear(0x100 | (0x400 if self.stencil else 0))

    def sample_positions(self) -> tuple[tuple[float, float], ...]:
        """The driver's sample positions (within the pixel, 0..1) of this target."""
        gl = lib()
        self.fbo.use()
        out = []
        for k in range(max(self.samples, 1)):
            v = (ctypes.c_float * 2)()
            gl.glGetMultisamplefv(0x8E50, k, v)       # GL_SAMPLE_POSITION
            out.append((float(v[0]), float(v[1])))
        return tuple(out)

    def release(self) -> None:
        gl = lib()
        if self.fbo is not None:
            self.fbo.release()                       # deletes the framebuffer too
            self.fbo, self.fb = None, ctypes.c_uint()
        if self.fb.value:
            gl.glDeleteFramebuffers(1, ctypes.byref(self.fb))
            self.fb = ctypes.c_uint()
        if self.rb.value:
            gl.glDeleteRenderbuffers(1, ctypes.byref(self.rb))
            self.rb = ctypes.c_uint()


def sample_positions(ctx, samples: int) -> tuple[tuple[float, float], ...]:
    """The positions of the samples of a `samples`-sample target on `ctx` (a 1x1 probe)."""
    t = DepthTarget(ctx, "sample-probe", (1, 1), samples)
    try:
        return t.sample_positions()
    finally:
        t.release()
