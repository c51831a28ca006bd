"""The frame graph checked before its first dispatch, as Falcor's reflect step does: a list
of steps either runs whole or fails in one line naming the technique, the step and the name
at fault, before any of it runs.

- steps: each a Pass or a HostStep; a compute pass's shader one file and its groups three
  integers within the driver's limit, a raster pass's shader (vertex, fragment) and its
  draw's mode, depth test, face culling, stencil functions and ops from the known names.
- buffers: each read is provided before the step (the build's uploads, an earlier pass's
  writes); a timed pass writes nothing an untimed step wrote (later samples re-run only the
  timed passes).  A host step's uploads are known once it has run: they reach the steps it
  returns, which are checked then, before they run.
- uniforms: each uniform a pass sets is declared by its shaders' source (includes and the
  generated files resolved, every #if branch read).  The driver may still drop one that a
  define leaves unused (a CELLS_ONLY frame, a light-type feature): that one is skipped, but
  a name no source declares is a misspelling, never a silent skip.
- indirect dispatch (Pass.indirect): its argument buffer is provided before the pass, its
  offset a multiple of 4 with three uint counts inside the buffer, and the pass's `groups`
  (the most it may dispatch) within the driver's limit.
- dispatch windows (u_window = [lo, hi) of each pixel's light sequence, techniques.base
  .windows): the windowed dispatches of one pass start at 0, each takes up where the last
  stopped, and the last runs to WINDOW_ALL, so no light of a sequence is skipped.
"""
from __future__ import annotations

import re

from cpu_prep.limits import WINDOW_ALL
from scenes.errors import closest

from ..errors import UserError
from . import rawgl
from .passes import DEPTH_FUNCS, DRAW_MODES, HostStep, Pass, Target
from .shaders import Source

FACE_CULLING = ("back", "front")
NAMED_TARGETS = ("gbuffer", "gbuffer_depth", "none")
_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_UNIFORM = re.compile(r"\buniform\s+([^;{}]*);")
_IDENT = re.compile(r"[A-Za-z_]\w*")
_UNIFORMS_OF: dict = {}      # (shader names, generated files) -> names their source declares


class GraphError(UserError):
    pass


def check_steps(steps, provided, untimed_writes=(), virtual=None, technique: str = "",
                max_groups=(65535, 65535, 65535)) -> None:
    """Check a list of steps against the buffers the frame has `provided` so far (and the
    ones `untimed_writes` wrote); raise GraphError before anything runs."""
    have, untimed, windows = set(provided), set(untimed_writes), {}
    sizes = {n: v[0] for n, v in provided.items()} if isinstance(provided, dict) else {}
    for k, step in enumerate(steps):
        where = where_of(step, k, technique)
        check_shape(step, where, max_groups)
        check_reads(step, where, have)
        if isinstance(step, Pass):
            check_indirect(step, where, have, sizes)
            check_uniforms(step, where, step.files(virtual or {}))
            check_writes(step, where, have, untimed)
            sizes.update({step.buffer_of(s): b.nbytes for s, b in step.writes.items()})
            check_window(step, where, windows)
    if windows:
        lo, where = next(iter(windows.values()))
        raise GraphError(f"{where}: its dispatch windows stop at light {lo}: the later lights "
                         f"of each pixel's sequence are never evaluated")


def where_of(step, index: int, technique: str) -> str:
    """'technique 'x', pass 'y'' (or 'host step', or the step's position)."""
    head = f"technique '{technique}', " if technique else ""
    if isinstance(step, Pass):
        return f"{head}pass '{step.name}'"
    if isinstance(step, HostStep):
        return f"{head}host step '{step.name}'"
    return f"{head}step {index}"


def check_shape(step, where: str, max_groups) -> None:
    """The step is a Pass or HostStep whose fields name known things."""
    if isinstance(step, HostStep):
        if not callable(step.run):
            raise GraphError(f"{where}: run is a {type(step.run).__name__}, not a function")
        return
    if not isinstance(step, Pass):
        raise GraphError(f"{where} is a {type(step).__name__}, not a Pass or a HostStep")
    if step.kind == "compute":
        check_compute(step, where, max_groups)
    else:
        check_draw(step, where)


def check_compute(p: Pass, where: str, max_groups) -> None:
    """One shader file; three whole group counts, 0 (a dispatch of nothing) up to the limit."""
    if not isinstance(p.shader, str):
        raise GraphError(f"{where}: a compute pass names one shader file, not {p.shader!r}")
    g = tuple(p.groups)
    if len(g) != 3 or not all(hasattr(n, "__index__") for n in g):
        raise GraphError(f"{where}: groups {g!r} is not three whole numbers")
    for axis, n, most in zip("xyz", g, max_groups):
        if not 0 <= int(n) <= most:
            raise GraphError(f"{where}: groups {axis} = {int(n)} is outside 0..{most} "
                             f"(GL_MAX_COMPUTE_WORK_GROUP_COUNT)")


