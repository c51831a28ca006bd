"""Run a program: the frame's lights, lists and nodes laid out as the kernels read them,
the kernels run, their counts gathered into Figures and per-pixel work."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpu_prep import layouts

from .figures import Figures
from .kernels import _replay_segments, _replay_words, _tree_visits
from .kinds import FIELDS, KINDS, LINE, NTYPES
from .lights import _EXT, _POS, light_bounds
from .program import LightList, Program


@dataclass
class Replay:
    """A replay's figures and the per-pixel work it implies (GL row order)."""
    figures: Figures
    evaluated: np.ndarray
    nodes: np.ndarray
    contrib: np.ndarray


def replay(prog: Program) -> Replay:
    """Run a program (module doc)."""
    fr = prog.frame
    n_pix = len(fr.cell)
    P = np.ascontiguousarray(fr.position[:, :3], np.float32)
    spec = np.ascontiguousarray(fr.specular, np.bool_)
    names, line_base, seen = _line_map(prog.buffers)
    loops = np.zeros((len(KINDS), len(FIELDS)), np.int64)
    types_acc = np.zeros((3, NTYPES), np.int64)          # tested, shaded, (specular in [2, 0])
    per_pixel = np.zeros((n_pix, 3), np.int64)           # evaluated, nodes, contrib
    shared = (P, spec, *_light_arrays(fr), line_base, seen, loops, types_acc, per_pixel)
    if prog.words is not None:
        _run_words(prog, *shared)
    _run_segments(prog, *shared)
    fig = _figures(prog, loops, types_acc)
    for k, name in enumerate(names):
        fig.unique_bytes[name] = int(seen[line_base[k]:line_base[k + 1]].sum()) * LINE
    return Replay(fig, per_pixel[:, 0].copy(), per_pixel[:, 1].copy(), per_pixel[:, 2].copy())


def _light_arrays(fr) -> tuple:
    """(L, types, bound, unbounded): the lights as the kernels' affects tests read them."""
    pl = fr.build.lights
    g = pl.gpu
    L = np.ascontiguousarray(g).view(np.float32).reshape(len(g), layouts.LIGHT_WORDS)
    types = np.ascontiguousarray(pl.type, np.int64)
    bound = light_bounds(L[:, _POS:_POS + 4], L[:, _EXT:_EXT + 4], types)
    return L, types, bound, bool(fr.unbounded)


def _line_map(buffers: dict) -> tuple:
    """The buffers' names, the first line of each in one unique-line map, and the map."""
    names = list(buffers)
    sizes = np.array([max(buffers[k], 1) for k in names], np.int64)
    line_base = np.concatenate([[0], np.cumsum((sizes + LINE - 1) // LINE)]).astype(np.int64)
    return names, line_base, np.zeros(int(line_base[-1]), np.bool_)


def _run_words(prog: Program, P, spec, *rest) -> None:
    """The bit-array word loop (Program.bit_words), its pixels by (wave, lane)."""
    fr, wd = prog.frame, prog.words
    order = np.lexsort((prog.lane, prog.wave))
    live = np.ones(len(fr.cell), np.bool_) if fr.live is None else fr.live
    _replay_words(order, prog.wave[order], fr.shading[order], live[order], wd["address"][order],
                  wd["lo"][order], wd["hi"][order], wd["bits"], wd["words"], wd["masked"],
                  wd["scalarized"], wd["printed"], int(wd["buf"]), P, spec, *rest)


def _run_segments(prog: Program, P, spec, *rest) -> None:
    """The program's segments, in (wave, branch, step, lane) order."""
    seg, calls = prog.segments()
    if not len(seg["lane"]):
        return
    nodes = prog.nodes if prog.nodes is not None else np.zeros(1, layouts.TREE_NODE)
    depth = np.ascontiguousarray(prog.frame.position[:, 3], np.float32)
    _replay_segments(prog.wave[seg["lane"]], seg["lane"], seg["step"], seg["hoff"],
                     seg["first"], seg["count"], seg["call"], calls, *_flatten(prog.lists),
                     *_node_columns(nodes), depth, P, spec, *rest)


def _node_columns(nodes) -> tuple:
    """min_depth, max_depth, first_light, bits of TREE_NODE records, as the kernels read them."""
    return (np.ascontiguousarray(nodes["min_depth"]), np.ascontiguousarray(nodes["max_depth"]),
            nodes["first_light"].astype(np.int64), nodes["bits"].astype(np.int64))


def _figures(prog: Program, loops, types_acc) -> Figures:
    fr = prog.frame
    busy = np.unique(prog.wave[fr.shading]).size
    return Figures(width=prog.width, waves=prog.waves, busy_waves=int(busy), pixels=len(fr.cell),
                   shading_pixels=int(fr.shading.sum()), loops=loops, tested=types_acc[0].copy(),
                   shaded=types_acc[1].copy(), specular=int(types_acc[2, 0]),
                   barriers=int(prog.barriers))


def _flatten(lists: list[LightList]):
    starts = np.concatenate([[0], np.cumsum([len(L.light) for L in lists])]).astype(np.int64)
    cat = lambda f, dt: (np.concatenate([getattr(L, f) for L in lists]).astype(dt)
                         if lists else np.zeros(0, dt))
    return (starts, np.array([L.light_buf for L in lists], np.int64),
            np.array([L.entry_buf for L in lists], np.int64),
            np.array([L.runs for L in lists], np.bool_),
            cat("light", np.int64), cat("slot", np.int64), cat("entry_off", np.int64))


def tree_visits(depth, base, count, nodes) -> np.ndarray:
    """(V, 5) int64 rows (lane, visit, node, leaf first, leaf count) of every lane's
    traversal of `count` nodes from `base` (layouts.TREE_NODE records)."""
    from cpu_prep import limits
    args = (np.ascontiguousarray(depth, np.float32), np.asarray(base, np.int64),
            np.asarray(count, np.int64), *_node_columns(nodes), limits.NODE_COUNT_BITS)
    n = _tree_visits(*args, None)
    out = np.zeros((n, 5), np.int64)
    _tree_visits(*args, out)
    return out
