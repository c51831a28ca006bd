"""Per-wave execution figures of a shading pass: a lockstep replay of what every lane of the
technique's shading pass does, over the technique's own built structure.

A GPU runs each 8x8 group of a shading pass (glsl/pixel.glsl) as 64 / W waves of W
consecutive invocations (W = 32: NVIDIA, RDNA wave32; 64: GCN; 8: llvmpipe's native
subgroup), and the lanes of a wave execute each instruction together, idle ones masked.
A technique describes its shading pass (Technique.wave_program) as *segments*, one per lane
and step:

    segment = (lane, branch, step, head fetch, list of lights)

    step    the alignment key: the segments of one wave with the same (branch, step) run as
            one issued iteration of their loop, lanes without one masked.  A per-lane list
            loop is one step; a tree traversal one step per node visit (a lane's k-th visit
            runs with the other lanes' k-th: lockstep, no re-synchronisation); a scalarized
            loop gives the lanes of one round the same step.
    branch  sides of a divergent if/else that a wave runs one after the other (the hybrid's
            mixed path: its list lanes, then its tree lanes).
    head    the fetch of the step itself (a cell record, a tree node, a bit-array word, a node
            from shared memory): its kind, buffer, byte offset and size, and whether its
            address is wave-uniform by construction (a scalar load where the GPU has a
            scalar unit).
    list    the lights the step evaluates in order, (list, first, count): an inner loop of
            max(count) issued iterations over the step's lanes, each fetching the entry
            (an index list's word, if any) and the light (96 B), then evaluating it.

    wave:   step 0 | cell | light light light          (lanes 0..W-1 in lockstep)
            step 1 | node | light light
            step 2 | node |                             issued = per step 1 + max(count)

Per issued iteration the replay counts the active lanes, the load instructions (vector or
scalar), the distinct 64-byte lines they touch, and, for light iterations, the light shapes
tested and shaded (a shape's code runs when any active lane needs it) and whether an affected
lane is specular (GGX).  Two loops are walked by the replay itself rather than given as
segments, which would cost more than the loops: a lane's tree traversal (Program.add_tree:
one segment a lane, the kernel steps the lanes' traversals in lockstep, a node visit a
step) and a bit-array technique's word loop (Program.bit_words: zbin, raster).  A list
walked as evaluate_all_lights walks every light (LightList.runs: brute, overflowed tiles)
is tested light by light as one list, and each run of 32 lights then issues its set-bit
loop: as many iterations as the run's busiest lane has affecting lights (set_bit).

Per pixel it adds up what the lane evaluated, visited and found affecting, so a test can hold
the replay to the shader's own counters (PixelStats.evaluated, .nodes; contrib_count up to
the float32 rounding of the CPU's copy of the affects test).  Whether a light affects a
lane is decided by a float32 copy of glsl's light_affects_as (affects() below): it only
steers which iterations pay for the shading code, never a count the tests compare exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from cpu_prep import layouts, limits, zbin as zb
from scenes.model import LIGHT_TYPES

WIDTHS = (32, 64)               # the wave widths the model reports (NVIDIA / RDNA, GCN)
GROUP = 8                       # the shading pass's 8x8 groups (pixel.glsl)
LINE = 64                       # bytes of a cache line in the figures
LIGHT_BYTES = layouts.GPU_LIGHT.itemsize

# Loop kinds (rows of Figures.loops): what one issued iteration of that kind does.  The
# shading pass's (the kernels below index the first six by number), then the culling
# passes' (Technique.cull_figures: counted from their fixed loops, analytic()).
KINDS = ("cell", "node", "lds_node", "word", "load", "light",
         "depth", "cull_test", "prune", "aabb", "vertex", "fragment", "set_bit", "mask_light")
CELL, NODE, LDS_NODE, WORD, LOAD, LIGHT = range(6)
SET_BIT = KINDS.index("set_bit")   # evaluate_all_lights' set-bit loop (LightList.runs)
MASK_LIGHT = KINDS.index("mask_light")   # ... and its affects-mask loop over a run's lights
RUN = 32                           # its lights a mask (glsl/pixel.glsl LIGHT_RUN)
# Fields per kind: issued iterations, active lane-iterations, vector load instructions,
# scalar load instructions, distinct lines of the vector loads, of the scalar loads, lanes
# reading shared memory (LDS).
FIELDS = ("issued", "lanes", "vector_loads", "scalar_loads", "vector_lines", "scalar_lines",
          "lds_reads")
ISSUED, LANES, VLOADS, SLOADS, VLINES, SLINES, LDS = range(len(FIELDS))
NTYPES = len(LIGHT_TYPES)
SHARED = -2                     # head buffer: shared memory (no global fetch)
_COUNT_BITS = limits.NODE_COUNT_BITS    # tree node bits (layouts.node_bits)


# ---- lanes ------------------------------------------------------------------------------

def lanes(size: tuple[int, int], width: int) -> tuple[np.ndarray, np.ndarray, int]:
    """(wave, lane) of every pixel, GL row order (index y * w + x), and the waves launched:
    group (x // 8, y // 8) in dispatch order, invocation (y % 8) * 8 + x % 8 in it, wave
    invocation // W.  Every group launches 64 / W waves, also those wholly past the image."""
    if GROUP * GROUP % width:
        raise ValueError(f"wave width {width} does not divide the {GROUP}x{GROUP} group")
    w, h = size
    gx, gy = -(-w // GROUP), -(-h // GROUP)
    y, x = np.divmod(np.arange(w * h, dtype=np.int64), w)
    group = (y // GROUP) * gx + x // GROUP
    local = (y % GROUP) * GROUP + x % GROUP
    per = GROUP * GROUP // width
    return group * per + local // width, local % width, gx * gy * per


# ---- what a replay reads of the frame ---------------------------------------------------

@dataclass
class FrameData:
    """A rendered frame as the replay reads it, GL row order (pixel index y * w + x): the
    technique's build, the frame's buffers (`read`), and per pixel what the shading pass saw."""
    build: object                  # app.pipeline.passes.Build
    opts: object                   # the technique's Options
    read: object                   # read(buffer name) -> array of the frame (renderer.read)
    size: tuple[int, int]
    position: np.ndarray           # (N, 4) float32 view-space xyz, depth (0: sky)
    specular: np.ndarray           # (N,) bool: GGX material (roughness > 0)
    cell: np.ndarray               # (N,) uint32 out_cell: the structure cell the pixel read
    size_of: object = None         # size_of(buffer name) -> bytes the frame provided
    names: frozenset = frozenset()  # the buffers the frame provided
    unbounded: bool = False        # UNBOUNDED_FALLOFF: every light affects every point
    live: np.ndarray | None = None  # (N,) bool: the pixels a sampled replay walks (sampled())
    programs: dict = field(default_factory=dict)   # pass name -> [ProgramKey] (app.model.counts)

    @property
    def shading(self) -> np.ndarray:
        return self.position[:, 3] > 0

    @property
    def pixel_xy(self) -> tuple[np.ndarray, np.ndarray]:
        w = self.size[0]
        y, x = np.divmod(np.arange(len(self.cell), dtype=np.int64), w)
        return x, y

    @property
    def group(self) -> np.ndarray:
        """The 8x8 group (dispatch order) of every pixel."""
        x, y = self.pixel_xy
        return (y // GROUP) * -(-self.size[0] // GROUP) + x // GROUP


# ---- programs ---------------------------------------------------------------------------

@dataclass
class LightList:
    """Lights a step's inner loop walks: per position the light (index into lights[], for
    the affects test), its slot in the light buffer it is fetched from, and the byte offset
    of the entry fetched first (-1: none, e.g. brute's loop or a bit array's set bits).
    runs: walked as evaluate_all_lights walks every light (glsl/pixel.glsl): per run of RUN
    positions the affects tests (light iterations), then the shading of each lane's
    affecting lights in order (set_bit iterations: as many as the run's busiest lane has)."""
    light: np.ndarray
    slot: np.ndarray
    entry_off: np.ndarray
    light_buf: int
    entry_buf: int
    runs: bool = False


class Program:
    """A shading pass as segments (module doc), built by Technique.wave_program.  What is
    the same for every segment of one add() (its branch, head kind and buffer, list) is kept
    once, in the call table; a segment holds its lane, step, head offset and list range."""

    def __init__(self, frame: FrameData, width: int):
        self.frame, self.width = frame, width
        self.wave, self.lane, self.waves = lanes(frame.size, width)
        self.buffers: dict[str, int] = {}
        self.buffer("lights", len(frame.build.lights) * LIGHT_BYTES)
        self.lists: list[LightList] = []
        self.calls: list[tuple] = []
        self._segs: list[tuple] = []
        self._all: int | None = None
        self.nodes = None          # the TREE_NODE records add_tree's traversals walk
        self.barriers = 0          # barrier() calls over the pass, every group's
        self.words: dict | None = None

    def all_lights(self) -> int:
        """The list of every visible light in order (brute; tiles that shade every light)."""
        if self._all is None:
            self._all = self.add_list(np.arange(len(self.frame.build.lights)), runs=True)
        return self._all

    @property
    def groups(self) -> int:
        return self.waves * self.width // (GROUP * GROUP)

    def buffer(self, name: str, nbytes: int) -> int:
        """The id of a buffer the pass reads (its bytes: for the unique-line count)."""
        if name not in self.buffers:
            self.buffers[name] = int(nbytes)
        return list(self.buffers).index(name)

    def add_list(self, light, entry_off=None, entry_buf: str | None = None,
                 slot=None, light_buf: str = "lights", light_buf_bytes: int | None = None,
                 runs: bool = False) -> int:
        light = np.asarray(light, np.int64)
        ebuf = -1 if entry_buf is None else self.buffer(entry_buf, self.frame.size_of(entry_buf))
        lbuf = self.buffer(light_buf, light_buf_bytes or self.frame.size_of(light_buf))
        self.lists.append(LightList(
            light, light.copy() if slot is None else np.asarray(slot, np.int64),
            np.full(len(light), -1, np.int64) if entry_off is None else np.asarray(entry_off, np.int64),
            lbuf, ebuf, bool(runs)))
        return len(self.lists) - 1

    def add(self, lane, step=0, branch=0, head=None, lights=None, tree: bool = False) -> None:
        """Segments for the pixels `lane` (an index array; scalars broadcast):
        head = (kind, buffer name or SHARED, byte offsets, bytes, scalar) or None,
        lights = (list id, first, count, scalar) or None.  tree: each segment is a whole
        traversal (add_tree) whose head is its node visits and lights its leaves'."""
        lane = np.asarray(lane, np.int64).ravel()
        n = len(lane)
        if n == 0:
            return
        b = lambda v: np.broadcast_to(np.asarray(v, np.int64), (n,))
        kind, hbuf, hoff, hbytes, hscalar = -1, -1, 0, 0, False
        if head is not None:
            name, buf, hoff, hbytes, hscalar = head
            kind = KINDS.index(name)
            hbuf = SHARED if buf is SHARED else self.buffer(buf, self.frame.size_of(buf))
        lid, first, count, lscalar = (-1, 0, 0, False) if lights is None else lights
        if not 0 <= int(branch) < 4:
            raise ValueError(f"branch {branch} out of 0..3")
        self.calls.append((int(branch), kind, hbuf, int(hbytes), bool(hscalar), int(lid),
                           bool(lscalar), bool(tree)))
        self._segs.append((lane, b(step), b(hoff), b(first), b(count), len(self.calls) - 1))

    def add_tree(self, lanes, base, count, nodes, list_id: int, step0: int = 1,
                 branch: int = 0, shared: bool = False) -> None:
        """A stackless traversal per lane (tree paper listing 3, glsl/tree.glsl) of `count`
        nodes from `base`, walked in lockstep by the replay from step `step0`: its node
        fetches (from `nodes`, or shared memory: the shared-tree paths), then each hit
        leaf's list (`list_id`, positions = the node's first_light + k)."""
        if self.nodes is not None and self.nodes is not nodes:
            raise ValueError("one program walks one node buffer")
        self.nodes = nodes
        head = ("lds_node", SHARED, 0, 16, False) if shared else \
            ("node", "nodes", 0, layouts.TREE_NODE.itemsize, False)
        self.add(lanes, step=step0, branch=branch, head=head, lights=(list_id, base, count, False),
                 tree=True)

    def bit_words(self, address, lo, hi, bits_buf: str, words: int, masked: bool,
                  scalarized: bool, printed: bool = False) -> None:
        """The pass is a bit-array word loop (shade_zbin.comp, raster_shade_cluster.comp):
        per pixel the word offset of its tile (or cluster) in `bits_buf`, its z-bin id range
        [lo, hi] (unmasked: [0, 2^32 - 1]); `words` per tile; the z-bin mask as the slides
        print it (`printed`) or exact."""
        bits = np.ascontiguousarray(self.frame.read(bits_buf)).view(np.uint32)
        self.words = dict(address=np.asarray(address, np.int64), lo=np.asarray(lo, np.int64),
                          hi=np.asarray(hi, np.int64), bits=bits, buf=self.buffer(bits_buf, bits.nbytes),
                          words=int(words), masked=bool(masked), scalarized=bool(scalarized),
                          printed=bool(printed))

    def segments(self) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Every segment (lane, step, hoff, first, count, call), sorted by (wave, branch,
        step, lane), and the call table ((C, 8) int64: branch, kind, hbuf, hbytes, hscalar,
        list, lscalar, tree)."""
        calls = np.array(self.calls, np.int64).reshape(-1, 8)
        names = ("lane", "step", "hoff", "first", "count")
        if not self._segs:
            return {k: np.zeros(0, np.int64) for k in names + ("call",)}, calls
        seg = {k: np.concatenate([s[i] for s in self._segs]) for i, k in enumerate(names)}
        seg["call"] = np.concatenate([np.full(len(s[0]), s[5], np.int64) for s in self._segs])
        if seg["step"].max() >= 1 << 24 or seg["step"].min() < 0:
            raise ValueError("a segment's step is out of 0..2^24")
        key = ((self.wave[seg["lane"]] * 4 + calls[seg["call"], 0]) << 24 | seg["step"]) << 6 \
            | self.lane[seg["lane"]]
        order = np.argsort(key, kind="stable")
        return {k: v[order] for k, v in seg.items()}, calls


# ---- figures ----------------------------------------------------------------------------

@dataclass
class Figures:
    """One pass at one wave width: per loop kind (KINDS x FIELDS), the light shapes tested
    and shaded, and the frame's totals."""
    width: int
    waves: int                     # launched (every group's 64 / W waves)
    busy_waves: int                # with at least one shading lane
    pixels: int
    shading_pixels: int
    loops: np.ndarray = field(default_factory=lambda: np.zeros((len(KINDS), len(FIELDS)), np.int64))
    tested: np.ndarray = field(default_factory=lambda: np.zeros(NTYPES, np.int64))
    shaded: np.ndarray = field(default_factory=lambda: np.zeros(NTYPES, np.int64))
    specular: int = 0              # light iterations in which an affected lane ran GGX
    unique_bytes: dict = field(default_factory=dict)   # buffer -> bytes of distinct lines read
    barriers: int = 0              # per pass (every group's)
    atomics: int = 0               # global atomics (culling passes)
    shared_atomics: int = 0
    graphics: bool = False         # a raster pass (vertex and fragment work)
    fragments: int = 0             # its fragments (depth tests)
    # what one issued iteration of each kind costs, counted from the pass's own program
    # (app.model.counts.program_counts: kind / "test:<shape>" / "shade:<shape>" / "ggx" /
    # "wave" -> [alu, trans, idiv, wred]); None until the cost model's counts are attached
    ops: dict | None = None
    programs: tuple = ()           # the shader files of the programs the counts come from
    stands_for: str = ""           # a regex of the frame's passes this figure prices, where
                                   # it is not one pass of its own name (raster's proxies)

    def loop_sum(self, name: str) -> int:
        """A field summed over every loop kind."""
        return int(self.loops[:, FIELDS.index(name)].sum())

    def loop(self, kind: str) -> dict[str, int]:
        return dict(zip(FIELDS, (int(v) for v in self.loops[KINDS.index(kind)])))

    def as_dict(self) -> dict:
        """Flat figures (the benchmark's stats column and the report): everything the cost
        model reads, so that a row's modelled times can be derived again (from_dict)."""
        out = {"width": self.width, "waves": self.waves, "busy_waves": self.busy_waves,
               "barriers": self.barriers, "pixels": self.pixels,
               "shading_pixels": self.shading_pixels, "graphics": bool(self.graphics)}
        for k, kind in enumerate(KINDS):
            for f, name in enumerate(FIELDS):
                if self.loops[k, f]:
                    out[f"{kind}_{name}"] = int(self.loops[k, f])
        for t, name in enumerate(LIGHT_TYPES):
            if self.tested[t]:
                out[f"tested_{name}"] = int(self.tested[t])
                out[f"shaded_{name}"] = int(self.shaded[t])
        out["specular_iterations"] = int(self.specular)
        out["unique_bytes"] = int(sum(self.unique_bytes.values()))
        for k in ("atomics", "shared_atomics", "fragments"):
            if getattr(self, k):
                out[k] = int(getattr(self, k))
        if self.ops is not None:
            out["ops"] = {k: [float(x) for x in v] for k, v in sorted(self.ops.items())}
            out["programs"] = list(self.programs)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "Figures":
        """The figures as_dict() wrote (unique bytes as one total: the model sums them)."""
        f = cls(width=int(d["width"]), waves=int(d["waves"]), busy_waves=int(d["busy_waves"]),
                pixels=int(d["pixels"]), shading_pixels=int(d["shading_pixels"]),
                specular=int(d.get("specular_iterations", 0)),
                unique_bytes={"all": int(d.get("unique_bytes", 0))},
                barriers=int(d.get("barriers", 0)), atomics=int(d.get("atomics", 0)),
                shared_atomics=int(d.get("shared_atomics", 0)), graphics=bool(d["graphics"]),
                fragments=int(d.get("fragments", 0)), ops=d.get("ops"),
                programs=tuple(d.get("programs", ())))
        for k, kind in enumerate(KINDS):
            for j, name in enumerate(FIELDS):
                f.loops[k, j] = int(d.get(f"{kind}_{name}", 0))
        for t, name in enumerate(LIGHT_TYPES):
            f.tested[t] = int(d.get(f"tested_{name}", 0))
            f.shaded[t] = int(d.get(f"shaded_{name}", 0))
        return f

    def scaled(self, factor: float, caps: dict) -> "Figures":
        """These figures of a sample of the waves stood for the whole pass: the work scaled
        by `factor`, each buffer's distinct bytes too but never past its size (`caps`)."""
        k = lambda v: int(round(v * factor))
        out = Figures(width=self.width, waves=self.waves, busy_waves=k(self.busy_waves),
                      pixels=self.pixels, shading_pixels=k(self.shading_pixels),
                      loops=np.rint(self.loops * factor).astype(np.int64),
                      tested=np.rint(self.tested * factor).astype(np.int64),
                      shaded=np.rint(self.shaded * factor).astype(np.int64),
                      specular=k(self.specular), barriers=k(self.barriers),
                      unique_bytes={n: min(k(b), -(-caps.get(n, b) // LINE) * LINE)
                                    for n, b in self.unique_bytes.items()},
                      atomics=self.atomics, shared_atomics=self.shared_atomics,
                      graphics=self.graphics, fragments=self.fragments, ops=self.ops,
                      programs=self.programs)
        return out

    @property
    def simd_use(self) -> float:
        """Active lanes per issued lane slot over every loop kind (1.0: no lane idle)."""
        issued = self.loops[:, ISSUED].sum()
        return float(self.loops[:, LANES].sum() / (issued * self.width)) if issued else 1.0


def per_tile(frame: FrameData, tile: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """(pixels, covered pixels) per screen tile of `tile` px (row-major) and the tile grid."""
    x, y = frame.pixel_xy
    tx, ty = -(-frame.size[0] // tile), -(-frame.size[1] // tile)
    t = (y // tile) * tx + x // tile
    return (np.bincount(t, minlength=tx * ty), np.bincount(t[frame.shading], minlength=tx * ty),
            tx, ty)


def analytic(width: int, waves: int, loops: dict, unique_bytes: dict | None = None, **kw) -> Figures:
    """Figures of a pass whose loops have fixed trip counts (a culling pass): per kind
    (issued, lanes, vector loads, vector lines[, scalar loads, scalar lines]) summed over its
    waves, counted by the technique from the frame's sizes and counts."""
    f = Figures(width=width, waves=int(waves), busy_waves=int(waves), pixels=0, shading_pixels=0,
                unique_bytes=dict(unique_bytes or {}), **kw)
    cols = ("issued", "lanes", "vector_loads", "vector_lines", "scalar_loads", "scalar_lines")
    for kind, vals in loops.items():
        for name, v in zip(cols, vals):
            f.loops[KINDS.index(kind), FIELDS.index(name)] += int(v)
    return f


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
    pl = fr.build.lights
    g = pl.gpu
    L = np.ascontiguousarray(g).view(np.float32).reshape(len(g), layouts.LIGHT_WORDS)
    types = np.ascontiguousarray(pl.type, np.int64)
    bound = light_bounds(L[:, _POS:_POS + 4], L[:, _EXT:_EXT + 4], types)
    P = np.ascontiguousarray(fr.position[:, :3], np.float32)
    spec = np.ascontiguousarray(fr.specular, np.bool_)
    names = list(prog.buffers)
    sizes = np.array([max(prog.buffers[k], 1) for k in names], np.int64)
    line_base = np.concatenate([[0], np.cumsum((sizes + LINE - 1) // LINE)]).astype(np.int64)
    seen = np.zeros(int(line_base[-1]), np.bool_)
    loops = np.zeros((len(KINDS), len(FIELDS)), np.int64)
    types_acc = np.zeros((3, NTYPES), np.int64)          # tested, shaded, (specular in [2, 0])
    per_pixel = np.zeros((n_pix, 3), np.int64)           # evaluated, nodes, contrib
    light_args = (L, types, bound, bool(fr.unbounded))
    if prog.words is not None:
        wd = prog.words
        order = np.lexsort((prog.lane, prog.wave))       # pixels by (wave, lane)
        live = np.ones(n_pix, np.bool_) if fr.live is None else fr.live
        _replay_words(order, prog.wave[order], fr.shading[order], live[order], wd["address"][order],
                      wd["lo"][order], wd["hi"][order], wd["bits"], wd["words"], wd["masked"],
                      wd["scalarized"], wd["printed"], int(wd["buf"]), P, spec, *light_args,
                      line_base, seen, loops, types_acc, per_pixel)
    seg, calls = prog.segments()
    if len(seg["lane"]):
        flat = _flatten(prog.lists)
        nodes = prog.nodes if prog.nodes is not None else np.zeros(1, layouts.TREE_NODE)
        depth = np.ascontiguousarray(fr.position[:, 3], np.float32)
        _replay_segments(prog.wave[seg["lane"]], seg["lane"], seg["step"], seg["hoff"],
                         seg["first"], seg["count"], seg["call"], calls, *flat,
                         np.ascontiguousarray(nodes["min_depth"]), np.ascontiguousarray(nodes["max_depth"]),
                         nodes["first_light"].astype(np.int64), nodes["bits"].astype(np.int64),
                         depth, P, spec, *light_args, line_base, seen, loops, types_acc, per_pixel)
    busy = np.unique(prog.wave[fr.shading]).size
    fig = Figures(width=prog.width, waves=prog.waves, busy_waves=int(busy), pixels=n_pix,
                  shading_pixels=int(fr.shading.sum()), loops=loops, tested=types_acc[0].copy(),
                  shaded=types_acc[1].copy(), specular=int(types_acc[2, 0]),
                  barriers=int(prog.barriers))
    for k, name in enumerate(names):
        fig.unique_bytes[name] = int(seen[line_base[k]:line_base[k + 1]].sum()) * LINE
    return Replay(fig, per_pixel[:, 0].copy(), per_pixel[:, 1].copy(), per_pixel[:, 2].copy())


def light_bounds(pos, ext, types) -> np.ndarray:
    """A bounding sphere radius per light around its position (point/spot: the radius;
    capsule: radius + half length; box: its half diagonal), a little grown."""
    r = pos[:, 3].astype(np.float64)
    r = np.where(types == LIGHT_TYPES.index("capsule"), r + 0.5 * ext[:, 3], r)
    r = np.where(types == LIGHT_TYPES.index("box"), np.linalg.norm(ext[:, :3].astype(np.float64), axis=1), r)
    return (r * 1.001 + 1e-6).astype(np.float32)


def _flatten(lists: list[LightList]):
    starts = np.concatenate([[0], np.cumsum([len(L.light) for L in lists])]).astype(np.int64)
    cat = lambda f, dt: (np.concatenate([getattr(L, f) for L in lists]).astype(dt)
                         if lists else np.zeros(0, dt))
    return (starts, np.array([L.light_buf for L in lists], np.int64),
            np.array([L.entry_buf for L in lists], np.int64),
            np.array([L.runs for L in lists], np.bool_),
            cat("light", np.int64), cat("slot", np.int64), cat("entry_off", np.int64))


# ---- the numba kernels ------------------------------------------------------------------
# One issued iteration's distinct lines: a small open-addressing set, cleared by stamping.

_SET = 1024


@numba.njit(inline="always")
def _set_add(keys, stamps, stamp, key) -> int:
    """Add a line to this iteration's set; 1 if it was new."""
    h = (key * 0x9E3779B97F4A7C15) & (_SET - 1)
    while True:
        if stamps[h] != stamp:
            stamps[h] = stamp
            keys[h] = key
            return 1
        if keys[h] == key:
            return 0
        h = (h + 1) & (_SET - 1)


@numba.njit(inline="always")
def _lines(keys, stamps, stamp, seen, base, off, nbytes) -> int:
    """New distinct lines of a fetch of `nbytes` at byte `off` of the buffer whose first line
    is `base`; marks them in the frame's unique-line map."""
    new = 0
    for line in range(off // 64, (off + max(nbytes, 1) - 1) // 64 + 1):
        key = base + line
        seen[key] = True
        new += _set_add(keys, stamps, stamp, key)
    return new


# word offsets of a GPU_LIGHT row (layouts: one source), compile-time constants below
_POS, _DIR = layouts.LIGHT_POS_RADIUS, layouts.LIGHT_DIR_COS_OUTER
_EXT, _RIGHT = layouts.LIGHT_EXTENT_LENGTH, layouts.LIGHT_RIGHT


@numba.njit(inline="always")
def affects(px, py, pz, i, L, types, unbounded) -> bool:
    """glsl light_affects_as in float32 (pixel.glsl, features.py SHAPES): the view-space
    point P inside light i's volume; L holds the GPU_LIGHT rows as float32 words."""
    if unbounded:
        return True
    f32 = np.float32
    dx, dy, dz = f32(px - L[i, _POS]), f32(py - L[i, _POS + 1]), f32(pz - L[i, _POS + 2])
    d2 = f32(dx * dx + dy * dy + dz * dz)
    r2 = L[i, _POS + 3] * L[i, _POS + 3]
    t = types[i]
    if t == 0:                                   # point
        return d2 < r2
    fx, fy, fz = L[i, _DIR], L[i, _DIR + 1], L[i, _DIR + 2]
    along = f32(dx * fx + dy * fy + dz * fz)
    if t == 1:                                   # spot: the sphere cut by the cone
        return d2 < r2 and along > f32(L[i, _DIR + 3] * np.sqrt(d2))
    if t == 2:                                   # capsule: distance to the segment
        h = f32(0.5) * L[i, _EXT + 3]
        s = min(max(along, -h), h)
        qx, qy, qz = f32(dx - fx * s), f32(dy - fy * s), f32(dz - fz * s)
        return f32(qx * qx + qy * qy + qz * qz) < r2
    # box: the local frame (right, up' = right x direction, direction)
    rx, ry, rz = L[i, _RIGHT], L[i, _RIGHT + 1], L[i, _RIGHT + 2]
    ux, uy, uz = f32(ry * fz - rz * fy), f32(rz * fx - rx * fz), f32(rx * fy - ry * fx)
    a = abs(f32(dx * rx + dy * ry + dz * rz))
    b = abs(f32(dx * ux + dy * uy + dz * uz))
    return a < L[i, _EXT] and b < L[i, _EXT + 1] and abs(along) < L[i, _EXT + 2]


@numba.njit(inline="always")
def _misses_box(i, L, bound, lo, hi) -> bool:
    """Light i's bounding sphere misses the box [lo, hi] of the iteration's lane positions."""
    d2 = np.float32(0.0)
    for k in range(3):
        c = L[i, _POS + k]
        e = lo[k] - c if c < lo[k] else (c - hi[k] if c > hi[k] else np.float32(0.0))
        d2 += e * e
    return d2 > bound[i] * bound[i]


@numba.njit(cache=True)
def _issue_lists(n, e_lane, e_list, e_first, e_count, e_scalar, list_start, list_lbuf, list_ebuf,
                 list_runs, flat_light, flat_slot, flat_eoff, P, spec, L, types, bound,
                 unbounded, keys, stamps, stamp, lo, hi, shapes, shaded, line_base, seen, loops,
                 types_acc, per_pixel, wx, wy, wz, wacc, wbits) -> int:
    """The inner light loops of n lanes run together: max(count) issued iterations, each
    the lanes' entry and light fetches and affects tests; returns the set's stamp.  The
    lanes' positions and hit counts live in the work arrays w* while the loops run."""
    longest = 0
    same = n > 0                 # every lane walks the same list (one cell, or wave-uniform)
    for q in range(n):
        longest = max(longest, e_count[q])
        same &= e_scalar[q] == e_scalar[0] and e_list[q] == e_list[0] and \
            e_first[q] == e_first[0] and e_count[q] == e_count[0]
    if longest == 0:
        return stamp
    lo[:] = np.inf
    hi[:] = -np.inf
    for q in range(n):
        px = e_lane[q]
        wx[q], wy[q], wz[q], wacc[q] = P[px, 0], P[px, 1], P[px, 2], 0
        per_pixel[px, 0] += e_count[q]
        if e_count[q] > 0:
            for k in range(3):
                lo[k] = min(lo[k], P[px, k])
                hi[k] = max(hi[k], P[px, k])
    if same:            # one list walked alike (brute's loop, a tile's list): per light, not lane
        lid, f0 = e_list[0], e_first[0]
        col = 3 if e_scalar[0] else 2                   # its loads: scalar or vector
        runs = list_runs[lid]
        row = MASK_LIGHT if runs else LIGHT      # evaluate_all_lights' mask loop, or a list's
        loops[row, 0] += longest
        loops[row, 1] += longest * n
        for t in range(longest):
            p = list_start[lid] + f0 + t
            li = flat_light[p]
            lines = 0
            if flat_eoff[p] >= 0:
                loops[row, col] += 1
                seen[line_base[list_ebuf[lid]] + flat_eoff[p] // 64] = True
                lines += 1
            off = flat_slot[p] * 96
            for line in range(off // 64, (off + 95) // 64 + 1):
                seen[line_base[list_lbuf[lid]] + line] = True
                lines += 1
            loops[row, col] += 1
            loops[row, col + 2] += lines
            types_acc[0, types[li]] += 1
            if runs and t % RUN == 0:
                wbits[:n] = 0
            if unbounded or not _misses_box(li, L, bound, lo, hi):
                hit, sp = False, False
                for q in range(n):
                    if affects(wx[q], wy[q], wz[q], li, L, types, unbounded):
                        if runs:
                            wbits[q] |= 1 << (t % RUN)
                        else:
                            wacc[q] += 1
                            hit = True
                            sp |= spec[e_lane[q]]
                if not runs:
                    types_acc[1, types[li]] += hit
                    types_acc[2, 0] += sp
            if runs and (t % RUN == RUN - 1 or t == longest - 1):
                stamp = _issue_set_bits(n, e_lane, wbits, list_start[lid] + f0 + t - t % RUN,
                                        line_base[list_lbuf[lid]], flat_light, flat_slot, spec,
                                        types, keys, stamps, stamp, seen, shaded, loops,
                                        types_acc, wacc)
    else:
        for t in range(longest):
            stamp += 1
            active, lines, entry_loads, scalar = 0, 0, False, False
            shapes[:] = False
            shaded[:] = False
            any_spec = False
            last, last_p, miss = -1, -1, False
            for q in range(n):
                if e_count[q] <= t:
                    continue
                lid = e_list[q]
                p = list_start[lid] + e_first[q] + t
                li = flat_light[p]
                active += 1
                scalar = e_scalar[q]
                if p != last_p:                  # lanes of one cell fetch the same entry
                    last_p = p
                    if flat_eoff[p] >= 0:
                        entry_loads = True
                        lines += _lines(keys, stamps, stamp, seen, line_base[list_ebuf[lid]],
                                        flat_eoff[p], 4)
                    lines += _lines(keys, stamps, stamp, seen, line_base[list_lbuf[lid]],
                                    flat_slot[p] * 96, 96)
                last, miss, hit = _evaluate(li, last, miss, wx[q], wy[q], wz[q], L, types, bound,
                                            lo, hi, unbounded, shapes, shaded)
                if hit:
                    wacc[q] += 1
                    any_spec |= spec[e_lane[q]]
            _issue_lights(active, 2 if entry_loads else 1, lines, scalar, shapes, shaded,
                          any_spec, loops, types_acc)
    for q in range(n):
        per_pixel[e_lane[q], 2] += wacc[q]
    return stamp


@numba.njit(inline="always")
def _issue_set_bits(n, e_lane, wbits, p0, lbase, flat_light, flat_slot, spec, types, keys,
                    stamps, stamp, seen, shaded, loops, types_acc, wacc) -> int:
    """evaluate_all_lights' set-bit loop over one run (glsl/pixel.glsl): per issued
    iteration every lane with bits left shades its lowest one (a vector load of its light,
    the shapes the lanes are at); as many iterations as the busiest lane has bits (none for
    an empty run: a GPU tests the loop before its body).  Returns the stamp."""
    while True:
        stamp += 1
        active, lines, any_spec = 0, 0, False
        shaded[:] = False
        for q in range(n):
            m = wbits[q]
            if m == 0:
                continue
            bit = 0
            while not (m >> bit) & 1:
                bit += 1
            wbits[q] = m & (m - 1)
            p = p0 + bit
            li = flat_light[p]
            active += 1
            lines += _lines(keys, stamps, stamp, seen, lbase, flat_slot[p] * 96, 96)
            shaded[types[li]] = True
            any_spec |= spec[e_lane[q]]
            wacc[q] += 1
        if active == 0:
            return stamp
        loops[SET_BIT, 0] += 1
        loops[SET_BIT, 1] += active
        _count_loads(SET_BIT, 1, lines, False, loops)
        for ty in range(types_acc.shape[1]):
            types_acc[1, ty] += shaded[ty]
        types_acc[2, 0] += any_spec


@numba.njit(inline="always")
def _count_loads(kind, loads, lines, scalar, loops):
    """An issued iteration's loads and cache lines, on the scalar or the vector unit."""
    if scalar:
        loops[kind, 3] += loads
        loops[kind, 5] += lines
    else:
        loops[kind, 2] += loads
        loops[kind, 4] += lines


@numba.njit(inline="always")
def _issue_head(kind, heads, lines, scalar, lds, loops):
    """One issued iteration of a head kind over `heads` lanes."""
    loops[kind, 0] += 1
    loops[kind, 1] += heads
    if lds:
        loops[kind, 6] += heads
    else:
        _count_loads(kind, 1, lines, scalar, loops)


@numba.njit(inline="always")
def _wave_scratch():
    """A replay's scratch: the cache-line set (_lines: keys, stamps), a wave's box of
    shading positions (lo, hi) and the light shapes an iteration met and shaded."""
    return (np.zeros(_SET, np.int64), np.zeros(_SET, np.int64), np.empty(3, np.float32),
            np.empty(3, np.float32), np.zeros(8, np.bool_), np.zeros(8, np.bool_))


@numba.njit(inline="always")
def _positions(n):
    """x, y, z of n lanes' positions (float32, as the shader's)."""
    xyz = np.zeros((3, n), np.float32)
    return xyz[0], xyz[1], xyz[2]


@numba.njit(inline="always")
def _evaluate(li, last, miss, x, y, z, L, types, bound, lo, hi, unbounded, shapes, shaded):
    """A lane's evaluate_light of light li at (x, y, z): the wave's box test once per light
    in a row (lanes on one light share it; `last`, `miss`: the previous one's), then the
    lane's own test.  Returns (li, its miss, whether it affects the lane)."""
    if li != last:
        shapes[types[li]] = True
        miss = not unbounded and _misses_box(li, L, bound, lo, hi)
    hit = not miss and affects(x, y, z, li, L, types, unbounded)
    if hit:
        shaded[types[li]] = True
    return li, miss, hit


@numba.njit(inline="always")
def _issue_lights(active, loads, lines, scalar, shapes, shaded, any_spec, loops, types_acc):
    """One issued iteration of a light loop over `active` lanes: its loads (the entry and
    the light, or the light) and lines, the shapes it met and those it shaded."""
    loops[5, 0] += 1
    loops[5, 1] += active
    _count_loads(5, loads, lines, scalar, loops)
    for ty in range(types_acc.shape[1]):
        types_acc[0, ty] += shapes[ty]
        types_acc[1, ty] += shaded[ty]
    types_acc[2, 0] += any_spec


@numba.njit(cache=True)
def _replay_segments(wave, lane, step, hoff, first, count, call, calls,
                     list_start, list_lbuf, list_ebuf, list_runs, flat_light, flat_slot,
                     flat_eoff, nmin, nmax, nfirst, nbits, depth,
                     P, spec, L, types, bound, unbounded,
                     line_base, seen, loops, types_acc, per_pixel):
    """Groups of segments of one (wave, branch, step): their heads as one issued iteration,
    then their lists together; a group's tree segments walk their trees in lockstep, a
    node visit per lane a step, each visit's hit leaves' lists together."""
    n = len(wave)
    biggest, i = 0, 0
    while i < n:                                         # the largest group, for buffers
        j = i
        while j < n and wave[j] == wave[i] and calls[call[j], 0] == calls[call[i], 0] \
                and step[j] == step[i]:
            j += 1
        biggest = max(biggest, j - i)
        i = j
    keys, stamps, lo, hi, shapes, shaded = _wave_scratch()
    stamp = 0
    # per segment of a group: its list entry (lane, list, first, count), tree walk (segment,
    # cursor) and lights affecting it; the lane's position
    ints = np.zeros((8, biggest), np.int64)
    e_lane, e_list, e_first, e_count, t_seg, t_cur, wacc, wbits = \
        ints[0], ints[1], ints[2], ints[3], ints[4], ints[5], ints[6], ints[7]
    e_scalar = np.zeros(biggest, np.bool_)
    wx, wy, wz = _positions(biggest)
    cmask = (1 << _COUNT_BITS) - 1
    i = 0
    while i < n:
        j = i
        while j < n and wave[j] == wave[i] and calls[call[j], 0] == calls[call[i], 0] \
                and step[j] == step[i]:
            j += 1
        # heads of the plain segments: one issued iteration
        stamp += 1
        kind, heads, lines, scalar, lds = -1, 0, 0, False, False
        # m is _issue_lists' n: typed, not the literal 0, or numba compiles _issue_lists
        # twice, once for n = Literal[int](0) (a call's literal argument is its own
        # specialization: ~6 s more of a cold compile, the same code)
        m, trees = np.int64(0), 0
        for s in range(i, j):
            c = call[s]
            if calls[c, 7]:                              # a tree: walked below
                t_seg[trees] = s
                t_cur[trees] = 0
                trees += 1
                continue
            if calls[c, 1] >= 0:
                kind = calls[c, 1]
                heads += 1
                scalar = calls[c, 4] != 0
                if kind == 1 or kind == 2:               # a node visit (global or shared)
                    per_pixel[lane[s], 1] += 1
                if calls[c, 2] == -2:
                    lds = True
                else:
                    lines += _lines(keys, stamps, stamp, seen, line_base[calls[c, 2]], hoff[s], calls[c, 3])
            if calls[c, 5] >= 0 and count[s] > 0:
                e_lane[m], e_list[m], e_first[m] = lane[s], calls[c, 5], first[s]
                e_count[m], e_scalar[m] = count[s], calls[c, 6] != 0
                m += 1
        if kind >= 0:
            _issue_head(kind, heads, lines, scalar, lds, loops)
        stamp = _issue_lists(m, e_lane, e_list, e_first, e_count, e_scalar, list_start,
                             list_lbuf, list_ebuf, list_runs, flat_light, flat_slot, flat_eoff, P,
                             spec, L, types, bound, unbounded, keys, stamps,
                             stamp, lo, hi, shapes, shaded, line_base, seen, loops, types_acc,
                             per_pixel, wx, wy, wz, wacc, wbits)
        # the group's traversals in lockstep
        while trees > 0:
            stamp += 1
            heads, lines, m = 0, 0, np.int64(0)          # m typed: see above
            kind, lds = -1, False
            for q in range(trees):
                s = t_seg[q]
                c = call[s]
                if t_cur[q] >= count[s]:
                    continue
                node = first[s] + t_cur[q]
                heads += 1
                kind = calls[c, 1]
                per_pixel[lane[s], 1] += 1
                if calls[c, 2] == -2:
                    lds = True
                else:
                    lines += _lines(keys, stamps, stamp, seen, line_base[calls[c, 2]], node * 16, 16)
                d = depth[lane[s]]
                bits = nbits[node]
                if d >= nmin[node] and d <= nmax[node]:
                    if bits & 1:
                        e_lane[m], e_list[m], e_first[m] = lane[s], calls[c, 5], nfirst[node]
                        e_count[m], e_scalar[m] = (bits >> 1) & cmask, False
                        m += 1
                    t_cur[q] += 1
                else:
                    t_cur[q] += bits >> (1 + _COUNT_BITS)
            if heads == 0:
                break
            _issue_head(kind, heads, lines, False, lds, loops)
            stamp = _issue_lists(m, e_lane, e_list, e_first, e_count, e_scalar, list_start,
                                 list_lbuf, list_ebuf, list_runs, flat_light, flat_slot, flat_eoff,
                                 P, spec, L, types, bound, unbounded, keys, stamps,
                                 stamp, lo, hi, shapes, shaded, line_base, seen, loops,
                                 types_acc, per_pixel, wx, wy, wz, wacc, wbits)
        i = j


@numba.njit(inline="always")
def _zbin_mask(lo, hi, w, printed):
    """A lane's z-bin mask of word w (shade_zbin.comp zbin_word_mask)."""
    return np.uint32(zb.zbin_word_mask(lo, hi, w) if printed else zb.range_mask(lo, hi, w))


@numba.njit(cache=True)
def _replay_words(order, wave, shading, live, address, zlo, zhi, bits, words, masked, scalarized,
                  printed, bits_buf, P, spec, L, types, bound, unbounded,
                  line_base, seen, loops, types_acc, per_pixel):
    """shade_zbin.comp / raster_shade_cluster.comp: per wave the word range (masked: from
    the lanes' z-bin min / max), per word the lanes' words (a vector load each), then the
    per-lane bit loop (max set bits) or the scalar loop over the wave's OR of them."""
    n = len(order)
    keys, stamps, lo, hi, shapes, shaded = _wave_scratch()
    stamp = 0
    own = np.zeros(64, np.uint32)
    wx, wy, wz = _positions(64)
    w_ev = np.zeros(64, np.int64)
    w_hit = np.zeros(64, np.int64)
    empty_min = 0x7FFFFFFF
    i = 0
    while i < n:
        j = i
        while j < n and wave[j] == wave[i]:
            j += 1
        w0, w1 = 0, words
        if masked:
            mn, mx = empty_min, 0
            for s in range(i, j):
                if shading[s]:
                    mn = min(mn, zlo[s])
                    mx = max(mx, zhi[s])
            w0, w1 = max(w0, mn // 32), min(w1, mx // 32 + 1)
        busy, alive = 0, False
        for s in range(i, j):
            q = s - i
            alive |= live[s]
            wx[q], wy[q], wz[q] = P[order[s], 0], P[order[s], 1], P[order[s], 2]
            w_ev[q], w_hit[q] = 0, 0
            busy += shading[s]
            if shading[s]:
                for k in range(3):
                    lo[k] = P[order[s], k] if busy == 1 else min(lo[k], P[order[s], k])
                    hi[k] = P[order[s], k] if busy == 1 else max(hi[k], P[order[s], k])
        if busy == 0:
            if scalarized and w1 > w0 and alive:  # the native loop runs its words unguarded
                loops[3, 0] += w1 - w0
            i = j
            continue
        for wd in range(w0, w1):
            # the word: a vector load per shading lane (lane_word)
            stamp += 1
            lines = 0
            merged = np.uint32(0)
            longest = 0
            for s in range(i, j):
                m = np.uint32(0)
                if shading[s]:
                    a = address[s] + wd
                    lines += _lines(keys, stamps, stamp, seen, line_base[bits_buf], a * 4, 4)
                    m = bits[a]
                    if masked:
                        m &= _zbin_mask(zlo[s], zhi[s], wd, printed)
                own[s - i] = m
                merged |= m
                c = 0
                x = m
                while x:
                    x &= x - np.uint32(1)
                    c += 1
                longest = max(longest, c)
            loops[3, 0] += 1
            loops[3, 1] += busy
            loops[3, 2] += 1
            loops[3, 4] += lines
            if scalarized:
                for s in range(i, j):
                    own[s - i] = merged if shading[s] else np.uint32(0)
            # the light loop: per lane its own bits in order, or every lane the merged bits
            t = 0
            while True:
                stamp += 1
                active, lines, scalar = 0, 0, scalarized
                shapes[:] = False
                shaded[:] = False
                any_spec = False
                last, miss = -1, False
                for s in range(i, j):
                    m = own[s - i]
                    if m == 0:
                        continue
                    bit = 0
                    while not (m >> np.uint32(bit)) & np.uint32(1):
                        bit += 1
                    own[s - i] = m & (m - np.uint32(1))
                    li = wd * 32 + bit
                    q = s - i
                    active += 1
                    w_ev[q] += 1
                    if li != last:               # lanes of one tile fetch the same light
                        lines += _lines(keys, stamps, stamp, seen, line_base[0], li * 96, 96)
                    last, miss, hit = _evaluate(li, last, miss, wx[q], wy[q], wz[q], L, types,
                                                bound, lo, hi, unbounded, shapes, shaded)
                    if hit:
                        w_hit[q] += 1
                        any_spec |= spec[order[s]]
                if active == 0:
                    break
                t += 1
                _issue_lights(active, 1, lines, scalar, shapes, shaded, any_spec, loops,
                              types_acc)
        for s in range(i, j):               # the wave's lanes' sums, once
            per_pixel[order[s], 0] += w_ev[s - i]
            per_pixel[order[s], 2] += w_hit[s - i]
        i = j


def sampled(frame: FrameData, every: int) -> tuple[FrameData, float]:
    """The frame with only every `every`-th 8x8 group shading (the others read as sky), and
    the share of the shading pixels it keeps: a replay of it, scaled by 1 / share, stands for
    the whole frame (the benchmark's 1080p validation runs; every test replays every wave)."""
    if every <= 1:
        return frame, 1.0
    keep = frame.group % every == 0
    pos = frame.position.copy()
    pos[~keep] = 0.0
    share = float((keep & frame.shading).sum()) / max(int(frame.shading.sum()), 1)
    from dataclasses import replace
    return replace(frame, position=pos, live=keep), share


def frame_data(renderer, result, opts, unbounded: bool = False) -> FrameData:
    """What the replay reads of the frame the renderer just rendered (with read-back)."""
    from ..pipeline.passes import OUT_CELL
    w, h = renderer.size
    return FrameData(build=result.build, opts=opts, read=renderer.read, size=(w, h),
                     position=np.ascontiguousarray(renderer.gbuffer.read_position().reshape(-1, 4)),
                     specular=renderer.gbuffer.read_normal().reshape(-1, 4)[:, 3] > 0,
                     cell=renderer.read(OUT_CELL).astype(np.int64), size_of=renderer.nbytes,
                     names=frozenset(renderer.provided()), unbounded=unbounded,
                     programs={k: list(v) for k, v in renderer._frame.programs.items()})


# ---- shared walks -----------------------------------------------------------------------

@numba.njit(cache=True)
def _tree_visits(depth, base, count, nmin, nmax, nfirst, nbits, count_bits, out):
    """Tree paper listing 3 for each lane (glsl/tree.glsl traverse_tree): its node visits in
    order.  out=None counts them; else fills out[k] = (lane, visit, node, leaf first, leaf
    count: 0 unless the visit hit a leaf)."""
    k = 0
    cmask = (1 << count_bits) - 1
    for lane in range(len(depth)):
        i = 0
        visit = 0
        d = depth[lane]
        while i < count[lane]:
            node = base[lane] + i
            bits = nbits[node]
            hit = d >= nmin[node] and d <= nmax[node]
            first, n = 0, 0
            if hit:
                if bits & 1:
                    first = nfirst[node]
                    n = (bits >> 1) & cmask
                i += 1
            else:
                i += bits >> (1 + count_bits)
            if out is not None:
                out[k, 0] = lane
                out[k, 1] = visit
                out[k, 2] = node
                out[k, 3] = first
                out[k, 4] = n
            k += 1
            visit += 1
    return k


def tree_visits(depth, base, count, nodes) -> np.ndarray:
    """(V, 5) int64 rows (lane, visit, node, leaf first, leaf count) of every lane's
    traversal of `count` nodes from `base` (layouts.TREE_NODE records)."""
    from cpu_prep import limits
    args = (np.ascontiguousarray(depth, np.float32), np.asarray(base, np.int64),
            np.asarray(count, np.int64), np.ascontiguousarray(nodes["min_depth"]),
            np.ascontiguousarray(nodes["max_depth"]), nodes["first_light"].astype(np.int64),
            nodes["bits"].astype(np.int64), limits.NODE_COUNT_BITS)
    n = _tree_visits(*args, None)
    out = np.zeros((n, 5), np.int64)
    _tree_visits(*args, out)
    return out


def rounds(prog: Program, lanes, cells) -> np.ndarray:
    """Scalarized walk over containers (lists.glsl evaluate_cells_scalarized): the round in
    which each lane's cell is walked, numbered per wave in order of the first lane still
    waiting (the native loop's waveReadFirstLane)."""
    lanes = np.asarray(lanes, np.int64)
    if not len(lanes):
        return np.zeros(0, np.int64)
    cells = np.asarray(cells, np.int64)
    order = np.lexsort((prog.lane[lanes], prog.wave[lanes]))
    w = prog.wave[lanes][order]
    pair = w * (int(cells.max()) + 1) + cells[order]
    _, first, inverse = np.unique(pair, return_index=True, return_inverse=True)
    by = np.lexsort((first, w[first]))             # the wave's pairs in order of first lane
    pw = w[first][by]
    new = np.r_[True, pw[1:] != pw[:-1]]
    k = np.arange(len(by))
    rank = np.empty(len(by), np.int64)
    rank[by] = k - np.maximum.accumulate(np.where(new, k, 0))
    out = np.empty(len(lanes), np.int64)
    out[order] = rank[inverse.ravel()]
    return out