def check_draw(p: Pass, where: str) -> None:
    """(vertex, fragment) shaders; the draw's state from the names the renderer knows."""
    if not (isinstance(p.shader, tuple) and len(p.shader) == 2):
        raise GraphError(f"{where}: a raster pass names (vertex, fragment) shaders, not {p.shader!r}")
    d = p.draw
    named = [("mode", d.mode, DRAW_MODES), ("depth_test", d.depth_test, DEPTH_FUNCS),
             ("cull", d.cull, FACE_CULLING)]
    for k, s in enumerate(d.stencil):
        named += [(f"stencil[{k}].cull", s.cull, FACE_CULLING),
                  (f"stencil[{k}].depth_test", s.depth_test, DEPTH_FUNCS),
                  (f"stencil[{k}].func", s.func, rawgl.STENCIL_FUNCS)]
        named += [(f"stencil[{k}].ops", op, rawgl.STENCIL_OPS) for op in s.ops]
    for field, value, known in named:
        if value is not None and value not in known:
            raise GraphError(f"{where}: {field} '{value}' is not one of {', '.join(known)}")
    if isinstance(d.target, str) and d.target not in NAMED_TARGETS:
        raise GraphError(f"{where}: target '{d.target}' is not one of "
                         f"{', '.join(NAMED_TARGETS)}, a Target or a framebuffer")
    if not isinstance(d.target, (str, Target)) and not hasattr(d.target, "use"):
        raise GraphError(f"{where}: target is a {type(d.target).__name__}, not a Target or a framebuffer")
    if d.instances < 0 or (d.count is not None and d.count < 0):
        raise GraphError(f"{where}: {d.count} vertices x {d.instances} instances is negative")


def check_reads(step, where: str, have: set) -> None:
    names = [step.buffer_of(s) for s in step.reads] if isinstance(step, Pass) else list(step.reads)
    missing = [n for n in names if n not in have]
    if missing:
        raise GraphError(f"{where} reads buffer '{missing[0]}', which nothing in this frame "
                         f"provides before it (neither the build's uploads nor an earlier pass)")


def check_indirect(p: Pass, where: str, have: set, sizes: dict) -> None:
    """An indirect pass's arguments: a provided buffer, a 4-aligned offset, 12 bytes there."""
    if p.indirect is None:
        return
    try:
        name, offset = p.indirect
        offset = int(offset)
    except (TypeError, ValueError):
        raise GraphError(f"{where}: indirect {p.indirect!r} is not (buffer, byte offset)") from None
    if name not in have:
        raise GraphError(f"{where} dispatches indirectly from buffer '{name}', which nothing in "
                         f"this frame provides before it")
    if offset < 0 or offset % 4 or (name in sizes and offset + 12 > sizes[name]):
        raise GraphError(f"{where}: indirect offset {offset} of '{name}' is not a multiple of 4 "
                         f"with 12 bytes of group counts inside its {sizes.get(name, '?')} bytes")


def check_writes(p: Pass, where: str, have: set, untimed: set) -> None:
    for slot in p.writes:
        name = p.buffer_of(slot)
        if p.timed and name in untimed:
            raise GraphError(f"{where} is timed but writes '{name}', which an untimed step "
                             f"wrote: later samples would lose that set-up")
        have.add(name)
        if not p.timed:
            untimed.add(name)


def check_uniforms(p: Pass, where: str, virtual: dict) -> None:
    """Each uniform the pass sets is declared by the source of one of its shaders."""
    names = (p.shader,) if isinstance(p.shader, str) else tuple(p.shader)
    declared = declared_uniforms(names, virtual)
    for name in p.uniforms:
        if name not in declared:
            near = closest(name, declared)
            raise GraphError(f"{where} sets uniform '{name}', which none of its shaders "
                             f"({', '.join(names)}) declares"
                             + (f" (closest: '{near}')" if near else ""))


def declared_uniforms(names: tuple[str, ...], virtual: dict) -> frozenset:
    """The uniform names the sources of `names` declare, in any #if branch (cached)."""
    key = (names, tuple(sorted(virtual.items())))
    if key not in _UNIFORMS_OF:
        found = set()
        for name in names:
            text = _COMMENT.sub(" ", "\n".join(Source(name, virtual).body))
            for m in _UNIFORM.finditer(text):
                found.update(declarator_names(m.group(1)))
        _UNIFORMS_OF[key] = frozenset(found)
    return _UNIFORMS_OF[key]


def declarator_names(decl: str) -> list[str]:
    """'vec3 u_a, u_b[4]' -> ['u_a', 'u_b']: the last identifier of each declarator."""
    out = []
    for part in decl.split(","):
        ids = _IDENT.findall(re.sub(r"\[[^\]]*\]|=.*", "", part, flags=re.S))
        if ids:
            out.append(ids[-1])
    return out


def check_window(p: Pass, where: str, open_windows: dict) -> None:
    """Windows of one pass (name, shader) tile [0, WINDOW_ALL) in order; open_windows
    holds, per pass, where its next window must start and the last window's step."""
    if "u_window" not in p.uniforms:
        return
    try:
        lo, hi = (int(v) for v in p.uniforms["u_window"])
    except (TypeError, ValueError):
        raise GraphError(f"{where}: u_window {p.uniforms['u_window']!r} is not [lo, hi)") from None
    key = (p.name, p.shader)
    start = open_windows.pop(key, (0, where))[0]
    if lo != start or not lo < hi <= WINDOW_ALL:
        raise GraphError(f"{where}: dispatch window [{lo}, {hi}) should start at light {start} "
                         f"and end past it, at most at {WINDOW_ALL} (WINDOW_ALL)")
    if hi != WINDOW_ALL:
        open_windows[key] = (hi, where)
