"""What each step the cost model prices costs, counted from the program that runs it.

A shader marks the steps the model prices with a comment on the line before a function
definition or a loop statement:

    // priced: KIND [minus: fn fn ...] [with: fn fn ...]

KIND is a loop kind of app.model.waves.KINDS, `test` (a light's affects test) or `shade`
(what an affecting light adds).  A function is counted whole, a loop one iteration (its own
blocks; a nested loop is priced as its own kind), callees included except the functions
named after `minus:` and every other priced function (each is priced on its own) but those
named after `with:` (fptl's pruning runs the affects test itself).  A kind marked at several
places of one program is their sum (zbin's cell: its bin and the bin's range).  A loop with
a fixed trip count inside a counted function says it on the line before it,

    // trips: N

and counts N times (fptl_aabb.comp's corners and their planes); any other loop counts once
(fptl_aabb's clipping, which most lights skip, counts once a light).

    program_counts(key) -> {kind: [alu, trans, idiv, wred], "test:<shape>", "shade:<shape>",
                            "ggx", "wave": [...]}     (app.model.spirv's columns)

`test:<shape>` and `shade:<shape>` come from the program compiled with that shape alone
(features.glsl), `ggx` is surface_response with a specular material less without, and
`wave` is what an invocation runs outside every priced step (the G-buffer fetch, the
stores, the counters: main with the priced steps left out).  Counted from the path a GPU
with subgroup operations compiles (WAVE_NATIVE = KHR where the program declares it), with
the modelling switches off (CELLS_ONLY, DEBUG_PIXEL), cached by the hash of the texts.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
import hashlib
import json
import os
from pathlib import Path
import re

from scenes.model import LIGHT_TYPES

from ..pipeline import phases
from ..pipeline import features as feat
from ..pipeline.gl import WAVE_KHR
from ..pipeline.shaders import ProgramKey, Source, stage_texts
from . import spirv
from .waves import KINDS

PRICED_KINDS = frozenset(KINDS) | {"test", "shade"}

RULE_VERSION = "1"          # the counting rule's version (the record the tests keep)
# the cache key holds the rule's own source too, so that an edit of the rule never reads a
# count the old rule made
_RULE_SOURCE = hashlib.sha256(b"".join(Path(m).read_bytes() for m in (spirv.__file__, __file__))
                              ).hexdigest()[:16]
_PRICED = re.compile(r"^\s*//\s*priced:\s*(\w+)((?:\s+(?:minus|with):(?:\s+\w+)+)*)\s*$")
_TRIPS = re.compile(r"^\s*//\s*trips:\s*(\d+)\s*$")
_LOOP = re.compile(r"^\s*(for|while|do)\b")
_FUNCTION = re.compile(r"^\s*(?:precise\s+)?\w+\s+(\w+)\s*\((?!.*\)\s*;\s*$)")
_CODE = re.compile(r"^\s*(//.*)?$")          # blank or comment-only lines
OFF = {"CELLS_ONLY": 0, "DEBUG_PIXEL": 0}
STAGES = {1: ("comp",), 2: ("vert", "frag")}


def _next_code(lines: list[str], no: int, where: str) -> int:
    nxt = next((k for k in range(no + 1, len(lines)) if not _CODE.match(lines[k])), None)
    if nxt is None:
        raise ValueError(f"{where}: a mark with no code after it")
    return nxt


def annotations(source: Source) -> tuple[list[tuple[str, tuple, frozenset, frozenset]], dict]:
    """The priced marks of a program's files, (kind, ("function", name) | ("loop", file,
    line), minus, with), and its trip marks {(file, line of the loop): N}."""
    marks, trips = [], {}
    for name in source.files:
        lines = source._read(name).splitlines()
        for no, text in enumerate(lines):
            where = f"{name}:{no + 1}"
            t = _TRIPS.match(text)
            if t:
                nxt = _next_code(lines, no, where)
                if not _LOOP.match(lines[nxt]):
                    raise ValueError(f"{where}: a trips mark must stand before a loop statement")
                trips[(name, nxt + 1)] = int(t.group(1))
                continue
            m = _PRICED.match(text)
            if not m:
                if re.search(r"//\s*priced\b", text):
                    raise ValueError(f"{where}: not a priced mark: {text.strip()}")
                continue
            if m.group(1) not in PRICED_KINDS:
                raise ValueError(f"{where}: '{m.group(1)}' is no priced kind "
                                 f"({', '.join(sorted(PRICED_KINDS))})")
            nxt = _next_code(lines, no, where)
            named = {"minus:": [], "with:": []}
            into = None
            for word in m.group(2).split():
                into = word if word in named else into
                if word not in named:
                    named[into].append(word)
            minus, keep = frozenset(named["minus:"]), frozenset(named["with:"])
            if _LOOP.match(lines[nxt]):
                marks.append((m.group(1), ("loop", name, nxt + 1), minus, keep))
            elif (f := _FUNCTION.match(lines[nxt])):
                marks.append((m.group(1), ("function", f.group(1)), minus, keep))
            else:
                raise ValueError(f"{where}: a priced mark must stand before a function "
                                 f"definition or a loop statement")
    return marks, trips


def counting_key(key: ProgramKey, features: tuple[str, ...] | None = None) -> ProgramKey:
    """The program as a GPU runs it: the native wave path, modelling switches off; with
    `features`, compiled for that feature set."""
    optional = dict(dict(key.optional), **OFF)
    if "WAVE_NATIVE" in optional:
        optional["WAVE_NATIVE"] = WAVE_KHR
    virtual = dict(key.virtual)
    if features is not None and "features.glsl" in virtual:
        virtual["features.glsl"] = feat.features_glsl(tuple(features))
    return key._replace(optional=tuple(sorted(optional.items())),
                        virtual=tuple(sorted(virtual.items())), extensions=())


def _stages(key: ProgramKey):
    sources, texts = stage_texts(key)
    stages = STAGES[len(texts)]
    return [(s, spirv.with_file_lines(t, s.files), st) for s, t, st in zip(sources, texts, stages)]


def _count_stage(source: Source, text: str, stage: str) -> dict[str, list[float]]:
    """Every priced kind of one stage, and its `wave` residual."""
    module = spirv.Module(spirv.disassemble(text, stage))
    marks, trips = annotations(source)
    priced_fns = frozenset(w[1] for _, w, _, _ in marks if w[0] == "function")
    probe = spirv.Counter(module)
    weight = {}
    for (file, line), n in trips.items():
        for fn, h in probe.loops_at(file, line):
            for b in probe.loop_blocks(fn, h):
                weight[(fn.name, b)] = weight.get((fn.name, b), 1) * n
    loops = {m: probe.loops_at(m[1][1], m[1][2]) for m in marks if m[1][0] == "loop"}
    skip = frozenset((fn.name, b) for found in loops.values() for fn, h in found
                     for b in probe.own_blocks(fn, h))
    c = spirv.Counter(module, skip, weight)
    out: dict[str, spirv.Count] = {}
    for mark in marks:
        kind, where, minus, keep = mark
        apart = (priced_fns | minus) - keep - ({where[1]} if where[0] == "function" else set())
        if where[0] == "function":
            if where[1] not in module.functions:
                continue                       # not in this program (not called)
            n = c.function(where[1], apart)
        elif loops[mark]:
            n = sum((c.loop_iteration(fn, h, apart) for fn, h in loops[mark]), spirv.ZERO)
        else:
            continue
        out[kind] = out.get(kind, spirv.ZERO) + n
    if "main" in module.functions:
        out["wave"] = c.function("main", priced_fns)
    return {k: v.row() for k, v in out.items()}


def _cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "many-light-lab" / "spirv-counts"


def _cached(texts: list[str], compute) -> dict:
    digest = hashlib.sha256("\0".join([RULE_VERSION, _RULE_SOURCE, *texts]).encode()).hexdigest()[:24]
    path = _cache_dir() / f"{digest}.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        pass
    value = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(value, sort_keys=True))
        tmp.replace(path)
    except OSError:
        pass                                   # an unwritable cache only costs a recount
    return value


def stage_counts(key: ProgramKey) -> dict[str, list[float]]:
    """The priced kinds of a program (its stages' together: a raster pass's vertex and
    fragment stages price different kinds)."""
    stages = _stages(key)

    def compute():
        out = {}
        for s, text, st in stages:
            for k, v in _count_stage(s, text, st).items():
                out[k if k != "wave" or st == "comp" else f"wave_{st}"] = v
        return out
    return _cached([t for _, t, _ in stages], compute)


@lru_cache(maxsize=256)
def program_counts(key: ProgramKey) -> dict[str, list[float]]:
    """The module doc's counts of one program (a frame graph pass's ProgramKey)."""
    shaded = "features.glsl" in dict(key.virtual)
    variants = [None] + ([(s,) for s in LIGHT_TYPES] + [("point", feat.SPECULAR)] if shaded else [])
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:   # glslang runs apart
        got = dict(zip(variants, pool.map(lambda f: stage_counts(counting_key(key, f)), variants)))
    out = {k: v for k, v in got[None].items() if k not in ("test", "shade")}
    if not shaded:
        return out
    for shape in LIGHT_TYPES:
        for part in ("test", "shade"):
            if part in got[(shape,)]:
                out[f"{part}:{shape}"] = got[(shape,)][part]
    spec, plain = got[("point", feat.SPECULAR)], got[("point",)]
    if "shade" in spec and "shade" in plain:
        out["ggx"] = [a - b for a, b in zip(spec["shade"], plain["shade"])]
    return out


def merged(keys) -> dict[str, list[float]]:
    """The counts of several programs that one figure stands for (feature variants' shading
    programs, raster's proxy passes): each kind at its costliest."""
    out: dict[str, list[float]] = {}
    for key in keys:
        for k, v in program_counts(key).items():
            if k not in out or sum(v) > sum(out[k]):
                out[k] = list(v)
    return out


@phases.timed("counts")           # app.pipeline.phases: where a run's time goes
def attach(passes: dict, programs: dict) -> None:
    """Each figure of a frame (pass name -> Figures) gets the counts of the programs its pass
    ran (`programs`: pass name -> [ProgramKey], the renderer's record).  A figure that stands
    for several passes (raster's "raster proxies") names them by its `stands_for` regex."""
    for name, f in passes.items():
        if f.stands_for:
            keys = [k for p, ks in programs.items() if re.fullmatch(f.stands_for, p) for k in ks]
        else:
            keys = programs.get(name)
        if not keys:
            raise ValueError(f"cost model: no program ran for the pass '{name}'")
        f.ops = merged(keys)
        f.programs = tuple(dict.fromkeys(n for k in keys for n in k.names))
