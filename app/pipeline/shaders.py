"""Shader loader and program cache.

- A shader name (a pass's source or an `#include "name"`) is found among the generated
  virtual files, then in the folder of the code that owns it (a technique's folder,
  app/gpu_build/ for the GPU build), then in glsl/ (what several owners share); names are
  unique across these folders.  Includes are depth-limited and wrapped in `#line` directives so compile errors name the right file and line.
- Defines are injected right after `#version` from a dict.  A shader declares the names it
  accepts with a `// define: NAME ...` comment; an undeclared name is an error.
- A stage given a native WAVE_NATIVE (glsl/wave.glsl: 1 ARB, 2 KHR) gets that path's
  `#extension` lines there too (gl.WAVE_EXTENSIONS): GLSL wants them before any
  declaration, and the stage that includes wave.glsl has made some by then.
- Storage buffers are bound by slot name: a shader writes `binding = B_LIGHTS`, and the
  program is built with the binding points of the slots its pass declares (`bindings`).
  The declaration of a buffer block whose slot the pass did not declare is dropped from the
  program text, so a shader that uses that buffer fails to compile, and the error is one
  line naming the buffer and the file:line of the use.
- Programs are cached by (source name, defines, bindings, generated files): changing a
  define recompiles, changing a uniform or a buffer's contents does not.  The compiled
  programs live for the process, per GL context: a new cache (a new renderer: a scene
  switch, another study of the benchmark) compiles only what the process has not compiled
  yet; a cache's `sources` and programs are those it returned itself, `built` the ones it
  compiled, and releasing it forgets them without deleting them.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path
import re
from typing import NamedTuple

import moderngl

from ..errors import UserError
from .gl import WAVE_EXTENSIONS

ROOT = Path(__file__).resolve().parents[2]
GLSL_DIR = ROOT / "glsl"
SHADER_SUFFIXES = (".comp", ".glsl", ".vert", ".frag")
MAX_INCLUDE_DEPTH = 16
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*(//.*)?$')     # a trailing // comment allowed
_DECLARE = re.compile(r"^\s*//\s*define:\s*(.+)$")
_ERROR_LOC = re.compile(r"\b(\d+):(\d+)\((\d+)\)|\b(\d+)\((\d+)\)")
# One storage block declaration: layout(... binding = B_SLOT ...) qualifiers buffer Name { members };
_BLOCK = re.compile(r"layout\s*\([^)]*\bbinding\s*=\s*B_([A-Z][A-Z0-9_]*)\b[^)]*\)[^{;]*\{([^}]*)\}\s*\w*\s*;")
_MEMBER = re.compile(r"(\w+)\s*(?:\[[^\]]*\])?\s*;")


class ShaderError(UserError):
    pass


def shader_dirs() -> list[Path]:
    """Where shader files live: each technique's folder and the GPU build's, then glsl/."""
    owned = sorted(p for p in (ROOT / "app" / "techniques").iterdir() if (p / "__init__.py").is_file())
    return owned + [ROOT / "app" / "gpu_build", GLSL_DIR]


@lru_cache(maxsize=None)
def shader_files() -> dict[str, Path]:
    """Every shader file by name; a name in two folders is an error (an include names a
    file, not a folder)."""
    found: dict[str, Path] = {}
    for folder in shader_dirs():
        for path in sorted(folder.iterdir()):
            if path.suffix in SHADER_SUFFIXES:
                if path.name in found:
                    raise ShaderError(f"shader {path.name} in two folders: {found[path.name]}, {path}")
                found[path.name] = path
    return found


class Source:
    """One preprocessed shader: text, file table for #line numbers, declared defines."""

    def __init__(self, name: str, virtual: dict[str, str] | None = None):
        self.virtual = dict(virtual or {})
        self.files: list[str] = []
        self.declared: set[str] = set()
        self.body = self._expand(name, 0, [])

    def _read(self, name: str) -> str:
        if name in self.virtual:
            return self.virtual[name]
        path = shader_files().get(name)
        if path is None:
            raise ShaderError(f"shader include not found: {name}")
        return path.read_text()

    def _expand(self, name: str, depth: int, stack: list[str]) -> list[str]:
        if depth > MAX_INCLUDE_DEPTH:
            raise ShaderError(f"#include nested deeper than {MAX_INCLUDE_DEPTH}: {' -> '.join(stack + [name])}")
        if name in stack:
            raise ShaderError(f"#include cycle: {' -> '.join(stack + [name])}")
        if name in self.files and depth > 0:
            return []  # include once
        self.files.append(name)
        fid = self.files.index(name)
        out = [] if depth == 0 else [f"#line 1 {fid}"]
        for no, line in enumerate(self._read(name).splitlines(), 1):
            m = _INCLUDE.match(line)
            if m:
                out += self._expand(m.group(1), depth + 1, stack + [name])
                out.append(f"#line {no + 1} {fid}")
                continue
            d = _DECLARE.match(line)
            if d:
                self.declared.update(d.group(1).split())
            out.append(line)
        return out

    def _bind(self, body: str, bindings: dict[str, int]) -> str:
        """Define B_<SLOT> for the declared slots; drop the other blocks (their newlines
        kept, so #line numbers hold) and remember their members for the error message."""
        self.dropped: dict[str, str] = {}

        def sub(m):
            slot = m.group(1).lower()
            if slot in bindings:
                return m.group(0)
            for member in _MEMBER.findall(m.group(2)):
                self.dropped[member] = slot
            return f"/* buffer '{slot}': not declared by the pass */" + "\n" * m.group(0).count("\n")
        return _BLOCK.sub(sub, body)

    def locate(self, member: str, line_hint: int | None = None) -> str:
        """'file:line' where a buffer `member` is used (indexed or a field taken), outside
        its block declaration; the driver's line number, when it gives one, picks among
        several uses.  Found from our own #line bookkeeping: drivers do not all report the
        file of an include."""
        fid, line, found = 0, 1, []
        use = re.compile(rf"\b{member}\s*[\[.]")
        for text in self.body[1:]:
            m = re.match(r"#line (\d+) (\d+)$", text)
            if m:
                line, fid = int(m.group(1)), int(m.group(2))
                continue
            line += 1
            if use.search(text) and not _BLOCK.search(text):
                found.append((line, f"{self.files[fid]}:{line}"))
        best = [loc for no, loc in found if no == line_hint] or [loc for _, loc in found]
        return best[0] if best else self.files[0]

    def text(self, defines: dict[str, object], extensions: tuple[str, ...] = (),
             bindings: dict[str, int] | None = None) -> str:
        unknown = sorted(set(defines) - self.declared)
        if unknown:
            raise ShaderError(f"{self.files[0]}: unknown define(s) {', '.join(unknown)} "
                              f"(declared: {', '.join(sorted(self.declared)) or 'none'})")
        if not self.body or not self.body[0].startswith("#version"):
            raise ShaderError(f"{self.files[0]}: first line must be #version")
        wave = int(defines.get("WAVE_NATIVE", 0))
        if wave and wave not in WAVE_EXTENSIONS:
            raise ShaderError(f"{self.files[0]}: WAVE_NATIVE {wave}: 0 (emulated), "
                              f"{' or '.join(map(str, sorted(WAVE_EXTENSIONS)))} (native paths)")
        extensions = dict.fromkeys(tuple(extensions) + WAVE_EXTENSIONS.get(wave, ()))
        head = [self.body[0]] + [f"#extension {e} : require" for e in extensions]
        head += [f"#define {k} {_define_value(v)}" for k, v in sorted(defines.items())]
        body = "\n".join(self.body[1:])
        if bindings is not None:
            head += [f"#define B_{slot.upper()} {i}" for slot, i in sorted(bindings.items())]
            body = self._bind(body, bindings)
        return "\n".join(head + ["#line 2 0", body]) + "\n"

    def explain(self, log: str) -> str:
        """Rewrite 'file-number:line' locations in a driver log to 'file:line'."""
        def sub(m):
            fid, line = (m.group(1), m.group(2)) if m.group(1) else (m.group(4), m.group(5))
            fid = int(fid)
            return f"{self.files[fid] if fid < len(self.files) else fid}:{line}"
        return _ERROR_LOC.sub(sub, log)


