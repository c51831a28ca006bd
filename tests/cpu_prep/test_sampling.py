"""The sampling CDF of the cluster lists (cpu_prep.sampling): every cell's masses sum to
2^31 exactly, none is 0, they follow the defensive mixture of the bounds, the bounds hold
over the cell's box, and the box holds every view-space point of the cell."""
import numpy as np
import pytest

from cpu_prep import sampling
from cpu_prep.camera import frame_camera
from cpu_prep.grid import make_grid
from scenes.model import Camera


def _csr(counts):
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)


def test_every_cell_sums_to_the_total_and_no_mass_is_zero(rng):
    counts = rng.integers(0, 40, 300)
    counts[::7] = 0
    offsets = _csr(counts)
    weights = rng.lognormal(0.0, 6.0, offsets[-1])        # bounds over 10+ decades
    weights[::13] = 0.0
    cdf = sampling.cell_cdf(offsets, weights)
    m = sampling.masses(cdf, offsets)
    assert (m >= 1).all()
    sums = np.add.reduceat(m, offsets[:-1][counts > 0])
    assert (sums == sampling.MASS_TOTAL).all()
    assert (cdf[offsets[1:][counts > 0] - 1] == sampling.MASS_TOTAL).all()


def test_masses_follow_the_defensive_mixture(rng):
    counts = np.array([1, 5, 64])
    offsets = _csr(counts)
    weights = rng.uniform(0.0, 10.0, offsets[-1])
    m = sampling.masses(sampling.cell_cdf(offsets, weights), offsets) / sampling.MASS_TOTAL
    for c in range(3):
        w = weights[offsets[c]:offsets[c + 1]]
        want = (1 - sampling.DEFENSIVE) * w / w.sum() + sampling.DEFENSIVE / len(w)
        got = m[offsets[c]:offsets[c + 1]]
        # quantised to 2^-31 with the cell's remainder (< n units) on its last entry
        assert np.allclose(got, want, rtol=0, atol=(counts[c] + 1) / sampling.MASS_TOTAL)
    assert m[0] == 1.0                                     # a one-light cell: p = 1


def test_a_list_longer_than_the_resolution_is_refused():
    offsets = np.array([0, sampling.MASS_TOTAL], np.int64)
    with pytest.raises(ValueError, match="resolution"):
        sampling.cell_cdf(offsets, np.zeros(0))


def _grid_and_camera(w=160, h=90, tile=16, slices=8):
    cam = frame_camera(Camera((0, 2, 8), (0, 1, -20), fov_y_deg=70, near=0.1, far=200.0), w, h)
    return make_grid(cam, tile, slices, 150.0, 5.0), cam


def test_cell_boxes_hold_every_view_point_of_their_cell(rng):
    grid, cam = _grid_and_camera()
    lo, hi = sampling.cell_view_boxes(grid, cam)
    px, py = rng.uniform(0, grid.width, 4000), rng.uniform(0, grid.height, 4000)
    depth = np.exp(rng.uniform(np.log(0.1), np.log(cam.far), 4000))
    x = (2 * px / grid.width - 1) * cam.tan_half_x * depth
    y = (2 * py / grid.height - 1) * cam.tan_half_y * depth
    p = np.stack([x, y, -depth], 1)
    cell = ((py // grid.tile).astype(int) * grid.tiles_x + (px // grid.tile).astype(int)) * grid.slices \
        + grid.slice_of(depth)
    eps = 1e-9 * (1 + np.abs(p))
    assert (p >= lo[cell] - eps).all() and (p <= hi[cell] + eps).all()


def test_bounds_are_at_least_the_falloff_anywhere_in_the_cell(rng):
    grid, cam = _grid_and_camera(64, 48, 16, 4)
    lo, hi = sampling.cell_view_boxes(grid, cam)
    cells = np.arange(grid.cells)
    offsets = np.arange(grid.cells + 1, dtype=np.int64)      # one light a cell
    lights = np.zeros(grid.cells, [("pos_radius", np.float32, 4), ("color_cos_inner", np.float32, 4)])
    centre = (lo + hi) / 2 + rng.normal(0, 5, (grid.cells, 3))
    lights["pos_radius"][:, :3] = centre
    lights["color_cos_inner"][:, :3] = rng.uniform(0.1, 30, (grid.cells, 3))
    bound = sampling.entry_bounds(offsets, cells, lights, lo, hi)
    for _ in range(50):
        q = lo + rng.uniform(0, 1, lo.shape) * np.minimum(hi - lo, 1e4)
        d2 = ((q - lights["pos_radius"][:, :3]) ** 2).sum(1)
        peak = lights["color_cos_inner"][:, :3].max(1)
        assert (peak / (d2 + 1) <= bound * (1 + 1e-9)).all()
