"""The sweep's presets (--quick, --full, --gpu-check) and the command-line overrides of them.

A preset is its studies (app.bench.study) in the order they run and their rows stand in
results.csv, each with its own config; the studies that render the sweep's frames share one
Shared config (size, scenes, light counts, frames, samples ...).  A study with nothing to
measure (no counts, no frames) writes nothing.  The temporal series comes first: the report
that reads its file is written last.

Option values are not part of a preset: every technique runs at its declared defaults, and
the option studies sweep each option's declared study values (app.results.option_studies).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

from ..errors import UserError
from .args import int_list
from .c_reference.compare import CReferenceConfig
from .caps import CAPS
from .cpu import GROWTH_LIGHTS, GrowthConfig
from .cpu_series import CpuConfig
from .fog import FogConfig
from .gpu_build import GpuBuildConfig
from .rendered import RenderedConfig
from .sampling import SamplingConfig
from .stereo import StereoConfig
from .study import Shared
from .temporal import TemporalConfig
from .transparent import TransparentConfig
from .validation import PapersConfig

STUDY_ORDER = ("temporal", "rendered", "sampling", "papers", "cpu", "growth", "gpu_build", "c_reference",
               "stereo", "transparent", "fog")
SCENES = ("arena", "city", "hangar", "gallery", "corridor")
SHARED = "shared"             # a change of the Shared config, in `changed`
SAMPLE_STUDY = (1, 2, 4, 8, 16, 32, 64)        # the full preset's light samples S a pixel


@dataclass(frozen=True)
class Preset:
    """A preset: its studies in order, each with its config (the study's Config); the
    configs with a `shared` field hold one and the same Shared config (`shared`)."""
    name: str
    studies: tuple[tuple[str, object], ...]    # (study name, its config), in STUDY_ORDER

    def __post_init__(self):
        assert tuple(n for n, _ in self.studies) == STUDY_ORDER, self.name
        assert len({c.shared for c in self._sharing()}) == 1, self.name

    def _sharing(self) -> list:
        return [c for _, c in self.studies if hasattr(c, SHARED)]

    @property
    def shared(self) -> Shared:
        return self._sharing()[0].shared

    def config(self, study: str):
        return dict(self.studies)[study]

    def changed(self, name: str | None = None, **changes) -> "Preset":
        """The preset with `changes` {study: {field: value}} replaced in those studies'
        configs ("shared": in the Shared config of every study that takes it)."""
        assert set(changes) <= {SHARED, *STUDY_ORDER}, sorted(changes)
        shared = replace(self.shared, **changes.pop(SHARED, {}))
        studies = tuple((n, replace(c, **changes.get(n, {}),
                                    **({SHARED: shared} if hasattr(c, SHARED) else {})))
                        for n, c in self.studies)
        return Preset(name or self.name, studies)

    def as_dict(self) -> dict:
        """run.json's config: the Shared config, then each study's own fields."""
        return {SHARED: asdict(self.shared),
                **{n: {f.name: getattr(c, f.name) for f in fields(c) if f.name != SHARED}
                   for n, c in self.studies}}


def _quick() -> Preset:
    # About 6 minutes on 2 idle cores (the run's last lines say where the time went).  3
    # frames along each path (0, 1/3 and 2/3 of the loop): at 320x180 with 3 samples the
    # other 3 of 6 frames changed no finding of the path study in one run (each scene and
    # count's fastest over the path and those within its spread, and 1,068 of 1,100 pairwise
    # verdicts, the same) for ~210 s of the run
    s = Shared(size=(320, 180), scenes=SCENES, lights=(1024, 4096), frames=3, repeat=3,
               study_scene="arena", study_lights=4096)
    return Preset("quick", (
        # 6 frames x 19 configurations at 128x72: ~3 s on 2 cores (numba's cache warm; cold,
        # its compiles add ~12 s)
        ("temporal", TemporalConfig(frames=6, seed=s.seed)),
        # caps: 6 list techniques x 7 policies (1,530 of 2,048 lights visible: every policy
        # drops some).  model_frames, unmodelled: the wave replay models the first frame of
        # each path and the option studies' rows (the path's other frames and the cutoff and
        # caps rows have blank modelled columns: no section reads them on a software
        # rasterizer; --full models every row).
        # replay_segments: a program of more segments than ~1M (sample-ris's CDF searches,
        # 6-18M at 4,096 lights) is replayed over a lattice of its 8x8 groups, scaled:
        # sample-ris's modelled lighting within 1.7% of its whole replay (hangar, gallery,
        # city at 4,096 lights)
        ("rendered", RenderedConfig(s, study_repeat=5, heavy_repeat=2, heavy_eval_pp=256.0,
                                    cutoffs=(256, 1024, 4096, 16384, 65536),
                                    cutoff_scenes=("arena", "city"), cutoff_lights=2048,
                                    heat_scene="city", caps_scenes=("arena",), caps_lights=2048,
                                    model_frames=1, unmodelled=("cutoff", CAPS),
                                    replay_segments=1_000_000)),
        # samplers against culling on one frame: 2 scenes x (16 culling configurations x 3
        # samples + S in 1, 4, 16, 64 x 4 seeds) at 160x90 and the caps' 2,048 lights:
        # ~11 s on 2 idle cores, most of it brute's and tiled's 300-1,900 lights a pixel;
        # replay_segments as the rendered study's
        ("sampling", SamplingConfig(("arena", "city"), 2048, (160, 90), (1, 4, 16, 64), seeds=4,
                                    repeat=3, seed=s.seed, replay_segments=1_000_000)),
        # figure 7 along 8 frames of each path at 65,536 lights only (48 rows, ~16 s; every
        # verdict of its claims the same as along 16 frames, or 4, in one run), replayed over
        # every 32nd 8x8 group of a lattice (within 5% of every 8th group's; every 64th: 23%
        # on city's sparse frames); the other rows every 64th (within 2.1% of every 8th
        # group's, every scene and technique but the floor); raster's rows of Drobot's tables
        # only in --full (the cluster rasterizer's MARK / WALK draws at 1080p: ~25 s a row on
        # llvmpipe, ~140 s the 8 rows); replay_segments ~4M (sample-ris 28-80M at 1080p
        # before the sample)
        ("papers", PapersConfig(s, lights=(65536,), frames=8, sample=64, path_sample=32,
                                raster=False, replay_segments=4_000_000)),
        # the CPU series runs at the paper's resolution even in --quick
        ("cpu", CpuConfig(s, scene="arena", lights=(1024, 4096, 16384, 65536),
                          size=(1920, 1080), repeat=5)),
        # 8,192 doubling to 1,048,576, one build after a warm-up each; ~18 s on 2 idle
        # cores, a technique whose build passes 500 ms stopped there
        ("growth", GrowthConfig("arena", GROWTH_LIGHTS, (1920, 1080), 1, threads=(1, 2),
                                cap_ms=500.0, seed=s.seed, frames=s.frames)),
        # 2 counts x the --build techniques, both builds, at the rendered size
        ("gpu_build", GpuBuildConfig("city", (4096, 16384), s.size, 3)),
        # 2 techniques x 2 thread counts x 21 frames each side at 65,536 lights: ~3 s
        ("c_reference", CReferenceConfig("arena", (65536,), (1920, 1080), 21, threads=(1, 2))),
        # both eyes, both ways, every culling technique on one frame at 160x90 an eye and
        # 2,048 lights: ~4 s on 2 cores
        ("stereo", StereoConfig(("arena",), 2048, (160, 90), 0.064, repeat=3, seed=s.seed)),
        # the frame with its transparent layers against the opaque-only frame, every
        # technique, frame 0 of city-glass at 4,096 lights (the fewest at which most pixels
        # and fragments meet a light: 0.47 exact lights a pixel, 0.68 a fragment; 2,048 give
        # 0.07) and 128x72, 3 samples: 12-24 s on 2 shared cores, most of it brute's, raster's
        # and perfect's frames
        ("transparent", TransparentConfig(("city-glass",), 4096, (128, 72), repeat=3, seed=s.seed)),
        # froxel sets of the serving techniques on frame 0 of hangar-fog at 1,024 lights and
        # 160x90 on a 40x23x16 grid (the default 160x90x64 grid's sets take seconds on the
        # CPU), 3 samples, and the banding case on that grid: 3-7 s on 2 shared cores
        ("fog", FogConfig(("hangar-fog",), 1024, (160, 90), (40, 23, 16), repeat=3, seed=s.seed))))


def _full() -> Preset:
    s = Shared(size=(1920, 1080), scenes=SCENES, lights=(8192, 16384, 32768, 65536), frames=64,
               repeat=5, study_scene="arena", study_lights=32768)
    return Preset("full", (
        ("temporal", TemporalConfig(frames=16, lights=16384, size=(480, 270), seed=s.seed)),
        ("rendered", RenderedConfig(s, study_repeat=7, heavy_repeat=2, heavy_eval_pp=4096.0,
                                    cutoffs=(256, 1024, 4096, 16384, 65536),
                                    cutoff_scenes=("arena", "city"), cutoff_lights=16384,
                                    heat_scene="city", caps_scenes=("arena",),
                                    caps_lights=16384)),
        # every builtin scene and the stress scene (its own 100,000 lights), every declared S
        ("sampling", SamplingConfig(SCENES + ("stress",), 16384, (480, 270), SAMPLE_STUDY, seeds=8,
                                    repeat=5, seed=s.seed)),
        ("papers", PapersConfig(s, frames=16, sample=2)),
        ("cpu", CpuConfig(s, scene="arena", lights=(1024, 2048, 4096, 8192, 16384, 32768, 65536),
                          size=(1920, 1080), repeat=9)),
        ("growth", GrowthConfig("arena", GROWTH_LIGHTS, (1920, 1080), 5, threads=(1, 2),
                                cap_ms=0.0, seed=s.seed, frames=s.frames)),
        ("gpu_build", GpuBuildConfig("city", (8192, 32768, 131072), s.size, 5)),
        ("c_reference", CReferenceConfig("arena", (16384, 65536), (1920, 1080), 61,
                                         threads=(1, 2))),
        ("stereo", StereoConfig(("arena", "city"), 16384, (960, 540), 0.064, repeat=5,
                                seed=s.seed)),
        # brute's frame with its layers at 8,192 lights: ~20 s a sample on 2 llvmpipe cores
        ("transparent", TransparentConfig(("city-glass",), 8192, (960, 540), repeat=5, seed=s.seed)),
        # the default grid (160x90x64): brute's sets test every visible light at each froxel
        ("fog", FogConfig(("hangar-fog",), 4096, (960, 540), (160, 90, 64), repeat=3, seed=s.seed))))


QUICK = _quick()
FULL = _full()

# scripts/gpu_check.sh: what matters of --full on one real GPU in minutes: every technique,
# two scenes (figure 7's two kinds of level), the two ends of the light counts, one path
# frame, exactness; measured against the model (the report's "measured against modelled");
# no option studies, cutoff or CPU series (the CPU is not the question there).  On an H200
# machine (16 cores) a 1080p group of the 12 techniques took 55-115 s, most of it the CPU's
# replays and checks: three counts x two frames (12 groups) ran past 10 minutes, these 4
# groups take about 6
GPU_CHECK = FULL.changed(
    "gpu-check", shared=dict(scenes=("arena", "city"), lights=(8192, 65536), frames=1,
                             option_studies=False),
    temporal=dict(frames=0), rendered=dict(cutoffs=(), cutoff_scenes=(), caps_scenes=()),
    sampling=dict(scenes=()),
    papers=dict(size=None), cpu=dict(lights=()), growth=dict(lights=(), frames=2),
    gpu_build=dict(lights=()), c_reference=dict(lights=()), stereo=dict(scenes=()),
    transparent=dict(scenes=()), fog=dict(scenes=()))

PRESETS = {"quick": QUICK, "full": FULL, "gpu-check": GPU_CHECK}


def _counts(args, flag: str) -> tuple[int, ...] | None:
    """An optional count list flag's counts ("" or "0": none), None where it is not given."""
    text = getattr(args, flag.replace("-", "_"), None)
    if text is None:
        return None
    return tuple(n for n in int_list(text or "0", "--" + flag) if n)


def preset_from_args(args) -> Preset:
    """The --quick/--full preset with the sweep command's overrides applied, each to the
    configs of the studies it is about."""
    preset = FULL if args.full else GPU_CHECK if getattr(args, "gpu_check", False) else QUICK
    ch: dict[str, dict] = {k: {} for k in (SHARED, *STUDY_ORDER)}
    rendered = preset.config("rendered")
    if args.size:
        ch[SHARED]["size"] = ch["gpu_build"]["size"] = ch["sampling"]["size"] = tuple(args.size)
    if args.scenes:
        scenes = tuple(s.strip() for s in args.scenes.split(",") if s.strip())
        if not scenes:
            raise UserError("--scenes names no scene")
        ch[SHARED].update(scenes=scenes, study_scene=scenes[0])
        ch["rendered"].update(heat_scene=scenes[-1], cutoff_scenes=scenes[:1],
                              caps_scenes=scenes[:1] if rendered.caps_scenes else (),
                              also_studies=False)
        ch["papers"]["size"] = None
        ch["sampling"]["scenes"] = scenes[:len(preset.config("sampling").scenes)]
        for study in ("cpu", "growth", "gpu_build", "c_reference"):
            ch[study]["scene"] = scenes[0]
        ch["stereo"]["scenes"] = scenes[:len(preset.config("stereo").scenes)]
    if args.lights:
        lights = int_list(args.lights, "--lights")
        ch[SHARED].update(lights=lights, study_lights=max(lights))
        ch["rendered"].update(cutoff_lights=min(lights), caps_lights=min(lights))
        ch["sampling"]["lights"] = min(lights)
    if args.frames is not None:
        if args.frames < 1:
            raise UserError("--frames must be >= 1")
        ch[SHARED]["frames"] = ch["growth"]["frames"] = args.frames
    if args.repeat is not None:
        if args.repeat < 1:
            raise UserError("--repeat must be >= 1")
        ch[SHARED]["repeat"] = args.repeat
        ch["rendered"].update(study_repeat=args.repeat,
                              heavy_repeat=min(rendered.heavy_repeat, args.repeat))
        ch["gpu_build"]["repeat"] = ch["c_reference"]["repeat"] = args.repeat
        ch["sampling"]["repeat"] = args.repeat
    if args.cpu_lights:
        ch["cpu"]["lights"] = int_list(args.cpu_lights, "--cpu-lights")
    if args.cpu_size:
        for study in ("cpu", "growth", "c_reference"):
            ch[study]["size"] = tuple(args.cpu_size)
    for study, flag in (("growth", "growth-lights"), ("gpu_build", "gpu-build-lights"),
                        ("c_reference", "c-reference-lights")):
        if (counts := _counts(args, flag)) is not None:
            ch[study]["lights"] = counts
    if getattr(args, "temporal_frames", None) is not None:
        if args.temporal_frames < 0:
            raise UserError("--temporal-frames must be >= 0")
        ch["temporal"]["frames"] = args.temporal_frames
    if getattr(args, "papers", None) is not None:
        ch["papers"]["size"] = preset.config("papers").size if args.papers else None
    if args.threads is not None:
        if args.threads < 0:
            raise UserError("--threads must be >= 0")
        ch[SHARED]["threads"] = args.threads
    if args.size:                        # the stereo study follows the frame overrides too
        ch["stereo"]["size"] = tuple(args.size)
    if args.lights:
        ch["stereo"]["lights"] = min(int_list(args.lights, "--lights"))
    if args.repeat is not None:
        ch["stereo"]["repeat"] = args.repeat
    for study in ("transparent", "fog"):   # their own scenes; the frame overrides reach them
        if args.size:
            ch[study]["size"] = tuple(args.size)
        if args.lights:
            ch[study]["lights"] = min(int_list(args.lights, "--lights"))
        if args.repeat is not None:
            ch[study]["repeat"] = args.repeat
    return preset.changed(**ch)


__all__ = ["Preset", "PRESETS", "QUICK", "FULL", "GPU_CHECK", "STUDY_ORDER", "GROWTH_LIGHTS",
           "preset_from_args"]