def _first_error(sources: list[Source], log: str, context: str = "") -> str:
    """'<shader>: <first error line, located as file:line>' from a driver's log.  For a
    vertex + fragment program moderngl heads each stage's errors with its name.  A buffer
    the pass did not declare is named as such."""
    stage = sources[0]
    if len(sources) == 2 and "fragment_shader\n" in log:
        stage = sources[1]
    for line in log.splitlines():
        used = [m for m in getattr(stage, "dropped", {}) if re.search(rf"\b{m}\b", line)]
        if used and "error" in line.lower():
            at = _ERROR_LOC.search(line)
            hint = int(at.group(2) or at.group(5)) if at else None
            return (f"{context or stage.files[0]}: {stage.locate(used[0], hint)} uses buffer "
                    f"'{stage.dropped[used[0]]}', which the pass does not declare (reads or writes)")
    for line in stage.explain(log).splitlines():
        if "error" in line.lower():
            return f"{stage.files[0]}: {line.strip()}"
    first = next((l for l in log.splitlines() if l.strip()), "compile failed")
    return f"{stage.files[0]}: {first.strip()}"


class ProgramKey(NamedTuple):
    """What a cached program is built from; stage_texts(key) gives its stages' text."""
    names: tuple[str, ...]
    defines: tuple
    virtual: tuple
    extensions: tuple[str, ...]
    bindings: tuple | None      # None: the text as written
    optional: tuple


