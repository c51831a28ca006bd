"""`python -m app.bench`'s subcommands: one parser, and each runs its own study alone, so it
writes its own files and no other (the sweep's temporal series ran before any command that
was not `cpu`, `--path` or `--help`, and `gpu-build --out DIR` found DIR/temporal.csv); the
sweep's preset is its studies, each timed."""
import subprocess
import sys
from pathlib import Path

import pytest

from app import bench
from app.bench import presets, study
from app.bench.sweep import preset_studies
from tests.helpers import path_file

ROOT = Path(__file__).resolve().parents[3]


def _files(argv, out: Path, entry: bool) -> set[str]:
    """The files a command leaves in `out`: run as `python -m app.bench` (`entry`, the
    module's own entry point) or through app.bench.main in this process."""
    if entry:
        r = subprocess.run([sys.executable, "-m", "app.bench", *argv], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
    else:
        bench.main(argv)
    return {p.name for p in out.iterdir()}


@pytest.mark.parametrize("argv, files, entry", [
    # the command the temporal series ran before: through the module's entry point
    (["gpu-build", "--sweep", "64", "--size", "16x9", "--repeat", "1", "--technique", "clustered"],
     {"gpu_build.csv", "gpu_build.md"}, True),
    (["cpu", "--growth", "--scene", "arena", "--sweep", "64", "--threads", "1", "--repeat", "1",
      "--size", "16x9", "--technique", "clustered"], {"growth.csv", "growth.md", "cpu_growth.png"},
     False),
    (["--path", "{path}", "--size", "32x18", "--lights", "64", "--techniques", "tiled"],
     {"path.csv", "path.json", "path.png"}, False),
])
def test_each_subcommand_writes_only_its_own_files(gl, tmp_path, argv, files, entry):
    out = tmp_path / "out"
    argv = [a.replace("{path}", str(path_file(tmp_path, 1))) for a in argv] + ["--out", str(out)]
    assert _files(argv, out, entry) == files


def test_help_runs_no_study(tmp_path):
    for argv in (["--help", "--out", str(tmp_path)], ["cpu", "--help"], ["gpu-build", "--help"],
                 ["--path", "--help", "--out", str(tmp_path)]):
        r = subprocess.run([sys.executable, "-m", "app.bench", *argv], cwd=ROOT,
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0 and "usage: python -m app.bench" in r.stdout, (argv, r.stderr)
    assert not list(tmp_path.iterdir())


def test_a_preset_is_its_studies_in_order():
    for p in presets.PRESETS.values():
        got = preset_studies(p)
        assert [s.name for s in got] == list(presets.STUDY_ORDER)
        assert all(isinstance(s, study.STUDIES[s.name]) for s in got)
    temporal = preset_studies(presets.QUICK)[0].config
    assert temporal is presets.QUICK.config("temporal")
    assert all(s.config is c for s, (_, c) in zip(preset_studies(presets.QUICK),
                                                  presets.QUICK.studies))
    assert preset_studies(presets.GPU_CHECK)[0].config.frames == 0     # none: no file


def test_the_time_lines_say_where_the_time_went():
    lines = study.time_lines({"rendered": 3.0, "cpu": 1.0})
    assert len(lines) == 2 and "rendered" in lines[0] and "75.0%" in lines[0]
    assert "cpu" in lines[1] and "25.0%" in lines[1]


def test_each_study_names_the_report_modules_that_read_it():
    import importlib
    preset_studies(presets.QUICK)                           # every study module imported
    for name, cls in study.STUDIES.items():
        assert cls.sections, name
        for module in cls.sections:
            importlib.import_module(f"app.report.{module}")
