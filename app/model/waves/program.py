"""A shading pass as the technique describes it (its replay.py's wave_program): the frame it
reads (FrameData), its lanes, the light lists its steps walk and its segments (Program),
and the helpers a technique builds its program with (rounds, sampled)."""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from cpu_prep import layouts

from .kernels import _gather_rows
from .kinds import GROUP, KINDS, LIGHT_BYTES, SHARED


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
    """A shading pass as segments (module doc), built by a replay.py's wave_program.  What is
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

    def segment_count(self) -> int:
        """The segments added so far (what the replay sorts and walks)."""
        return sum(len(s[0]) for s in self._segs)

    def segments(self) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Every segment (lane, step, hoff, first, count, call), sorted by (wave, branch,
        step, lane), and the call table ((C, 8) int64: branch, kind, hbuf, hbytes, hscalar,
        list, lscalar, tree)."""
        calls = np.array(self.calls, np.int64).reshape(-1, 8)
        names = ("lane", "step", "hoff", "first", "count", "call")
        if not self._segs:
            return {k: np.zeros(0, np.int64) for k in names}, calls
        cols = np.empty((len(names), sum(len(s[0]) for s in self._segs)), np.int64)
        at = 0
        for s in self._segs:              # the columns in the order the segments were added
            n = len(s[0])
            for i in range(5):
                cols[i, at:at + n] = s[i]
            cols[5, at:at + n] = s[5]
            at += n
        seg = dict(zip(names, cols))
        if seg["step"].max() >= 1 << 24 or seg["step"].min() < 0:
            raise ValueError("a segment's step is out of 0..2^24")
        key = ((self.wave[seg["lane"]] * 4 + calls[seg["call"], 0]) << 24 | seg["step"]) << 6 \
            | self.lane[seg["lane"]]
        order = np.argsort(key, kind="stable")
        return dict(zip(names, _gather_rows(order, cols))), calls


def lattice_step(every: int) -> int:
    """The row step of sampled()'s lattice: near every / golden ratio^2 and coprime with it,
    so that the kept groups of consecutive rows fall far apart (a rank-1 lattice)."""
    step = max(1, round(every * 0.381966))
    while math.gcd(step, every) != 1:
        step += 1
    return step


def sampled(frame: FrameData, every: int) -> tuple[FrameData, float]:
    """The frame with only one in `every` 8x8 groups shading (the others read as sky), and
    the share of the shading pixels it keeps: a replay of it, scaled by 1 / share, stands for
    the whole frame (the benchmark's 1080p validation runs; every test replays every wave).
    The kept groups are a lattice, (column + row x lattice_step) % every == 0: one in every
    `every` of each row and, where every divides into the rows, of each column too.  Every
    k-th group in dispatch order would keep whole columns of the image where `every` divides
    the groups of a row (at 1080p, 240): stripes, whose modelled lighting ms missed a replay
    of every 2nd group by up to 7.5% at every 32nd group and 6.9% at every 8th, where the
    lattice's stays within 1.0% at every 32nd (hangar and city at 1920x1080, 4,096 lights,
    every technique but the floor)."""
    if every <= 1:
        return frame, 1.0
    columns = -(-frame.size[0] // GROUP)
    g = frame.group
    keep = (g % columns + (g // columns) * lattice_step(every)) % every == 0
    pos = frame.position.copy()
    pos[~keep] = 0.0
    share = float((keep & frame.shading).sum()) / max(int(frame.shading.sum()), 1)
    from dataclasses import replace
    return replace(frame, position=pos, live=keep), share


def frame_data(renderer, result, opts, unbounded: bool = False) -> FrameData:
    """What the replay reads of the frame the renderer just rendered (with read-back)."""
    from ...pipeline.passes import OUT_CELL
    w, h = renderer.size
    return FrameData(build=result.build, opts=opts, read=renderer.read, size=(w, h),
                     position=np.ascontiguousarray(renderer.gbuffer.read_position().reshape(-1, 4)),
                     specular=renderer.gbuffer.read_normal().reshape(-1, 4)[:, 3] > 0,
                     cell=renderer.read(OUT_CELL).astype(np.int64), size_of=renderer.nbytes,
                     names=frozenset(renderer.provided()), unbounded=unbounded,
                     programs={k: list(v) for k, v in renderer._frame.programs.items()})


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
