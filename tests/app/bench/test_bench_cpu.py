"""`bench cpu`: the CPU stage alone, as one JSON line, without importing OpenGL; its errors
in one line; and the light cutoff rule."""
import json
import math
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from app import bench
from app.bench.cutoff import cutoff_lights, light_intensity
from app.results import CPU_STAGES
from app.techniques import REGISTRY
from tests.helpers import random_lights, takes

ROOT = Path(__file__).resolve().parents[3]


def test_cutoff_rule():
    lights = random_lights(np.random.default_rng(1), 200, (0, 0, 0), (1, 1, 1))
    lights["intensity"] = np.linspace(0.1, 10.0, 200)
    lights["color"] = 1.0
    a = cutoff_lights(lights, 1 / 256)
    b = cutoff_lights(lights, 1 / 1024)
    assert 0 < len(a) <= len(b) <= len(lights)
    i = light_intensity(a)
    assert np.allclose(a["radius"], np.sqrt(i / (10.0 / 256) - 1), rtol=1e-5)
    assert np.all(np.diff(a["radius"]) > 0)        # brighter -> larger: the law is kept
    assert a["radius"].max() == pytest.approx(math.sqrt(255), rel=1e-5)


def test_bench_cpu_json_without_gl():
    code = ("import sys; from app import bench; bench.main(sys.argv[1:]); "
            "assert 'moderngl' not in sys.modules, 'bench cpu imported moderngl'")
    name = next(t for t in REGISTRY if takes(t, "tile", "slices"))
    argv = ["cpu", "--scene", "arena", "--technique", name, "--lights", "512",
            "--size", "320x180", "--tile", "48", "--slices", "16", "--repeat", "2", "--json"]
    p = subprocess.run([sys.executable, "-c", code, *argv], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    lines = [l for l in p.stdout.splitlines() if l.strip()]
    assert len(lines) == 1
    d = json.loads(lines[0])
    for k in ("median_ms", "min_ms", "max_ms"):
        assert set(d[k]) == set(CPU_STAGES) | {"total"}
    assert d["lights"] == 512 and 0 < d["visible"] <= 512
    assert d["median_ms"]["total"] > 0
    assert d["options"]["tile"] == 48 and d["options"]["slices"] == 16


@pytest.mark.parametrize("argv, word", [
    (["cpu", "--technique", "no-such-technique"], "no-such-technique"),
    (["cpu", "--technique", next(t for t in REGISTRY if not takes(t, "tile")), "--tile", "32"],
     "--tile"),
    (["cpu", "--threads", "1,2"], "--threads"),                     # a list only with --growth
    (["cpu", "--out", "x"], "--out"),
    (["cpu", "--growth", "--scene", "no-such.json"], "--scene"),
])
def test_bench_errors_are_one_line(capsys, argv, word):
    from app.cli import run_main
    with pytest.raises(SystemExit) as e:
        run_main(lambda: bench.main(argv))
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0]
