"""The GPU cost model: per-wave execution figures (app.model.waves) -> milliseconds on named
GPUs.  Version MODEL_VERSION; every modelled column of results.csv carries the version that
made it.

Nothing here is fitted to any paper's results.  Three kinds of number go in:
  * the GPUs' figures, from the vendors' public specifications (sources beside GPUS below);
  * the instructions each priced step runs, counted from the lab's own shaders' SPIR-V by
    one rule (app.model.spirv, app.model.counts), per program, so per technique variant and
    option: the figures carry them (Figures.ops) and the report prints them;
  * the assumptions no specification gives, each named once in ASSUMED with its source,
    and moved by +-30% one at a time in the report's sensitivity table.

A pass of figures F on GPU g (wave width W = g.wave, U units (SMs / CUs) at f Hz):

    ALU      T_alu  = I x W / (U x lanes x f) x issue_per_op
             I = sum over loop kinds k of  issued_k x slots(ops_k)
                 + for the light loops, per shape s:  tested_s x slots(test_s)
                                                      + shaded_s x slots(shade_s)
                 + specular x slots(ggx)  +  waves x slots(wave)      (a shading pass)
             slots(alu, trans, idiv, wred) = alu + (trans + idiv) / sfu
                                             + idiv x int_division + wred x wave_reduction
             a wave issues every instruction for all W lanes, idle or not: divergence and
             idle lanes are in `issued`; transcendentals run at the GPU's sfu rate
    L1       T_l1   = sum_k max(vector_loads_k x W / addr, vector_lines_k x 64 / l1) / (U x f)
             a vector load needs its lanes' addresses (addr per clock) and its distinct
             lines (l1 bytes per clock); a wave-uniform (scalar) load costs the same on a GPU
             without a scalar unit, and nothing on the vector path where there is one (GCN's
             scalar cache; its own throughput is not modelled)
             + lds_reads x 16 / (U x lds)        (tree nodes read from shared memory)
    DRAM     T_dram = (unique bytes read + per-pixel bytes) / (bandwidth x dram_scale)
             every distinct 64-B line of the pass's buffers once (a perfect L2), plus a
             shading pass's 52 B a pixel: the G-buffer's 36 B read, the colour's 16 B written
             (the 20 B of counters and cell the lab's shaders also write for the exactness
             check are left out: a production pass writes none, and they are the same for
             every technique; a measured GPU time includes them)
    raster   T_rast = max(vertices x vertex / (U_g x lanes x f), fragments / (rops x f))
             (a raster pass: vertex work on the graphics-capable units U_g, one depth
             test per ROP and clock)

    T_pass = max(T_alu, T_l1, T_dram, T_rast)

What it ignores, and which way each part errs:
  * occupancy and latency hiding: it assumes enough waves in flight to keep every unit busy
    (optimistic for register-heavy shaders: the slides' 56 -> 32 VGPR occupancy gain is not
    in it, nor is the cost of a small frame that fills no GPU);
  * the scalar unit's own cost and GCN's SALU / VALU split: a wave-uniform instruction
    costs the same issue slot as a vector one, so the model cannot express what
    scalarization gains beyond the loads it moves to the scalar cache (see L1);
  * caches between L1 and DRAM (an L2 that misses), bank conflicts, atomic contention at one
    address (atomics count as memory instructions), barriers (counted, not timed);
  * the compiler: SPIR-V is the shader as written, unoptimised; a GPU compiler fuses,
    hoists and schedules (issue_per_op stands for that, and is moved in the sensitivity
    table); FP64 (fptl_aabb.comp's clipping) is priced at the FP32 rate, which consumer GPUs
    do not have (1/32 on the GTX 980, 1/16 on GCN): fptl's light_aabb pass errs low there;
  * the limits overlap perfectly (max, not sum): reads low where they do not.
Those read low; one part reads high: the DRAM term fetches every G-buffer byte and every
line from DRAM at full bandwidth, while a real GPU's L2 and compression (delta colour
compression on Maxwell and GCN) serve part of them (the tree paper measures EpicCitadel at
0.38 ms on a GTX 980, below its modelled 0.481 ms floor).  So the model's error has no
known sign.  Read its milliseconds as a ranking and a ratio between techniques on one GPU, with an
absolute scale to be checked against a measured GPU (scripts/gpu_check.sh), never as a
measurement.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.model import LIGHT_TYPES

from .waves import FIELDS, KINDS, LINE, Figures

# 3: instruction counts from the shaders' SPIR-V per program (app.model.counts), the
#    assumptions named in ASSUMED; evaluate_all_lights' mask loop its own kind (mask_light)
MODEL_VERSION = "3"


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

@dataclass(frozen=True)
class Assumption:
    """A number the model needs that no specification gives."""
    value: float
    what: str
    source: str


# The model's assumptions: the only numbers of it that are not a GPU's published figure or
# counted from the shaders.  The report's sensitivity table moves each by -30% and +30%.
ASSUMED = {
    "issue_per_op": Assumption(
        1.0, "issue slots a counted SPIR-V instruction takes on the GPU",
        "one each: SPIR-V is the shader unoptimised; a GPU compiler's fused multiply-adds "
        "and hoisted loads take fewer, its address and predicate arithmetic more"),
    "int_division": Assumption(
        10.0, "issue slots of a 32-bit integer division or modulo (beside its reciprocal)",
        "GPUs have no integer divider: a float reciprocal, a multiply and a correction step "
        "(the NVIDIA and AMD compilers' sequences are about 10 instructions)"),
    "wave_reduction": Assumption(
        5.0, "issue slots of a subgroup reduction or scan",
        "log2(32) shuffle-and-combine steps (a wave64 reduction on GCN takes 6 DPP steps)"),
    "l1_scale": Assumption(
        1.0, "L1 bytes a clock, times the figure given per GPU",
        "unpublished for the GTX 980 and the H200: shared memory's 128 B a clock stands in"),
    "dram_scale": Assumption(
        1.0, "effective DRAM bandwidth, times the peak",
        "the peak, every byte from DRAM: streaming kernels reach 0.7-0.9 of it, while L2 hits "
        "and framebuffer compression serve part of the traffic (more than 1)"),
}
_assumed = {k: a.value for k, a in ASSUMED.items()}


class assume:
    """`with assume(issue_per_op=1.3):` the model with an assumption moved (the report's
    sensitivity table), restored on exit."""

    def __init__(self, **values):
        unknown = set(values) - set(ASSUMED)
        if unknown:
            raise KeyError(f"no such assumption: {', '.join(sorted(unknown))}")
        self.values, self.saved = values, {}

    def __enter__(self):
        self.saved = dict(_assumed)
        _assumed.update(self.values)
        return self

    def __exit__(self, *exc):
        _assumed.clear()
        _assumed.update(self.saved)


PIXEL_BYTES = 36 + 16       # G-buffer read, colour written, per pixel (module doc)


def slots(ops, gpu: GPU) -> float:
    """Issue slots of one counted step (alu, trans, idiv, wred) on `gpu`."""
    alu, trans, idiv, wred = ops
    return (alu + (trans + idiv) / gpu.sfu + idiv * _assumed["int_division"]
            + wred * _assumed["wave_reduction"])


def _ops(f: Figures, key: str):
    """The counts of a step the pass runs: an error where its program prices none."""
    if f.ops is None:
        raise ValueError("figures without instruction counts (app.model.counts.attach)")
    if key not in f.ops:
        raise ValueError(f"the pass runs '{key}' but its program prices no such step "
                         f"(a '// priced: {key.split(':')[0]}' mark in its shaders)")
    return f.ops[key]


def instructions(f: Figures, gpu: GPU) -> float:
    """I: instructions per lane slot summed over the pass's waves (module doc)."""
    w = lambda key, n: n * slots(_ops(f, key), gpu) if n else 0.0
    issued = f.loops[:, FIELDS.index("issued")]
    total = sum(w(kind, int(issued[k])) for k, kind in enumerate(KINDS))
    for t, shape in enumerate(LIGHT_TYPES):
        total += w(f"test:{shape}", int(f.tested[t])) + w(f"shade:{shape}", int(f.shaded[t]))
    total += w("ggx", int(f.specular))
    if f.shading_pixels:                 # a shading pass: every launched wave's fixed work
        total += w("wave", int(f.waves))
    return float(total) * _assumed["issue_per_op"]


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
    l1 = gpu.l1_bytes_clk * _assumed["l1_scale"]
    l1_cycles = np.maximum(vloads * gpu.wave / gpu.addr_clk, vlines * LINE / l1).sum()
    l1_cycles += col("lds_reads").sum() * 16 / gpu.lds_bytes_clk
    graphics = f.graphics
    units = gpu.graphics_units if graphics else gpu.units
    alu = instructions(f, gpu) * gpu.wave / (units * gpu.lanes * hz)
    dram = _dram_s(sum(f.unique_bytes.values()) + f.pixels * (PIXEL_BYTES if f.shading_pixels else 0), gpu)
    rast = f.fragments / (gpu.rops * hz) if graphics else 0.0
    return {"alu": alu, "l1": float(l1_cycles) / (units * hz), "dram": dram, "raster": rast}


def _dram_s(nbytes: float, gpu: GPU) -> float:
    return nbytes / (gpu.dram_gbs * 1e9 * _assumed["dram_scale"])


def dram_floor_ms(pixels: int, gpu: GPU) -> float:
    """A shading pass's least time: every pixel's G-buffer read and colour write from DRAM."""
    return 1e3 * _dram_s(pixels * PIXEL_BYTES, gpu)


def pass_ms(f: Figures, gpu: GPU) -> float:
    """T_pass in milliseconds: the largest of the limits."""
    return 1e3 * max(times(f, gpu).values())


def bound(f: Figures, gpu: GPU) -> str:
    """Which limit sets a pass's time ("alu", "l1", "dram" or "raster")."""
    t = times(f, gpu)
    return max(t, key=t.get)


__all__ = ["MODEL_VERSION", "GPU", "GPUS", "BY_KEY", "match", "ASSUMED", "assume", "slots",
           "instructions", "times", "pass_ms", "bound"]
