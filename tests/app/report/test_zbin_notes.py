"""zbin's report section (app/report/notes.py hands it every technique's zbin_variant rows):
the slides' optimization table beside both pipelines, raster's rasterized tiles and zbin's
CPU tiles."""
from app.report.notes import technique_notes


def row(technique: str, variant: int, ms: float) -> dict:
    return {"study": "zbin_variant", "technique": technique, "scene": "arena", "lights": 256,
            "zbin_variant": variant, "tile_depth": 1 if technique == "zbin" else "",
            "gpu_shade_ms": ms, "gpu_shade_min_ms": 0.9 * ms, "gpu_shade_max_ms": 1.1 * ms,
            "evaluated_pp": 4.0 - variant % 2, "stats": "{}"}


def test_the_zbin_section_has_raster_and_zbin_columns():
    rows = [row(t, v, ms * (1 - 0.1 * v)) for t, ms in (("raster", 3.0), ("zbin", 2.0))
            for v in range(4)]
    text = dict(technique_notes(rows))["zbin: what the slides measure"]
    head = next(line for line in text.splitlines() if line.startswith("| variant | slides |"))
    assert "raster: ms (min-max), of its base, evaluated/px" in head
    assert "zbin: ms (min-max), of its base, evaluated/px" in head
    assert head.index("raster:") < head.index("zbin:")          # the slides' own pipeline first
    base = next(line for line in text.splitlines() if line.startswith("| base tile |"))
    assert "3 (2.7-3.3), 100%" in base and "2 (1.8-2.2), 100%" in base
    assert "raster: z-binning saves 10%" in text and "zbin: z-binning saves 10%" in text
