"""The stereo study (app.bench.stereo) on a tiny frame: every culling technique in both
ways, exact in each eye, its file read back by the report's section; the presets carry it."""
from types import SimpleNamespace

import pytest

from app.bench import presets
from app.bench.stereo import COLUMNS, CSV, StereoConfig, stereo_series, techniques
from app.report.stereo import stereo_section
from app.results import read_csv


@pytest.fixture(scope="module")
def study(gl, tmp_path_factory):
    out = tmp_path_factory.mktemp("stereo")
    rows = stereo_series(StereoConfig(("arena",), 256, (64, 36), 0.064, repeat=2), out)
    return out, rows


def test_every_technique_in_both_ways_exact(study):
    out, rows = study
    assert (out / CSV).read_text().splitlines()[0].split(",") == COLUMNS
    got = {(r["technique"], r["way"]) for r in rows}
    assert got == {(t.name, w) for t in techniques() for w in ("per-view", "union")}
    assert all(r["mismatch_count"] == 0 and r["mismatch_hash"] == 0 for r in rows)
    assert all(r["samples"] == 2 and r["cpu_total_min_ms"] <= r["cpu_total_ms"] <= r["cpu_total_max_ms"]
               for r in rows)
    by = {(r["technique"], r["way"]): r for r in rows}
    shares = {r["technique"] for r in rows if r["share"] == "structure"}
    assert shares                     # some technique shares its structure: fewer entries
    for t in shares:
        assert by[t, "union"]["entries"] < by[t, "per-view"]["entries"]
        assert by[t, "union"]["bytes"] < by[t, "per-view"]["bytes"]


def test_the_report_section_tables_both_ways_and_their_ratio(study):
    out, rows = study
    back = read_csv(out / CSV)
    png, text, table = stereo_section(back)
    assert png is None and text and "union / per-view" in table
    for t in techniques():
        assert sum(line.startswith(f"| {t.name} |") for line in table.splitlines()) == 3
    assert "no (" not in table        # every row exact
    assert stereo_section([]) == (None, [], "")


def test_the_presets_carry_the_study_and_the_overrides_reach_it():
    quick = presets.QUICK.config("stereo")
    assert quick.scenes and quick.size[0] * quick.size[1] <= 160 * 90
    assert presets.GPU_CHECK.config("stereo").scenes == ()
    args = SimpleNamespace(full=False, size=(32, 18), scenes="city", lights="128,256", frames=None,
                           repeat=2, cpu_lights=None, cpu_size=None, threads=None)
    got = presets.preset_from_args(args).config("stereo")
    assert (got.size, got.scenes, got.lights, got.repeat) == ((32, 18), ("city",), 128, 2)


def test_views_stereo_runs_the_study_alone(gl, tmp_path, capsys):
    from app.bench import main
    main(["--views", "stereo", "--out", str(tmp_path), "--scenes", "arena", "--size", "32x18",
          "--lights", "128", "--repeat", "1", "--eye-separation", "0.5"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stereo.csv", "stereo.md"]
    rows = read_csv(tmp_path / CSV)
    assert {r["separation"] for r in rows} == {0.5} and {r["width"] for r in rows} == {32}
    md = (tmp_path / "stereo.md").read_text()
    assert md.startswith("# Two eyes") and "| clustered | structure | union |" in md
    assert "| technique |" in capsys.readouterr().out


@pytest.mark.parametrize("argv, says", [
    (["--views", "both"], "--views"),
    (["--eye-separation", "0.1"], "--eye-separation needs --views stereo"),
    (["--views", "stereo", "--eye-separation", "-1"], "--eye-separation"),
])
def test_views_bad_input_is_one_line_exit_2(tmp_path, argv, says):
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-m", "app.bench", *argv, "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and says in r.stderr, r.stderr
