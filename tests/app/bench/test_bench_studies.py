"""The option studies come from the options' declarations alone: one study per option with
study values, over exactly the techniques that declare it (no hand-kept list)."""
from app.bench.plan import plan, technique_order
from app.bench.presets import QUICK
from app.results import option_studies
from app.techniques import REGISTRY, with_role

RENDERED = QUICK.config("rendered")


def test_studies_are_the_options_with_study_values():
    want = {}
    for t in REGISTRY.values():
        for spec in t.Options.specs():
            if spec.study:
                want.setdefault(spec.name, set()).add(t.name)
    got = option_studies()
    assert set(got) == set(want)
    for name, (spec, techs) in got.items():
        assert set(techs) == want[name], name
        assert spec.study, name
        # registry order, each technique once
        assert list(techs) == [t for t in REGISTRY if t in want[name]]


def test_plan_covers_each_study_value_and_technique():
    jobs = plan(RENDERED, lambda scene, counts: tuple(counts))
    assert technique_order()[0] == with_role("reference").name
    for name, (spec, techs) in option_studies().items():
        sub = [j for j in jobs if j.study == name]
        assert sorted((j.technique, getattr(j.opts, name)) for j in sub) == \
            sorted((t, v) for t in techs for v in spec.study), name
        for j in sub:     # every other option at the technique's default
            default = REGISTRY[j.technique].Options().as_dict()
            assert {k: v for k, v in j.opts.as_dict().items() if k != name} == \
                {k: v for k, v in default.items() if k != name}
    path = [j for j in jobs if j.study == "path"]
    s = QUICK.shared
    assert len(path) == len(s.scenes) * len(s.lights) * s.frames * len(REGISTRY)


def test_a_study_runs_in_its_own_scene_when_the_run_has_it():
    """fptl's type_loops is about mixed light shapes: its study runs in the corridor; a run
    without the corridor studies it in the preset's study scene like every other option."""
    counts = lambda scene, c: tuple(c)
    spec = option_studies()["type_loops"][0]
    assert spec.study_scene == "corridor" and "corridor" in QUICK.shared.scenes
    scenes = {j.scene for j in plan(RENDERED, counts) if j.study == "type_loops"}
    assert scenes == {"corridor"}
    others = {j.scene for j in plan(RENDERED, counts)
              if j.study not in ("path", "cutoff", "type_loops") and "@" not in j.study}
    assert others == {QUICK.shared.study_scene}
    no_corridor = QUICK.changed(shared=dict(scenes=("arena", "city"))).config("rendered")
    assert {j.scene for j in plan(no_corridor, counts) if j.study == "type_loops"} == {"arena"}


def test_a_study_also_runs_in_a_second_scene():
    """raster_variant runs in the study scene and again in the contention scene (the slides'
    case), as study raster_variant@contention; a run narrowed with --scenes skips it."""
    from dataclasses import replace
    counts = lambda scene, c: tuple(c)
    spec = option_studies()["raster_variant"][0]
    assert spec.also_study == ("contention",)
    jobs = [j for j in plan(RENDERED, counts) if j.study == "raster_variant@contention"]
    assert {j.scene for j in jobs} == {"contention"} and {j.technique for j in jobs} == {"raster"}
    assert sorted(j.opts.raster_variant for j in jobs) == list(spec.study)
    assert not [j for j in plan(replace(RENDERED, also_studies=False), counts) if "@" in j.study]
