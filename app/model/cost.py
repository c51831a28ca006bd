"""The GPU cost model: per-wave execution figures (app.model.waves) -> milliseconds on named
GPUs, from their public specifications alone.  Version MODEL_VERSION.

Nothing here is fitted to any paper's results: the GPU constants are the vendors' published
figures (the sources are beside each GPU below), the instruction counts are counted from
this lab's own GLSL (INSTRUCTIONS, with the counting rule), and the equations are the
throughput limits every GPU has.  A pass of figures F on GPU g (wave width W = g.wave,
U units (SMs / CUs) at f Hz):

    ALU      T_alu  = I x W / (U x lanes x f)
             I = sum over loop kinds k of  issued_k x alu_k  +  issued_k x trans_k / sfu
                 + for the light loop, per shape s:  tested_s x test_s + shaded_s x shade_s
                 + specular x ggx  +  waves x wave      (instructions per wave, summed)
             a wave issues every instruction for all W lanes, idle or not: divergence and
             idle lanes are in `issued`; trans_k are quarter-rate (sfu = 1/4) or eighth-rate
             transcendentals (sqrt, inversesqrt, log, exp, rcp)
    L1       T_l1   = sum_k max(vector_loads_k x W / addr, vector_lines_k x 64 / l1) / (U x f)
             a vector load needs its lanes' addresses (addr per clock) and its distinct
             lines (l1 bytes per clock); a wave-uniform (scalar) load costs the same on a GPU
             without a scalar unit, and nothing on the vector path where there is one (GCN's
             scalar cache; its own throughput is not modelled)
             + lds_reads x 16 / (U x lds)        (tree nodes read from shared memory)
    DRAM     T_dram = (unique bytes read + per-pixel bytes) / bandwidth
             every distinct 64-B line of the pass's buffers once (a perfect L2), plus a
             shading pass's 52 B a pixel: the G-buffer's 36 B read, the colour's 16 B written
             (the 20 B of counters and cell the lab's shaders also write for the exactness
             check are left out: a production pass writes none, and they are the same for
             every technique; a measured GPU time includes them)
    raster   T_rast = max(vertices x vertex / (U_g x lanes x f), fragments / (rops x f))
             (a raster pass: vertex work on the graphics-capable units U_g, one depth
             test per ROP and clock)

    T_pass = max(T_alu, T_l1, T_dram, T_rast)

What it ignores, and which way that errs:
  * occupancy and latency hiding: it assumes enough waves in flight to keep every unit busy
    (optimistic for register-heavy shaders: the slides' 56 -> 32 VGPR occupancy gain is not
    in it, nor is the cost of a small frame that fills no GPU);
  * the scalar unit's own cost and GCN's SGPR/VGPR split beyond the loads (see L1);
  * caches between L1 and DRAM (an L2 that misses), bank conflicts, atomic contention at one
    address (atomics count as vector memory instructions), barriers (counted, not timed);
  * instruction issue details: dual issue, fused multiply-add pairs, the compiler's own
    schedule; a kernel launch's fixed cost (a few microseconds);
  * the limits overlap perfectly (max, not sum): a lower bound on time.
So read its milliseconds as a ranking and a ratio between techniques on one GPU, with an
absolute scale to be checked against a measured GPU (scripts/gpu_check.sh), never as a
measurement.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.model import LIGHT_TYPES

from .waves import FIELDS, KINDS, LINE, Figures

# 2: evaluate_all_lights (brute, overflowed tiles) shades in a set-bit loop after its masks
MODEL_VERSION = "2"


@dataclass(frozen=True)
class GPU:
    """A GPU's public figures (sources in GPUS' comments)."""
    name: str
    key: str                # short id for column names
    units: int              # SMs / CUs
    lanes: int              # FP32 lanes per unit
    wave: int               # native wave width
    clock_ghz: float        # boost clock (the papers' cards ran at boost)
    dram_gbs: float         # DRAM bandwidth
    l1_bytes_clk: int       # L1 bytes per clock per unit
    addr_clk: int           # lanes' addresses a unit's load path takes per clock
    scalar_unit: bool       # wave-uniform loads bypass the vector memory path
    sfu: float              # transcendental rate relative to FP32 lanes
    lds_bytes_clk: int      # shared memory bytes per clock per unit
    rops: int               # depth tests per clock (raster passes)
    graphics_units: int     # units that run graphics (vertex / fragment) work
    note: str = ""


GPUS = (
    # GTX 980 whitepaper (v1.1): 16 SMM x 128 lanes, 4 warp schedulers of 32, 1216 MHz boost,
    # 224 GB/s, 64 ROPs; CUDA C++ Programming Guide 5.x: 32 LD/ST units, SFU 1/4 rate,
    # shared memory 32 banks x 4 B a clock.  L1 bandwidth is not published: the shared
    # memory's 128 B/clk stands in.  No scalar unit.
    GPU("NVIDIA GeForce GTX 980 (Maxwell GM204)", "gtx980", 16, 128, 32, 1.216, 224.0,
        128, 32, False, 0.25, 128, 64, 16),
    # AMD Polaris / GCN: 36 CUs x 4 SIMD16, wave64, 1266 MHz boost, 256 GB/s (8 GB card);
    # GPUOpen "GCN memory coalescing": buffer loads 16 lanes' addresses a clock; GCN vector
    # L1 64 B/clk, 64 B lines; SALU + scalar data cache; LDS 32 banks x 4 B; 32 ROPs;
    # transcendentals 1/4 rate.
    GPU("AMD Radeon RX 480 (Polaris 10, GCN 4)", "rx480", 36, 64, 64, 1.266, 256.0,
        64, 16, True, 0.25, 128, 32, 36),
    # PS4 "Liverpool": 18 GCN CUs at 800 MHz (Sony: 1.84 TFLOPS = 18 x 64 x 2 x 0.8 GHz),
    # 176 GB/s GDDR5, 32 ROPs; the CU as GCN above.
    GPU("Sony PS4 GPU (GCN 1.1, 18 CUs)", "ps4", 18, 64, 64, 0.800, 176.0,
        64, 16, True, 0.25, 128, 32, 18),
    # H100 whitepaper (GH100 SXM5; H200 is the same die with HBM3e): 132 SMs x 128 lanes,
    # ~1980 MHz boost, 4.8 TB/s (H200 brief); CUDA guide 9.0: 32 LD/ST, SFU 1/8 rate.  L1
    # bandwidth unpublished (128 B/clk as for the 980).  Only two TPCs (4 SMs) run graphics
    # (H100 whitepaper, section 4); ROPs unpublished: 4 SMs' lanes stand in.
    GPU("NVIDIA H200 (Hopper GH100)", "h200", 132, 128, 32, 1.980, 4800.0,
        128, 32, False, 0.125, 128, 16, 4,
        note="raster work on its 2 graphics TPCs only; whether OpenGL compute uses all 132 SMs "
             "is unpublished"),
)
BY_KEY = {g.key: g for g in GPUS}
# GL_RENDERER strings of the modelled GPUs (lower case), for measured-vs-modelled runs
RENDERER_NAMES = {"gtx980": ("gtx 980",), "rx480": ("rx 480", "polaris10", "ellesmere"),
                  "ps4": ("liverpool",), "h200": ("h200",)}


def match(renderer: str) -> GPU | None:
    """The modelled GPU a GL_RENDERER string names, if any."""
    r = renderer.lower()
    return next((BY_KEY[k] for k, names in RENDERER_NAMES.items() if any(n in r for n in names)), None)

# Instructions per issued iteration, counted from the GLSL by one rule: one per scalar add /
# mul / fma / compare / select / bit op after vec3 ops are split (a vec3 op is 3, a dot 3),
# one issue slot per load or store instruction (their data is timed by L1 / DRAM), a loop's
# counter, test and branch 3; an integer division by a uniform 10 plus a reciprocal (GPUs
# have no integer divider); transcendentals (sqrt, inversesqrt, log, exp, rcp) counted apart.
# (alu, trans) per loop kind:
INSTRUCTIONS = {
    "cell": (32, 3),        # cell_of: two divisions for the tile, listing 4's slice (a log),
                            # the cell index, the record's load
    "node": (19, 0),        # visit_node: loop, address, load, counter, the depth-bounds test,
                            # leaf bit, count and skip fields, the cursor
    "lds_node": (19, 0),
    "word": (40, 0),        # lane_word: address, load, range_mask and the window mask, AND,
                            # popcount, the wave OR (a few cross-lane steps), loop
    "load": (6, 0),         # load_shared_tree: one node a lane
    "light": (13, 0),       # the light loop: counter, entry and light addresses, 4 loads,
                            # s.evaluated, d = P - L (the test's shared part); in
                            # evaluate_all_lights' mask loop the entry address (it has no
                            # entry) stands for the mask bit's shift and OR
    "set_bit": (18, 0),     # evaluate_all_lights' set-bit loop: loop 3, findLSB, clearing
                            # the bit 2, the light's address 2, 4 loads, d = P - L and d2 again
    # culling passes
    "depth": (6, 0),        # a tile's min/max depth: one texel, two shared atomics
    "cull_test": (40, 2),   # tile_cull's sphere test (four planes, inversesqrt each pair) /
                            # fptl's coarse AABB test (6 compares: counted as 40 with the loop)
    "prune": (4 * 12, 0),   # fptl fine pruning: four pixels' affects tests (point cost each)
    "aabb": (600, 20),      # fptl_aabb.comp: the OBB's 6 quads clipped to the frustum, the
                            # sphere's rectangle (273 lines of GLSL, counted once per light)
    "vertex": (30, 1),      # raster_proxy.vert: placing one proxy vertex
    "fragment": (20, 1),    # raster_mark.frag: the linear-depth test and the bit's address
}
# The light loop per shape: the affects test, and the shading code where it affects
# (count, hash, radiance, Lambert response), as (alu, trans):
TEST = {"point": (8, 0), "spot": (13, 1), "capsule": (16, 0), "box": (23, 0)}
SHADE = {"point": (45, 4), "spot": (57, 5), "capsule": (54, 4), "box": (60, 3)}
GGX = (75, 6)               # material.glsl's GGX term on top (specular surfaces)
WAVE = (40, 0)              # per wave: the G-buffer fetch, the stores, the counters
PIXEL_BYTES = 36 + 16       # G-buffer read, colour written, per pixel (module doc)
assert set(INSTRUCTIONS) <= set(KINDS) and set(TEST) == set(SHADE) == set(LIGHT_TYPES)


def instructions(f: Figures, gpu: GPU) -> float:
    """I: instructions per lane slot summed over the pass's waves (module doc)."""
    w = lambda ops: ops[0] + ops[1] / gpu.sfu
    issued = f.loops[:, FIELDS.index("issued")]
    total = sum(issued[k] * w(INSTRUCTIONS.get(kind, (0, 0))) for k, kind in enumerate(KINDS))
    for t, shape in enumerate(LIGHT_TYPES):
        total += f.tested[t] * w(TEST[shape]) + f.shaded[t] * w(SHADE[shape])
    total += f.specular * w(GGX)
    if f.shading_pixels:                 # a shading pass: every launched wave's fixed work
        total += f.waves * w(WAVE)
    return float(total)


