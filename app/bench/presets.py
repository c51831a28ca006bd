"""The sweep's presets (--quick, --full) and the command-line overrides of them.

Option values are not part of a preset: every technique runs at its declared defaults, and
the option studies sweep each option's declared study values (app.results.option_studies).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import UserError
from .args import int_list
from .cpu import GROWTH_LIGHTS

# A preset's studies (app.bench.study), in the order they run and their rows stand in
# results.csv; each reads its config from the preset (Study.of), and one with nothing to
# measure (no counts, no frames) writes nothing.  The temporal series comes first: the
# report that reads its file is written last.
STUDY_ORDER = ("temporal", "rendered", "papers", "cpu", "growth", "gpu_build", "c_reference")


@dataclass(frozen=True)
class Preset:
    name: str
    size: tuple[int, int]
    scenes: tuple[str, ...]
    lights: tuple[int, ...]
    frames: int                   # frames sampled evenly along the camera-path loop
    repeat: int                   # timing samples of a configuration
    study_repeat: int             # ... of an option study's (its one frame is all it has:
                                  # with 3 samples, 1 in 10 comparisons of two identical
                                  # configurations passes the min-max rule, with 5 under 1%)
    heavy_repeat: int             # samples of one evaluating > heavy_eval_pp lights a pixel
    heavy_eval_pp: float
    cutoffs: tuple[int, ...]      # light cutoff t = 1 / value, relative to the brightest light
    cutoff_scenes: tuple[str, ...]
    cutoff_lights: int
    study_scene: str              # scene, light count (frame 0) of the option studies
    study_lights: int
    heat_scene: str               # the frame of the heat maps and classification (figures 1, 3)
    cpu_scene: str
    cpu_size: tuple[int, int]     # the CPU series runs at the paper's resolution even in --quick
    cpu_lights: tuple[int, ...]
    cpu_repeat: int
    seed: int = 0
    cpu_threads: int = 1          # numba threads of the CPU stage (0: numba's default)
    option_studies: bool = True   # the options' declared studies (app.results.option_studies)
    also_studies: bool = True     # ... and their second scenes (OptionSpec.also_study)
    # the papers' settings, modelled only (app.bench.validation); paper_size None: none
    paper_size: tuple[int, int] | None = (1920, 1080)
    paper_lights: tuple[int, ...] = (8192, 16384, 32768, 65536)
    paper_frames: int = 16        # camera-path frames of figure 7, spread over each path
    paper_sample: int = 8         # the shading replay over every k-th 8x8 group (scaled)
    paper_path_sample: int = 0    # ... figure 7's rows (0: paper_sample)
    paper_raster: bool = True     # raster's rows of Drobot's tables (zbin table, cluster table)
    # the CPU stage's growth (app.bench.cpu.growth_series) in cpu_scene at
    # cpu_size: every technique with a CPU build, each count on each thread count in turn;
    # () none.  growth_cap_ms: a technique whose median build passes it runs no larger count
    growth_lights: tuple[int, ...] = ()
    growth_threads: tuple[int, ...] = (1, 2)
    growth_repeat: int = 1
    growth_cap_ms: float = 0.0
    # temporal stability along a moving path (app.bench.temporal): frames
    # 0..temporal_frames-1 of a temporal_loop-frame loop of temporal_scene's path with its
    # lights bouncing, every technique, cap policy and temporal_cutoffs level against the
    # unbounded reference; temporal_frames < 2: none
    temporal_frames: int = 0
    temporal_loop: int = 600
    temporal_scene: str = "arena"
    temporal_lights: int = 2048
    temporal_size: tuple[int, int] = (128, 72)
    temporal_cutoffs: tuple[int, ...] = (256, 4096, 65536)
    # the engines' light caps (app.bench.caps): every list technique at each
    # cap policy that drops lights, in caps_scenes at caps_lights (the cutoff study's count,
    # so the report's lead figure holds both); () none
    caps_scenes: tuple[str, ...] = ()
    caps_lights: int = 2048
    # the CPU and GPU builds as a ratio (app.bench.gpu_build): every
    # technique that takes --build, built both ways at each count in gpu_build_scene at the
    # rendered size, fastest of gpu_build_repeat samples; results.csv study "gpu_build";
    # () none
    gpu_build_lights: tuple[int, ...] = ()
    gpu_build_scene: str = "city"
    gpu_build_repeat: int = 3
    # the CPU stage against the plain single-threaded C reference (app.bench.c_reference):
    # hybrid and clustered in cpu_scene at cpu_size, C and numba
    # interleaved frame by frame, numba on each of c_reference_threads; results.csv study
    # "c_reference"; () none (and skipped, with a line, where cpu_scene has other lights
    # than points or no C compiler is found)
    c_reference_lights: tuple[int, ...] = ()
    c_reference_threads: tuple[int, ...] = (1, 2)
    c_reference_repeat: int = 21


QUICK = Preset(
    name="quick", size=(320, 180), scenes=("arena", "city", "hangar", "gallery", "corridor"),
    lights=(1024, 4096), frames=6, repeat=3, study_repeat=5, heavy_repeat=2, heavy_eval_pp=256.0,
    cutoffs=(256, 1024, 4096, 16384, 65536), cutoff_scenes=("arena", "city"), cutoff_lights=2048,
    study_scene="arena", study_lights=4096, heat_scene="city", cpu_scene="arena",
    cpu_size=(1920, 1080), cpu_lights=(1024, 4096, 16384, 65536), cpu_repeat=5,
    # 8,192 doubling to 1,048,576, one build after a warm-up each; ~25 s on 2 idle cores,
    # raster's numpy proxies (~0.5 s at 128k) stopped by the cap
    growth_lights=GROWTH_LIGHTS, growth_repeat=1, growth_cap_ms=500.0,
    # 6 frames x 19 configurations at 128x72: ~15 s on 2 cores (shaders warm)
    temporal_frames=6,
    # 6 list techniques x 7 policies (1,530 of 2,048 lights visible: every policy drops some)
    caps_scenes=("arena",), caps_lights=2048,
    # 2 counts x the --build techniques, both builds, at 320x180: GPU_BUILD_QUICK_S below
    gpu_build_lights=(4096, 16384),
    # 2 techniques x 2 thread counts x 21 frames each side at 65,536 lights: ~3 s
    c_reference_lights=(65536,),
    # figure 7 along 16 frames of each path at 65,536 lights only (96 rows, ~1.7 s each on
    # 2 loaded cores, ~170 s; at two counts ~330 s), every 32nd 8x8 group replayed; raster's
    # rows of Drobot's tables only in --full (the cluster rasterizer's MARK / WALK draws at
    # 1080p: ~25 s a row on llvmpipe, ~140 s the 8 rows)
    paper_lights=(65536,), paper_path_sample=32, paper_raster=False)

FULL = Preset(
    name="full", size=(1920, 1080), scenes=("arena", "city", "hangar", "gallery", "corridor"),
    lights=(8192, 16384, 32768, 65536), frames=64, repeat=5, study_repeat=7, heavy_repeat=2,
    heavy_eval_pp=4096.0, cutoffs=(256, 1024, 4096, 16384, 65536), cutoff_scenes=("arena", "city"),
    cutoff_lights=16384, study_scene="arena", study_lights=32768, heat_scene="city",
    cpu_scene="arena", cpu_size=(1920, 1080),
    cpu_lights=(1024, 2048, 4096, 8192, 16384, 32768, 65536), cpu_repeat=9,
    paper_frames=16, paper_sample=2, growth_lights=GROWTH_LIGHTS, growth_repeat=5,
    temporal_frames=16, temporal_lights=16384, temporal_size=(480, 270),
    caps_scenes=("arena",), caps_lights=16384,
    gpu_build_lights=(8192, 32768, 131072), gpu_build_repeat=5,
    c_reference_lights=(16384, 65536), c_reference_repeat=61)

# scripts/gpu_check.sh: what matters of --full on one real GPU in minutes: every technique,
# two scenes (figure 7's two kinds of level), three light counts, exactness; measured against
# the model (the report's "measured against modelled"); no option studies, cutoff or CPU
# series (the CPU is not the question there)
GPU_CHECK = replace(
    FULL, name="gpu-check", scenes=("arena", "city"), lights=(8192, 32768, 65536), frames=2,
    cutoffs=(), cutoff_scenes=(), cpu_lights=(), option_studies=False, paper_size=None,
    growth_lights=(), temporal_frames=0, caps_scenes=(), gpu_build_lights=(),
    c_reference_lights=())

PRESETS = {"quick": QUICK, "full": FULL, "gpu-check": GPU_CHECK}


def preset_from_args(args) -> Preset:
    """The --quick/--full preset with the sweep command's overrides applied."""
    preset = FULL if args.full else GPU_CHECK if getattr(args, "gpu_check", False) else QUICK
    ch = {}
    if args.size:
        ch["size"] = tuple(args.size)
    if args.scenes:
        scenes = tuple(s.strip() for s in args.scenes.split(",") if s.strip())
        if not scenes:
            raise UserError("--scenes names no scene")
        ch.update(scenes=scenes, study_scene=scenes[0], heat_scene=scenes[-1],
                  cpu_scene=scenes[0], cutoff_scenes=scenes[:1],
                  caps_scenes=scenes[:1] if preset.caps_scenes else (), paper_size=None,
                  gpu_build_scene=scenes[0],
                  also_studies=False)
    if args.lights:
        lights = int_list(args.lights, "--lights")
        ch.update(lights=lights, study_lights=max(lights), cutoff_lights=min(lights),
                  caps_lights=min(lights))
    if args.frames is not None:
        if args.frames < 1:
            raise UserError("--frames must be >= 1")
        ch["frames"] = args.frames
    if args.repeat is not None:
        if args.repeat < 1:
            raise UserError("--repeat must be >= 1")
        ch.update(repeat=args.repeat, study_repeat=args.repeat,
                  heavy_repeat=min(preset.heavy_repeat, args.repeat), gpu_build_repeat=args.repeat,
                  c_reference_repeat=args.repeat)
    if args.cpu_lights:
        ch["cpu_lights"] = int_list(args.cpu_lights, "--cpu-lights")
    if args.cpu_size:
        ch["cpu_size"] = tuple(args.cpu_size)
    if getattr(args, "growth_lights", None) is not None:      # "" or "0": no growth series
        ch["growth_lights"] = tuple(n for n in int_list(args.growth_lights or "0", "--growth-lights") if n)
    if getattr(args, "gpu_build_lights", None) is not None:   # "" or "0": none
        ch["gpu_build_lights"] = tuple(n for n in int_list(args.gpu_build_lights or "0",
                                                           "--gpu-build-lights") if n)
    if getattr(args, "c_reference_lights", None) is not None:   # "" or "0": none
        ch["c_reference_lights"] = tuple(n for n in int_list(args.c_reference_lights or "0",
                                                             "--c-reference-lights") if n)
    if getattr(args, "temporal_frames", None) is not None:
        if args.temporal_frames < 0:
            raise UserError("--temporal-frames must be >= 0")
        ch["temporal_frames"] = args.temporal_frames
    if getattr(args, "papers", None) is not None:
        ch["paper_size"] = preset.paper_size if args.papers else None
    if args.threads is not None:
        if args.threads < 0:
            raise UserError("--threads must be >= 0")
        ch["cpu_threads"] = args.threads
    return replace(preset, **ch)
