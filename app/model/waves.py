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
            is step k: lockstep, no re-synchronisation); a scalarized loop gives the lanes of
            one round the same step.
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
lane is specular (GGX).  A bit-array technique (zbin, raster) walks words instead of lists:
replay_words() replays its word loop directly (materialising a segment per word and lane
would cost more than the loop).

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

from cpu_prep import layouts, zbin as zb
from scenes.model import LIGHT_TYPES

WIDTHS = (32, 64)               # the wave widths the model reports (NVIDIA / RDNA, GCN)
GROUP = 8                       # the shading pass's 8x8 groups (pixel.glsl)
LINE = 64                       # bytes of a cache line in the figures
LIGHT_BYTES = layouts.GPU_LIGHT.itemsize

# Loop kinds (rows of Figures.loops): what one issued iteration of that kind does.  The
# shading pass's (the kernels below index the first six by number), then the culling
# passes' (Technique.cull_figures: counted from their fixed loops, analytic()).
KINDS = ("cell", "node", "lds_node", "word", "load", "light",
         "depth", "cull_test", "prune", "aabb", "vertex", "fragment")
CELL, NODE, LDS_NODE, WORD, LOAD, LIGHT = range(6)
# Fields per kind: issued iterations, active lane-iterations, vector load instructions,
# scalar load instructions, distinct lines of the vector loads, of the scalar loads, lanes
# reading shared memory (LDS).
FIELDS = ("issued", "lanes", "vector_loads", "scalar_loads", "vector_lines", "scalar_lines",
          "lds_reads")