def times(f: Figures, gpu: GPU) -> dict[str, float]:
    """The four limits of one pass, seconds (module doc), for figures at the GPU's width."""
    if f.width != gpu.wave:
        raise ValueError(f"{gpu.key}: figures of {f.width}-lane waves, the GPU runs {gpu.wave}")
    hz = gpu.clock_ghz * 1e9
    col = lambda name: f.loops[:, FIELDS.index(name)]
    vloads, vlines = col("vector_loads"), col("vector_lines")
    sloads, slines = col("scalar_loads"), col("scalar_lines")
    if not gpu.scalar_unit:              # a uniform load is a vector load sharing an address
        vloads, vlines = vloads + sloads, vlines + slines
    l1_cycles = np.maximum(vloads * gpu.wave / gpu.addr_clk, vlines * LINE / gpu.l1_bytes_clk).sum()
    l1_cycles += col("lds_reads").sum() * 16 / gpu.lds_bytes_clk
    graphics = f.graphics
    units = gpu.graphics_units if graphics else gpu.units
    alu = instructions(f, gpu) * gpu.wave / (units * gpu.lanes * hz)
    dram = (sum(f.unique_bytes.values()) + f.pixels * (PIXEL_BYTES if f.shading_pixels else 0)) \
        / (gpu.dram_gbs * 1e9)
    rast = f.fragments / (gpu.rops * hz) if graphics else 0.0
    return {"alu": alu, "l1": float(l1_cycles) / (units * hz), "dram": dram, "raster": rast}


def pass_ms(f: Figures, gpu: GPU) -> float:
    """T_pass in milliseconds: the largest of the limits."""
    return 1e3 * max(times(f, gpu).values())


def bound(f: Figures, gpu: GPU) -> str:
    """Which limit sets a pass's time ("alu", "l1", "dram" or "raster")."""
    t = times(f, gpu)
    return max(t, key=t.get)


__all__ = ["MODEL_VERSION", "GPU", "GPUS", "BY_KEY", "match", "INSTRUCTIONS", "TEST", "SHADE", "GGX",
           "instructions", "times", "pass_ms", "bound"]