def stage_texts(key: ProgramKey, context: str = "") -> tuple[list[Source], list[str]]:
    """The sources of a program and each stage's final text, as the driver gets it.
    `defines` must be declared by the sources; `optional` ones (frame-wide switches such as
    UNBOUNDED_FALLOFF) reach the stages that declare them and no others."""
    sources = [Source(n, dict(key.virtual)) for n in key.names]
    defines = dict(key.defines)
    unknown = sorted(set(defines) - set().union(*(s.declared for s in sources)))
    if unknown:
        raise ShaderError(f"{context or '+'.join(key.names)}: unknown define(s) {', '.join(unknown)}")
    every = dict(key.optional, **defines)
    bindings = None if key.bindings is None else dict(key.bindings)
    # each stage gets the defines it declares
    texts = [s.text({k: v for k, v in every.items() if k in s.declared}, key.extensions, bindings)
             for s in sources]
    return sources, texts


def _define_value(v) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    return str(v)


# every program compiled in the process, by context: ProgramKey -> (program, final text).
# A program's uniforms are set before each use (the renderer sets every one a pass declares),
# so a program carries nothing of one renderer's frame into another's.
_COMPILED: dict = {}


class ProgramCache:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._programs: dict = {}
        self.sources: dict = {}   # ProgramKey -> final text, for inspection and tests
        self.last_key: ProgramKey | None = None
        self.built = 0            # programs this cache compiled (the others were compiled)
        self._compiled = _COMPILED.setdefault(ctx, {})

    def compute(self, name: str, defines: dict | None = None, virtual: dict | None = None,
                extensions: tuple[str, ...] = (), bindings: dict | None = None,
                optional: dict | None = None, context: str = "") -> moderngl.ComputeShader:
        return self._get((name,), defines, virtual, extensions, bindings, optional, context,
                         lambda texts: self.ctx.compute_shader(texts[0]))

    def program(self, vertex: str, fragment: str, defines: dict | None = None,
                virtual: dict | None = None, bindings: dict | None = None,
                optional: dict | None = None, context: str = "") -> moderngl.Program:
        """A vertex + fragment program; both stages see the same defines and bindings."""
        return self._get((vertex, fragment), defines, virtual, (), bindings, optional, context,
                         lambda texts: self.ctx.program(vertex_shader=texts[0], fragment_shader=texts[1]))

    def _get(self, names, defines, virtual, extensions, bindings, optional, context, build):
        key = ProgramKey(names, tuple(sorted((defines or {}).items())),
                         tuple(sorted((virtual or {}).items())), tuple(extensions),
                         None if bindings is None else tuple(sorted(bindings.items())),
                         tuple(sorted((optional or {}).items())))
        if key not in self._programs:
            if key not in self._compiled:
                sources, texts = stage_texts(key, context)
                try:
                    self._compiled[key] = build(texts), "\n".join(texts)
                except Exception as exc:
                    raise ShaderError(_first_error(sources, str(exc), context)) from None
                self.built += 1
            self._programs[key], self.sources[key] = self._compiled[key]
        self.last_key = key        # the key of the program just returned (the frame's record)
        return self._programs[key]

    def release(self) -> None:
        """Forget this cache's programs; they stay compiled for the process's next cache."""
        self._programs.clear()
        self.sources.clear()