ISSUED, LANES, VLOADS, SLOADS, VLINES, SLINES, LDS = range(len(FIELDS))
NTYPES = len(LIGHT_TYPES)
SHARED = -2                     # head buffer: shared memory (no global fetch)


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
    of the entry fetched first (-1: none, e.g. brute's loop or a bit array's set bits)."""
    light: np.ndarray
    slot: np.ndarray
    entry_off: np.ndarray
    light_buf: int
    entry_buf: int


class Program:
    """A shading pass as segments (module doc), built by Technique.wave_program."""

    def __init__(self, frame: FrameData, width: int):
        self.frame, self.width = frame, width
        self.wave, self.lane, self.waves = lanes(frame.size, width)
        self.buffers: dict[str, int] = {}
        self.buffer("lights", len(frame.build.lights) * LIGHT_BYTES)
        self.lists: list[LightList] = []
        self._segs: list[dict] = []
        self._all: int | None = None
        self.barriers = 0          # barrier() calls over the pass, every group's
        self.words: dict | None = None

    def all_lights(self) -> int:
        """The list of every visible light in order (brute; tiles that shade every light)."""
        if self._all is None:
            self._all = self.add_list(np.arange(len(self.frame.build.lights)))
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
                 slot=None, light_buf: str = "lights", light_buf_bytes: int | None = None) -> int:
        light = np.asarray(light, np.int64)
        ebuf = -1 if entry_buf is None else self.buffer(entry_buf, self.frame.size_of(entry_buf))
        lbuf = self.buffer(light_buf, light_buf_bytes or self.frame.size_of(light_buf))
        self.lists.append(LightList(
            light, light.copy() if slot is None else np.asarray(slot, np.int64),
            np.full(len(light), -1, np.int64) if entry_off is None else np.asarray(entry_off, np.int64),
            lbuf, ebuf))
        return len(self.lists) - 1

    def add(self, lane, step=0, branch=0, head=None, lights=None) -> None:
        """Segments for the pixels `lane` (an index array; scalars broadcast):
        head = (kind, buffer name or SHARED, byte offsets, bytes, scalar) or None,
        lights = (list id, first, count, scalar) or None."""
        lane = np.asarray(lane, np.int64).ravel()
        n = len(lane)
        if n == 0:
            return
        b = lambda v, dt: np.broadcast_to(np.asarray(v, dt), (n,))
        seg = {"lane": lane, "step": b(step, np.int64), "branch": b(branch, np.int64)}
        if head is None:
            seg.update(kind=b(-1, np.int64), hbuf=b(-1, np.int64), hoff=b(0, np.int64),
                       hbytes=b(0, np.int64), hscalar=b(False, np.bool_))
        else:
            kind, buf, off, nbytes, scalar = head
            bid = SHARED if buf is SHARED else self.buffer(buf, self.frame.size_of(buf))
            seg.update(kind=b(KINDS.index(kind), np.int64), hbuf=b(bid, np.int64),
                       hoff=b(off, np.int64), hbytes=b(nbytes, np.int64), hscalar=b(scalar, np.bool_))
        if lights is None:
            seg.update(list=b(-1, np.int64), first=b(0, np.int64), count=b(0, np.int64),
                       lscalar=b(False, np.bool_))
        else:
            lid, first, count, scalar = lights
            seg.update(list=b(lid, np.int64), first=b(first, np.int64), count=b(count, np.int64),
                       lscalar=b(scalar, np.bool_))
        self._segs.append(seg)

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

    def segments(self) -> dict[str, np.ndarray]:
        """Every segment, sorted by (wave, branch, step, lane)."""
        keys = ("lane", "step", "branch", "kind", "hbuf", "hoff", "hbytes", "hscalar", "list",
                "first", "count", "lscalar")
        if not self._segs:
            return {k: np.zeros(0, np.bool_ if k in ("hscalar", "lscalar") else np.int64) for k in keys}
        seg = {k: np.concatenate([s[k] for s in self._segs]) for k in keys}
        if seg["step"].max() >= 1 << 24 or seg["branch"].max() >= 4:
            raise ValueError("a segment's step or branch is out of the sort key's range")
        key = ((self.wave[seg["lane"]] * 4 + seg["branch"]) << 24 | seg["step"]) << 6 | self.lane[seg["lane"]]
        order = np.argsort(key, kind="stable")
        return {k: v[order] for k, v in seg.items()}


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

    def loop(self, kind: str) -> dict[str, int]:
        return dict(zip(FIELDS, (int(v) for v in self.loops[KINDS.index(kind)])))

    def as_dict(self) -> dict:
        """Flat figures (the benchmark's stats column and the report)."""
        out = {"waves": self.waves, "busy_waves": self.busy_waves, "barriers": self.barriers}
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
    pos = np.ascontiguousarray(g["pos_radius"], np.float32)
    dirs = np.ascontiguousarray(g["dir_cos_outer"], np.float32)
    ext = np.ascontiguousarray(g["extent_length"], np.float32)
    right = np.ascontiguousarray(g["right"], np.float32)
    types = np.ascontiguousarray(pl.type, np.int64)
    bound = light_bounds(pos, ext, types)
    P = np.ascontiguousarray(fr.position[:, :3], np.float32)
    spec = np.ascontiguousarray(fr.specular, np.bool_)
    names = list(prog.buffers)
    sizes = np.array([max(prog.buffers[k], 1) for k in names], np.int64)
    line_base = np.concatenate([[0], np.cumsum((sizes + LINE - 1) // LINE)]).astype(np.int64)
    seen = np.zeros(int(line_base[-1]), np.bool_)
    loops = np.zeros((len(KINDS), len(FIELDS)), np.int64)
    types_acc = np.zeros((3, NTYPES), np.int64)          # tested, shaded, (specular in [2, 0])
    per_pixel = np.zeros((n_pix, 3), np.int64)           # evaluated, nodes, contrib
    light_args = (pos, dirs, ext, right, types, bound, bool(fr.unbounded))
    if prog.words is not None:
        wd = prog.words
        order = np.lexsort((prog.lane, prog.wave))       # pixels by (wave, lane)
        _replay_words(order, prog.wave[order], fr.shading[order], wd["address"][order],
                      wd["lo"][order], wd["hi"][order], wd["bits"], wd["words"], wd["masked"],
                      wd["scalarized"], wd["printed"], int(wd["buf"]), P, spec, *light_args,
                      line_base, seen, loops, types_acc, per_pixel)
    seg = prog.segments()
    if len(seg["lane"]):
        flat = _flatten(prog.lists)
        _replay_segments(prog.wave[seg["lane"]], seg["branch"], seg["step"], seg["lane"],
                         seg["kind"], seg["hbuf"], seg["hoff"], seg["hbytes"], seg["hscalar"],
                         seg["list"], seg["first"], seg["count"], seg["lscalar"], *flat,
                         P, spec, *light_args, line_base, seen, loops, types_acc, per_pixel)
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


@numba.njit(inline="always")
def affects(px, py, pz, i, pos, dirs, ext, right, types, unbounded) -> bool:
    """glsl light_affects_as in float32 (pixel.glsl, features.py SHAPES): the point at view
    position P inside light i's volume."""
    if unbounded:
        return True
    dx = np.float32(px - pos[i, 0])
    dy = np.float32(py - pos[i, 1])
    dz = np.float32(pz - pos[i, 2])
    d2 = np.float32(dx * dx + dy * dy + dz * dz)
    r = pos[i, 3]
    t = types[i]
    if t == 0:                                   # point
        return d2 < r * r
    if t == 1:                                   # spot: the sphere cut by the cone
        along = np.float32(dx * dirs[i, 0] + dy * dirs[i, 1] + dz * dirs[i, 2])
        return d2 < r * r and along > np.float32(dirs[i, 3] * np.sqrt(d2))
    if t == 2:                                   # capsule
        h = np.float32(0.5) * ext[i, 3]
        s = np.float32(dx * dirs[i, 0] + dy * dirs[i, 1] + dz * dirs[i, 2])
        s = min(max(s, -h), h)
        qx = np.float32(dx - dirs[i, 0] * s)
        qy = np.float32(dy - dirs[i, 1] * s)
        qz = np.float32(dz - dirs[i, 2] * s)
        return np.float32(qx * qx + qy * qy + qz * qz) < r * r
    # box: local frame (right, up' = right x direction, direction)
    rx, ry, rz = right[i, 0], right[i, 1], right[i, 2]
    fx, fy, fz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
    ux = np.float32(ry * fz - rz * fy)
    uy = np.float32(rz * fx - rx * fz)
    uz = np.float32(rx * fy - ry * fx)
    a = abs(np.float32(dx * rx + dy * ry + dz * rz))
    b = abs(np.float32(dx * ux + dy * uy + dz * uz))
    c = abs(np.float32(dx * fx + dy * fy + dz * fz))
    return a < ext[i, 0] and b < ext[i, 1] and c < ext[i, 2]


@numba.njit(inline="always")
def _misses_box(i, pos, bound, lo, hi) -> bool:
    """Light i's bounding sphere misses the box [lo, hi] of the iteration's lane positions."""
    d2 = 0.0
    for k in range(3):
        c = pos[i, k]
        if c < lo[k]:
            d2 += (lo[k] - c) ** 2
        elif c > hi[k]:
            d2 += (c - hi[k]) ** 2
    return d2 > float(bound[i]) ** 2


@numba.njit(cache=True)
def _replay_segments(wave, branch, step, lane, kind, hbuf, hoff, hbytes, hscalar,
                     lst, first, count, lscalar,
                     list_start, list_lbuf, list_ebuf, flat_light, flat_slot, flat_eoff,
                     P, spec, pos, dirs, ext, right, types, bound, unbounded,
                     line_base, seen, loops, types_acc, per_pixel):
    n = len(wave)
    keys = np.zeros(_SET, np.int64)
    stamps = np.zeros(_SET, np.int64)
    stamp = 0
    lo = np.empty(3, np.float32)
    hi = np.empty(3, np.float32)
    shapes = np.zeros(8, np.bool_)
    shaded = np.zeros(8, np.bool_)
    i = 0
    while i < n:
        j = i
        while j < n and wave[j] == wave[i] and branch[j] == branch[i] and step[j] == step[i]:
            j += 1
        # the head: one issued iteration of its kind over the step's lanes that have one
        stamp += 1
        k0, heads, lines, scalar, lds = -1, 0, 0, False, False
        for s in range(i, j):
            if kind[s] >= 0:
                k0 = kind[s]
                heads += 1
                scalar = hscalar[s]
                if kind[s] == 1 or kind[s] == 2:         # a node visit (global or shared)
                    per_pixel[lane[s], 1] += 1
                if hbuf[s] == -2:                        # shared memory: no global line
                    lds = True
                else:
                    lines += _lines(keys, stamps, stamp, seen, line_base[hbuf[s]], hoff[s], hbytes[s])
        if k0 >= 0:
            loops[k0, 0] += 1
            loops[k0, 1] += heads
            if lds:
                loops[k0, 6] += heads
            elif scalar:
                loops[k0, 3] += 1
                loops[k0, 5] += lines
            else:
                loops[k0, 2] += 1
                loops[k0, 4] += lines
        # the inner light loop: max(count) issued iterations
        longest = 0
        for s in range(i, j):
            if lst[s] >= 0 and count[s] > longest:
                longest = count[s]
        if longest > 0:
            lo[:] = np.inf
            hi[:] = -np.inf
            for s in range(i, j):
                if lst[s] >= 0 and count[s] > 0:
                    for k in range(3):
                        lo[k] = min(lo[k], P[lane[s], k])
                        hi[k] = max(hi[k], P[lane[s], k])
        # a wave-uniform list every lane of the step walks alike (brute's loop, an
        # overflowed tile): its figures without visiting each lane at each light
        uniform = longest > 0 and lscalar[i] and lst[i] >= 0
        for s in range(i, j):
            uniform &= lst[s] == lst[i] and first[s] == first[i] and count[s] == count[i]
        if uniform:
            _uniform_list(i, j, lane, lst[i], first[i], count[i], list_start, list_lbuf,
                          list_ebuf, flat_light, flat_slot, flat_eoff, P, spec, pos, dirs, ext,
                          right, types, bound, unbounded, lo, hi, line_base, seen, loops,
                          types_acc, per_pixel)
            longest = 0
        for t in range(longest):
            stamp += 1
            active, lines, entry_loads, scalar = 0, 0, False, False
            shapes[:] = False
            shaded[:] = False
            any_spec = False
            last, last_p, miss = -1, -1, False
            for s in range(i, j):
                if lst[s] < 0 or count[s] <= t:
                    continue
                L = lst[s]
                p = list_start[L] + first[s] + t
                li = flat_light[p]
                active += 1
                scalar = lscalar[s]
                per_pixel[lane[s], 0] += 1
                if p != last_p:                  # lanes of one cell fetch the same entry
                    last_p = p
                    if flat_eoff[p] >= 0:
                        entry_loads = True
                        lines += _lines(keys, stamps, stamp, seen, line_base[list_ebuf[L]], flat_eoff[p], 4)
                    lines += _lines(keys, stamps, stamp, seen, line_base[list_lbuf[L]],
                                    flat_slot[p] * 96, 96)
                if li != last:
                    last = li
                    shapes[types[li]] = True
                    miss = not unbounded and _misses_box(li, pos, bound, lo, hi)
                if miss:
                    continue
                px = lane[s]
                if affects(P[px, 0], P[px, 1], P[px, 2], li, pos, dirs, ext, right, types, unbounded):
                    per_pixel[px, 2] += 1
                    shaded[types[li]] = True
                    any_spec |= spec[px]
            loops[5, 0] += 1
            loops[5, 1] += active
            loads = 1 + (1 if entry_loads else 0)
            if scalar:
                loops[5, 3] += loads
                loops[5, 5] += lines
            else:
                loops[5, 2] += loads
                loops[5, 4] += lines
            for ty in range(types_acc.shape[1]):
                types_acc[0, ty] += shapes[ty]
                types_acc[1, ty] += shaded[ty]
            types_acc[2, 0] += any_spec
        i = j


@numba.njit(cache=True)
def _uniform_list(i, j, lane, L, first, count, list_start, list_lbuf, list_ebuf, flat_light,
                  flat_slot, flat_eoff, P, spec, pos, dirs, ext, right, types, bound, unbounded,
                  lo, hi, line_base, seen, loops, types_acc, per_pixel):
    """The segments i..j-1 walk one wave-uniform list alike: `count` scalar iterations of
    j - i lanes, each one light (and entry) fetch; the lanes tested only where the light's
    bounding sphere meets their box."""
    n = j - i
    for s in range(i, j):
        per_pixel[lane[s], 0] += count
    loops[5, 0] += count
    loops[5, 1] += count * n
    for t in range(count):
        p = list_start[L] + first + t
        li = flat_light[p]
        lines = 0
        if flat_eoff[p] >= 0:
            loops[5, 3] += 1
            a = line_base[list_ebuf[L]] + flat_eoff[p] // 64
            seen[a] = True
            lines += 1
        off = flat_slot[p] * 96
        for line in range(off // 64, (off + 95) // 64 + 1):
            seen[line_base[list_lbuf[L]] + line] = True
            lines += 1
        loops[5, 3] += 1
        loops[5, 5] += lines
        ty = types[li]
        types_acc[0, ty] += 1
        if not unbounded and _misses_box(li, pos, bound, lo, hi):
            continue
        hit, sp = 0, False
        for s in range(i, j):
            px = lane[s]
            if affects(P[px, 0], P[px, 1], P[px, 2], li, pos, dirs, ext, right, types, unbounded):
                per_pixel[px, 2] += 1
                hit += 1
                sp |= spec[px]
        if hit:
            types_acc[1, ty] += 1
            types_acc[2, 0] += sp


@numba.njit(inline="always")
def _zbin_mask(lo, hi, w, printed):
    """A lane's z-bin mask of word w (shade_zbin.comp zbin_word_mask)."""
    return np.uint32(zb.zbin_word_mask(lo, hi, w) if printed else zb.range_mask(lo, hi, w))


@numba.njit(cache=True)
def _replay_words(order, wave, shading, address, zlo, zhi, bits, words, masked, scalarized,
                  printed, bits_buf, P, spec, pos, dirs, ext, right, types, bound, unbounded,
                  line_base, seen, loops, types_acc, per_pixel):
    """shade_zbin.comp / raster_shade_cluster.comp: per wave the word range (masked: from
    the lanes' z-bin min / max), per word the lanes' words (a vector load each), then the
    per-lane bit loop (max set bits) or the scalar loop over the wave's OR of them."""
    n = len(order)
    keys = np.zeros(_SET, np.int64)
    stamps = np.zeros(_SET, np.int64)
    stamp = 0
    lo = np.empty(3, np.float32)
    hi = np.empty(3, np.float32)
    own = np.zeros(64, np.uint32)
    shapes = np.zeros(8, np.bool_)
    shaded = np.zeros(8, np.bool_)
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
        busy = 0
        for s in range(i, j):
            busy += shading[s]
            if shading[s]:
                for k in range(3):
                    lo[k] = P[order[s], k] if busy == 1 else min(lo[k], P[order[s], k])
                    hi[k] = P[order[s], k] if busy == 1 else max(hi[k], P[order[s], k])
        if busy == 0:
            if scalarized and w1 > w0:           # the native loop runs its words unguarded
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
                    px = order[s]
                    active += 1
                    per_pixel[px, 0] += 1
                    if li != last:               # lanes of one tile fetch the same light
                        last = li
                        lines += _lines(keys, stamps, stamp, seen, line_base[0], li * 96, 96)
                        shapes[types[li]] = True
                        miss = not unbounded and _misses_box(li, pos, bound, lo, hi)
                    if miss:
                        continue
                    if affects(P[px, 0], P[px, 1], P[px, 2], li, pos, dirs, ext, right, types, unbounded):
                        per_pixel[px, 2] += 1
                        shaded[types[li]] = True
                        any_spec |= spec[px]
                if active == 0:
                    break
                t += 1
                loops[5, 0] += 1
                loops[5, 1] += active
                if scalar:
                    loops[5, 3] += 1
                    loops[5, 5] += lines
                else:
                    loops[5, 2] += 1
                    loops[5, 4] += lines
                for ty in range(types_acc.shape[1]):
                    types_acc[0, ty] += shapes[ty]
                    types_acc[1, ty] += shaded[ty]
                types_acc[2, 0] += any_spec
        i = j


def frame_data(renderer, result, opts, unbounded: bool = False) -> FrameData:
    """What the replay reads of the frame the renderer just rendered (with read-back)."""
    from ..pipeline.passes import OUT_CELL
    w, h = renderer.size
    return FrameData(build=result.build, opts=opts, read=renderer.read, size=(w, h),
                     position=np.ascontiguousarray(renderer.gbuffer.read_position().reshape(-1, 4)),
                     specular=renderer.gbuffer.read_normal().reshape(-1, 4)[:, 3] > 0,
                     cell=renderer.read(OUT_CELL).astype(np.int64), size_of=renderer.nbytes,
                     names=frozenset(renderer.provided()), unbounded=unbounded)


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


def add_tree(prog: Program, lanes, base, count, nodes, list_id: int, step0: int = 1,
             branch: int = 0, shared: bool = False) -> None:
    """Segments of a stackless traversal per lane (one step per visit from `step0`): the node
    fetch (from `nodes`, or shared memory: hybrid's and tree's shared tree), then the hit
    leaf's list (`list_id`, positions = node first_light + k)."""
    lanes = np.asarray(lanes, np.int64)
    v = tree_visits(prog.frame.position[lanes, 3], base, count, nodes)
    if not len(v):
        return
    head = ("lds_node", SHARED, 0, 16, False) if shared else \
        ("node", "nodes", v[:, 2] * layouts.TREE_NODE.itemsize, layouts.TREE_NODE.itemsize, False)
    prog.add(lanes[v[:, 0]], step=step0 + v[:, 1], branch=branch, head=head,
             lights=(list_id, v[:, 3], v[:, 4], False))


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
