"""The froxel grid of a fog frame and each froxel's exact light set (numpy in, numpy out).

A froxel grid is W x H screen columns by D depth slices, each froxel a frustum cell of view
space: pixel columns [xs[i], xs[i+1]] x rows [ys[j], ys[j+1]] (GL order: row 0 at the bottom)
x view depths [zs[k], zs[k+1]].  The default grid splits the image evenly and its depth
exponentially from the camera's near plane to the fog's far depth,
zs[k] = near * (far / near) ** (k / D); the matched grid (matched_grid) is clustered's own
grid: its tiles (clipped to the image) and its slices (clipped to [near, fog far]), one
froxel per cell.

    froxel id = (k * H + j) * W + i          (i from the left, j from the bottom)

"Meets" (the one definition; tests/cpu_prep/test_froxels.py reproduces it in float64 with
its own code): light L meets froxel F when all three hold, in float64,

    sphere   the Euclidean distance from c to F's closed cell is below r + 1e-5 |c|
    screen   L's screen rectangle overlaps F's pixel rectangle (open intervals:
             x0 < F.x1 and F.x0 < x1, and the same in y)
    depth    L's depth range overlaps F's (dlo < F.z1 and F.z0 < dhi)

with c, r the light's culling sphere and (x0, x1, y0, y1), (dlo, dhi) its conservative screen
rectangle and depth range, all as the CPU stage made them for every technique
(cpu_prep.lights.PreparedLights: center, bound_radius, rect, depth_lo, depth_hi; per shape,
float margins included).  The cell is the convex hull of its eight corners (u tx z, v ty z, -z)
for u, v the NDC of its pixel edges (u = 2 x / width - 1), z its two depths, tx, ty the
camera's tangents.  The 1e-5 |c| covers the float32 rounding of the GPU's sample points, so
every light that affects a float32 sample point of a froxel meets it; the screen and depth
conditions make the set one that every structure binned from those bounds holds (a cell
technique's candidates are a superset of it: grid.py's tiles and slices of the same bounds).

The sphere test is the sphere against the cell's six planes (reject: outside one by the radius
or more; accept: inside all six) and, between, the exact distance to the nearest of its six
faces (each a planar convex quad: the plane's distance where the point projects inside it,
else the nearest of its edges).

Light sets come from candidates: brute's are every visible light (froxel_sets_all), a cell
technique's the union of the lists of the cells its froxel overlaps (froxel_sets_from_cells);
both keep exactly the candidates that meet the froxel, each froxel's list in light-buffer
order.  The build (_sets_run) goes a row of froxels at a time: the column, row and slice
tests are each the light's against the froxel's own column, row or slice alone, made once a
frame per light (_axis_tables); the froxels of a row that overlap the same cells share their
candidates, gathered once and passed through the row's and slice's tests once; then light by
light along the columns its column test passes, the sphere against each froxel's cell where
the light's centre is not inside it: a sphere clearly off the cell's bounding box rejects
(BOX_MARGIN), a corner within r accepts, else the faces decide; the lists are written froxel
by froxel.  Every decision is the definition's float64 expression, so the sets do not depend
on the order the build takes.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
import math

import numba
import numpy as np

from . import layouts, parallel, threads
from .grid import Grid, slice_table

# The froxel budget: a grid of more froxels is refused (its per-froxel buffers, 48 bytes a
# froxel: the range, the in-scatter, the integrated scattering and the counts, stay under
# 200 MiB, and each within the 128 MiB storage-block limit).
MAX_FROXELS = 1 << 22
MAX_FROXEL_SLICES = 1024
DEFAULT_FROXELS = (160, 90, 64)

class FroxelError(ValueError):
    """A froxel grid that cannot be made (the message is one line)."""


@dataclass(frozen=True, eq=False)
class FroxelGrid:
    xs: np.ndarray          # (W+1,) pixel edges, left to right, 0 .. width
    ys: np.ndarray          # (H+1,) pixel edges, bottom to top, 0 .. height
    zs: np.ndarray          # (D+1,) view depths, near .. far
    width: int
    height: int
    tan_x: float
    tan_y: float

    @property
    def dims(self) -> tuple[int, int, int]:
        return len(self.xs) - 1, len(self.ys) - 1, len(self.zs) - 1

    @property
    def count(self) -> int:
        w, h, d = self.dims
        return w * h * d

    def ndc(self) -> tuple[np.ndarray, np.ndarray]:
        return 2.0 * self.xs / self.width - 1.0, 2.0 * self.ys / self.height - 1.0

    def corners(self, i: int, j: int, k: int) -> np.ndarray:
        """(8, 3) float64 view-space corners of froxel (i, j, k), index bits (u, v, z)."""
        us, vs = self.ndc()
        out = np.empty((8, 3))
        for n in range(8):
            u, v, z = us[i + (n & 1)], vs[j + (n >> 1 & 1)], self.zs[k + (n >> 2 & 1)]
            out[n] = (u * self.tan_x * z, v * self.tan_y * z, -z)
        return out


def default_dims(width: int, height: int) -> tuple[int, int, int]:
    """DEFAULT_FROXELS, its columns and rows at most the image's pixels."""
    w, h, d = DEFAULT_FROXELS
    return min(w, width), min(h, height), d


def check_dims(dims, width: int, height: int) -> None:
    """The grid's limits: a froxel at least a pixel wide and high, 1..MAX_FROXEL_SLICES
    slices, at most MAX_FROXELS froxels in all (the budget)."""
    w, h, d = dims
    if not (1 <= w <= width and 1 <= h <= height):
        raise FroxelError(f"--froxels {w}x{h}x{d}: W and H must be in 1..{width} and 1..{height} "
                          f"(a froxel at least a pixel of the {width}x{height} image)")
    if not 1 <= d <= MAX_FROXEL_SLICES:
        raise FroxelError(f"--froxels {w}x{h}x{d}: D must be in 1..{MAX_FROXEL_SLICES}")
    if w * h * d > MAX_FROXELS:
        raise FroxelError(f"--froxels {w}x{h}x{d}: {w * h * d:,} froxels, over the budget of "
                          f"{MAX_FROXELS:,} froxels (48 bytes each)")


def _tangents(cam) -> tuple[float, float]:
    """tx, ty of the projection (view x / depth at NDC 1), from the matrix the G-buffer uses."""
    p = np.asarray(cam.clip_from_view, np.float64)
    return 1.0 / p[0, 0], 1.0 / p[1, 1]


DEPTHS = ("exponential", "linear")     # the slices' depth distributions (make_froxel_grid)


def make_froxel_grid(cam, dims, far: float, depth: str = "exponential") -> FroxelGrid:
    """Even columns and rows; slices from near to `far`, exponential (each slice the same
    ratio deep: froxels about as deep as they are wide, as engines lay out fog) or linear
    (the same depth each: fine far away, coarse near the eye)."""
    check_dims(dims, cam.width, cam.height)
    w, h, d = dims
    near = float(cam.near)
    if not far > near:
        raise FroxelError(f"fog.far ({far:g}) must be beyond the camera's near plane ({near:g})")
    if depth not in DEPTHS:
        raise FroxelError(f"froxel depth {depth!r}: one of {', '.join(DEPTHS)}")
    t = np.arange(d + 1) / d
    zs = near * (far / near) ** t if depth == "exponential" else near + (far - near) * t
    zs[0], zs[-1] = near, far
    tx, ty = _tangents(cam)
    return FroxelGrid(np.linspace(0.0, cam.width, w + 1), np.linspace(0.0, cam.height, h + 1),
                      zs, int(cam.width), int(cam.height), tx, ty)


def slice_edges(grid: Grid) -> np.ndarray:
    """The depths where the grid's slices begin (slice k >= 1 at edges[k - 1]): the steps of
    its slice_index(), cpu_prep.grid.slice_table."""
    t = slice_table(grid)
    return np.asarray(t[:grid.slices - 1], np.float64)


def matched_grid(cam, grid: Grid, far: float) -> FroxelGrid:
    """A froxel per cell of `grid` within [near, far]: its tiles clipped to the image, its
    slices clipped to the depth range (the slices past `far` left out)."""
    near = float(cam.near)
    edges = slice_edges(grid)
    inner = edges[(edges > near) & (edges < far)]
    zs = np.concatenate([[near], inner, [far]])
    xs = np.minimum(np.arange(grid.tiles_x + 1) * float(grid.tile), cam.width).astype(np.float64)
    ys = np.minimum(np.arange(grid.tiles_y + 1) * float(grid.tile), cam.height).astype(np.float64)
    tx, ty = _tangents(cam)
    out = FroxelGrid(xs, ys, zs, int(cam.width), int(cam.height), tx, ty)
    check_dims(out.dims, max(cam.width, out.dims[0]), max(cam.height, out.dims[1]))
    return out


@dataclass
class LightBounds:
    """What "meets" reads of each visible light (light-buffer order), float64."""
    centre: np.ndarray      # (N, 3) view space
    radius: np.ndarray      # (N,) the culling radius grown by SAMPLE_REL_MARGIN |centre|
    rect: np.ndarray        # (N, 4) x0, x1, y0, y1 pixels (GL)
    depth: np.ndarray       # (N, 2) dlo, dhi

    def __len__(self):
        return len(self.radius)


# the GPU's sample points are float32 view-space positions: within ~1e-6 |P| of the exact
# point (a few roundings of u tx z), far inside this
SAMPLE_REL_MARGIN = 1e-5


def light_bounds(pl) -> LightBounds:
    """The module's bounds of prepared lights (cpu_prep.lights.PreparedLights)."""
    c = np.ascontiguousarray(pl.center, np.float64)
    r = np.asarray(pl.bound_radius, np.float64) + SAMPLE_REL_MARGIN * np.sqrt((c ** 2).sum(1))
    depth = np.stack([np.asarray(pl.depth_lo, np.float64), np.asarray(pl.depth_hi, np.float64)], 1)
    return LightBounds(c, np.ascontiguousarray(r), np.ascontiguousarray(pl.rect, np.float64),
                       np.ascontiguousarray(depth))




# ---- the exact test ------------------------------------------------------------------------

# a sphere whose squared distance to a froxel's bounding box passes r^2 by this share of the
# squared scale of the coordinates (|c|_1 + r + the froxel's far depth) misses the froxel,
# decided without the faces: float64's rounding of those distances is some 1e-15 of it
BOX_MARGIN = 1e-9

@numba.njit(inline="always")
def _seg_d2(px, py, pz, ax, ay, az, bx, by, bz):
    ex, ey, ez = bx - ax, by - ay, bz - az
    wx, wy, wz = px - ax, py - ay, pz - az
    ee = ex * ex + ey * ey + ez * ez
    t = 0.0
    if ee > 0.0:
        t = min(max((wx * ex + wy * ey + wz * ez) / ee, 0.0), 1.0)
    dx, dy, dz = wx - t * ex, wy - t * ey, wz - t * ez
    return dx * dx + dy * dy + dz * dz


@numba.njit(inline="always")
def _face_planes(q, faces, fp):
    """fp[f] = the outward unit normal of face f and its offset (n . x = offset on it): the
    normal from the quad's diagonals (robust for a thin quad), turned away from the cell's
    centroid.  A degenerate face (no area) gets a zero normal."""
    gx = (q[0, 0] + q[1, 0] + q[2, 0] + q[3, 0] + q[4, 0] + q[5, 0] + q[6, 0] + q[7, 0]) / 8.0
    gy = (q[0, 1] + q[1, 1] + q[2, 1] + q[3, 1] + q[4, 1] + q[5, 1] + q[6, 1] + q[7, 1]) / 8.0
    gz = (q[0, 2] + q[1, 2] + q[2, 2] + q[3, 2] + q[4, 2] + q[5, 2] + q[6, 2] + q[7, 2]) / 8.0
    for f in range(6):
        a, b, c, d = faces[f, 0], faces[f, 1], faces[f, 2], faces[f, 3]
        e1x, e1y, e1z = q[c, 0] - q[a, 0], q[c, 1] - q[a, 1], q[c, 2] - q[a, 2]
        e2x, e2y, e2z = q[d, 0] - q[b, 0], q[d, 1] - q[b, 1], q[d, 2] - q[b, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        nn = math.sqrt(nx * nx + ny * ny + nz * nz)
        if nn > 0.0:
            nx, ny, nz = nx / nn, ny / nn, nz / nn
            if (gx - q[a, 0]) * nx + (gy - q[a, 1]) * ny + (gz - q[a, 2]) * nz > 0.0:
                nx, ny, nz = -nx, -ny, -nz
        fp[f, 0], fp[f, 1], fp[f, 2] = nx, ny, nz
        fp[f, 3] = nx * q[a, 0] + ny * q[a, 1] + nz * q[a, 2]


@numba.njit(inline="always")
def _quad_d2(p, q, a, b, c, d, nx, ny, nz, h):
    """Squared distance from p to the planar convex quad q[a], q[b], q[c], q[d] (in order
    around it; unit normal n, p at height h above its plane): the plane's where p projects
    inside the quad, else the nearest edge's."""
    if nx != 0.0 or ny != 0.0 or nz != 0.0:
        sx, sy, sz = p[0] - h * nx, p[1] - h * ny, p[2] - h * nz
        pos, neg = 0, 0
        for m in range(4):
            u = a if m == 0 else (b if m == 1 else (c if m == 2 else d))
            w = b if m == 0 else (c if m == 1 else (d if m == 2 else a))
            ex, ey, ez = q[w, 0] - q[u, 0], q[w, 1] - q[u, 1], q[w, 2] - q[u, 2]
            rx, ry, rz = sx - q[u, 0], sy - q[u, 1], sz - q[u, 2]
            side = (ey * rz - ez * ry) * nx + (ez * rx - ex * rz) * ny + (ex * ry - ey * rx) * nz
            if side > 0.0:
                pos += 1
            elif side < 0.0:
                neg += 1
        if pos == 0 or neg == 0:
            return h * h
    best = np.inf
    for m in range(4):
        u = a if m == 0 else (b if m == 1 else (c if m == 2 else d))
        w = b if m == 0 else (c if m == 1 else (d if m == 2 else a))
        best = min(best, _seg_d2(p[0], p[1], p[2], q[u, 0], q[u, 1], q[u, 2],
                                 q[w, 0], q[w, 1], q[w, 2]))
    return best


# faces of a froxel by its corner index bits (u, v, z), each quad in order around it
FACES = np.array([[0, 1, 3, 2], [4, 5, 7, 6],       # near, far
                  [0, 2, 6, 4], [1, 3, 7, 5],       # left, right
                  [0, 1, 5, 4], [2, 3, 7, 6]],      # bottom, top
                 np.int64)


@numba.njit(inline="always")
def _sphere_faces(c, r, q, faces, fp):
    """_sphere_meets_cell past its corners: the faces that c lies above by less than r
    measured; c above none lies inside the cell."""
    r2 = r * r
    above = False
    for f in range(6):
        h = fp[f, 0] * c[0] + fp[f, 1] * c[1] + fp[f, 2] * c[2] - fp[f, 3]
        if h <= 0.0:
            continue
        above = True
        if h >= r:
            continue
        if _quad_d2(c, q, faces[f, 0], faces[f, 1], faces[f, 2], faces[f, 3],
                    fp[f, 0], fp[f, 1], fp[f, 2], h) < r2:
            return True
    return not above


@numba.njit(inline="always")
def _sphere_meets_cell(c, r, q, faces, fp):
    """Past the plane tests and not inside all six planes: the distance from c to the cell
    (corners q, face planes fp: _face_planes) below r.  A corner within r answers at once;
    else the nearest point of a convex cell to a point outside it lies on a face whose
    outer side holds the point, so only the faces that c lies above by less than r are
    measured (_sphere_faces); c above none lies inside the cell."""
    r2 = r * r
    for n in range(8):
        dx, dy, dz = q[n, 0] - c[0], q[n, 1] - c[1], q[n, 2] - c[2]
        if dx * dx + dy * dy + dz * dz < r2:
            return True
    return _sphere_faces(c, r, q, faces, fp)


@numba.njit(inline="always")
def _plane_sd(c, u, t, axis):
    """Signed distance of c from the side plane through the eye at NDC u (axis 0: the plane
    x = u t depth, 1: y = u t depth), positive towards larger x (y)."""
    v = c[0] if axis == 0 else c[1]
    return (v + u * t * c[2]) / math.sqrt(1.0 + (u * t) * (u * t))


@numba.njit(inline="always")
def _corners(us, vs, zs, tx, ty, i, j, k, q):
    for n in range(8):
        u, v, z = us[i + (n & 1)], vs[j + (n >> 1 & 1)], zs[k + (n >> 2 & 1)]
        q[n, 0], q[n, 1], q[n, 2] = u * tx * z, v * ty * z, -z


@numba.njit(inline="always")
def _axis_test(c, r, lo_edge, hi_edge, u0, u1, t, axis, r0, r1):
    """One column (axis 0) or row (1): bit 1 the sphere is not outside its two planes by r
    or more and the light's rectangle [r0, r1] overlaps the pixels [lo_edge, hi_edge] (open);
    bit 2 the centre is inside both planes."""
    lo = _plane_sd(c, u0, t, axis)
    hi = _plane_sd(c, u1, t, axis)
    ok = lo > -r and hi < r and lo_edge < r1 and r0 < hi_edge
    return (1 if ok else 0) | (2 if (lo >= 0.0 and hi <= 0.0) else 0)


@numba.njit(inline="always")
def _depth_test(c, r, z0, z1, d0, d1):
    """One slice: bit 1 the sphere is not outside its two depth planes by r or more and the
    light's depth range [d0, d1] overlaps (z0, z1); bit 2 the centre lies between them."""
    depth = -c[2]
    lo, hi = depth - z0, z1 - depth
    ok = lo > -r and hi > -r and z0 < d1 and d0 < z1
    return (1 if ok else 0) | (2 if (lo >= 0.0 and hi >= 0.0) else 0)


@numba.njit(inline="always")
def _span(lo, hi, edges):
    """First and last t whose [edges[t], edges[t+1]) overlaps the open interval (lo, hi)."""
    n = edges.shape[0] - 1
    a = 0
    while a < n - 1 and edges[a + 1] <= lo:
        a += 1
    b = a
    while b < n - 1 and edges[b + 1] < hi:
        b += 1
    return a, b


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _spans_of(froxel_edges, cell_edges):
    """_span of each froxel interval [froxel_edges[t], froxel_edges[t+1]] among the cells'."""
    out = np.empty((froxel_edges.shape[0] - 1, 2), np.int64)
    for t in range(froxel_edges.shape[0] - 1):
        out[t, 0], out[t, 1] = _span(froxel_edges[t], froxel_edges[t + 1], cell_edges)
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _axis_tables(C, R, RECT, DEP, xs, ys, us, vs, zs, tx, ty):
    """Each light's column, row and slice tests (_axis_test, _depth_test: each separable, the
    froxel's own column, row or slice alone), once a frame: PX[i, l], PY[j, l], PZ[k, l]."""
    W, H, D = us.shape[0] - 1, vs.shape[0] - 1, zs.shape[0] - 1
    n = C.shape[0]
    PX, PY, PZ = np.empty((W, n), np.uint8), np.empty((H, n), np.uint8), np.empty((D, n), np.uint8)
    for l in range(n):
        c, r = C[l], R[l]
        for i in range(W):
            PX[i, l] = _axis_test(c, r, xs[i], xs[i + 1], us[i], us[i + 1], tx, 0, RECT[l, 0], RECT[l, 1])
        for j in range(H):
            PY[j, l] = _axis_test(c, r, ys[j], ys[j + 1], vs[j], vs[j + 1], ty, 1, RECT[l, 2], RECT[l, 3])
        for k in range(D):
            PZ[k, l] = _depth_test(c, r, zs[k], zs[k + 1], DEP[l, 0], DEP[l, 1])
    return PX, PY, PZ


@numba.njit(inline="always")
def _cell_union(c0, c1, r0, r1, s0, s1, z0, z1, tiles_x, slices, cell_spans, spans,
                cell_entries, stamp, key, out):
    """The union of the lists of cells (tiles c0..c1 x r0..r1, slices s0..s1; each cell's
    spans whose depth interval overlaps (z0, z1)), without repeats, sorted unless it is one
    span (in order already).  -> its size, in out[:size]."""
    nb = 0
    runs = 0
    for cy in range(r0, r1 + 1):
        for cx in range(c0, c1 + 1):
            for s in range(s0, s1 + 1):
                cell = (cy * tiles_x + cx) * slices + s
                for p in range(cell_spans[cell, 0], cell_spans[cell, 0] + cell_spans[cell, 1]):
                    if not (spans[p, 2] < z1 and z0 < spans[p, 3]):
                        continue
                    runs += 1
                    first, cnt = np.int64(spans[p, 0]), np.int64(spans[p, 1])
                    for e in range(first, first + cnt):
                        l = cell_entries[e]
                        if stamp[l] != key:
                            stamp[l] = key
                            out[nb] = l
                            nb += 1
    if runs > 1:
        out[:nb] = np.sort(out[:nb])
    return nb


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _sets_run(C, R, xs, ys, us, vs, zs, tx, ty, faces, PX, PY, PZ, k0, k1, from_cells,
              col_t, row_t, slice_s, cell_spans, spans, cell_entries, tiles_x, slices,
              offsets, entries, base):
    """The sets of slices k0..k1-1, froxel-major (CSR, each list in light order): per froxel
    its candidates (from_cells: the union of the cells it overlaps, col_t / row_t / slice_s
    its tiles and slices, cell_spans / spans / cell_entries the cells' lists as in
    froxel_sets_from_spans; else every light), each kept where it meets the froxel.

    A row of froxels is cut into runs that overlap the same cells (every light: one run);
    a run's candidates are gathered once and the row's and slice's tests (PY, PZ:
    _axis_tables) applied to them once.  Then light by light, along the columns its column
    test (PX) passes within the run, the meets decision of each froxel: the centre inside it
    (all three tests' bit 2) accepts; else the sphere against the cell, a sphere clearly off
    the cell's bounding box rejects (BOX_MARGIN), a corner within r accepts, the faces decide
    the rest (_sphere_faces, each froxel's face planes made once, when first needed).  Along
    a light's columns the outcome changes in few places, so its branches are predicted; the
    corners are those _corners makes, the same float64 expressions.  The run's lists are then
    written froxel by froxel, each in light order, at entries[base:], offsets[f + 1] (f the
    froxel's id) counted from base.  -> (entries written, candidates)."""
    W, H = us.shape[0] - 1, vs.shape[0] - 1
    n = C.shape[0]
    n1 = max(n, 1)
    stamp = np.full(n1, -1, np.int64)
    union = np.empty(n1, np.int64)
    row = np.empty(n1, np.int64)
    xlo, xhi = np.empty(n1, np.int64), np.empty(n1, np.int64)   # the columns PX passes
    for l in range(n):
        a = 0
        while a < W and (PX[a, l] & 1) == 0:
            a += 1
        b = W
        while b > a and (PX[b - 1, l] & 1) == 0:
            b -= 1
        xlo[l], xhi[l] = a, b
    keep = np.zeros((n1, W), np.uint8)                # a run's decisions, light x column
    xe = np.empty((W + 1, 2))                          # corner x at column edge e, near / far
    yv = np.empty((2, 2))                              # corner y at the row's edges
    q = np.empty((8, 3))
    fps = np.empty((W, 6, 4))
    have_fp = np.zeros(W, np.bool_)
    m = 0
    candidates = 0
    key = 0
    for k in range(k0, k1):
        for e in range(W + 1):
            for zb in range(2):
                xe[e, zb] = us[e] * tx * zs[k + zb]
        bz0, bz1 = -zs[k + 1], -zs[k]
        for j in range(H):
            for vb in range(2):
                for zb in range(2):
                    yv[vb, zb] = vs[j + vb] * ty * zs[k + zb]
            by0, by1 = min(yv[0, 0], yv[0, 1]), max(yv[1, 0], yv[1, 1])
            ia = 0
            while ia < W:
                ib = ia + 1
                if from_cells:
                    while ib < W and col_t[ib, 0] == col_t[ia, 0] and col_t[ib, 1] == col_t[ia, 1]:
                        ib += 1
                    key += 1
                    nu = _cell_union(col_t[ia, 0], col_t[ia, 1], row_t[j, 0], row_t[j, 1],
                                     slice_s[k, 0], slice_s[k, 1], zs[k], zs[k + 1],
                                     tiles_x, slices, cell_spans, spans, cell_entries,
                                     stamp, key, union)
                else:
                    ib = W
                    nu = n
                    for t in range(n):
                        union[t] = t
                candidates += nu * (ib - ia)
                nr = 0
                for t in range(nu):
                    l = union[t]
                    if PY[j, l] & PZ[k, l] & 1:
                        row[nr] = l
                        nr += 1
                have_fp[ia:ib] = False
                for t in range(nr):
                    l = row[t]
                    keep[t, ia:ib] = 0
                    lo, hi = max(ia, xlo[l]), min(ib, xhi[l])
                    inside = PY[j, l] & PZ[k, l] & 2
                    c0, c1, c2 = C[l, 0], C[l, 1], C[l, 2]
                    r = R[l]
                    r2 = r * r
                    scale = abs(c0) + abs(c1) + abs(c2) + r + zs[k + 1]
                    slack = r2 + BOX_MARGIN * scale * scale
                    ey = max(by0 - c1, c1 - by1, 0.0)
                    ez = max(bz0 - c2, c2 - bz1, 0.0)
                    eyz = ey * ey + ez * ez
                    for i in range(lo, hi):
                        a = PX[i, l]
                        if (a & 1) == 0:
                            continue
                        if a & inside:
                            keep[t, i] = 1
                            continue
                        # the box around the cell: a sphere clearly off it misses the
                        # cell (the margin far past the rounding of the faces' distances)
                        ex = max(min(xe[i, 0], xe[i, 1]) - c0, c0 - max(xe[i + 1, 0], xe[i + 1, 1]), 0.0)
                        if ex * ex + eyz > slack:
                            continue
                        ok = False
                        for nn in range(8):
                            dx = xe[i + (nn & 1), nn >> 2 & 1] - c0
                            dy = yv[nn >> 1 & 1, nn >> 2 & 1] - c1
                            dz = -zs[k + (nn >> 2 & 1)] - c2
                            if dx * dx + dy * dy + dz * dz < r2:
                                ok = True
                                break
                        if not ok:
                            _corners(us, vs, zs, tx, ty, i, j, k, q)
                            if not have_fp[i]:
                                _face_planes(q, faces, fps[i])
                                have_fp[i] = True
                            ok = _sphere_faces(C[l], r, q, faces, fps[i])
                        if ok:
                            keep[t, i] = 1
                for i in range(ia, ib):
                    for t in range(nr):                 # branchless: written, kept or not
                        entries[base + m] = row[t]
                        m += keep[t, i]
                    offsets[(k * H + j) * W + i + 1] = m
                ia = ib
    return m, candidates


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _compact(entries, offsets, bases, sizes, cuts):
    """The runs' lists, each written at its own base, moved to follow one another (forward:
    each lands at or before where it was written) and their offsets, counted from their
    base, made global (cuts: the runs' first froxels)."""
    dst = 0
    for t in range(bases.shape[0]):
        src = bases[t]
        if src != dst:
            for e in range(sizes[t]):
                entries[dst + e] = entries[src + e]
        for f in range(cuts[t] + 1, cuts[t + 1] + 1):
            offsets[f] += dst
        dst += sizes[t]
    return dst


@dataclass
class FroxelSets:
    """Each froxel's light set, CSR: offsets (F+1,) int64, entries uint32 positions in the
    light buffer; `candidates`: what the froxels were given in all before the exact test
    (the union of their cells for a cell technique, every visible light for brute)."""
    offsets: np.ndarray
    entries: np.ndarray
    candidates: int

    def counts(self) -> np.ndarray:
        return np.diff(self.offsets)


def _sets(fg: FroxelGrid, lb: LightBounds, cells=None):
    """_sets_run over runs of slices, on the CPU stage's threads (parallel(): each run its own
    kernel call, the GIL released), into one array: each run writes at its own base, then
    _compact closes the gaps in slice order (froxel ids are slice-major, so the runs' CSR
    lists follow one another): the lists are written once and moved once.  cells: None
    (every light a candidate) or (col_t, row_t, slice_s, cell_spans, spans, cell_entries,
    tiles_x, slices).
    -> (offsets, entries, candidates)."""
    us, vs = fg.ndc()
    base = (lb.centre, lb.radius, lb.rect, lb.depth, fg.xs, fg.ys, us, vs, fg.zs,
            fg.tan_x, fg.tan_y)
    tables = _axis_tables(*base)
    from_cells = cells is not None
    if not from_cells:
        none = np.zeros((1, 2), np.int64)
        cells = (none, none, none, none, np.zeros((1, 4)), np.zeros(1, np.int64), 1, 1)
    w, h, d = fg.dims
    runs = min(d, 4 * threads()) if parallel() else 1
    cuts = np.array([d * t // runs for t in range(runs + 1)], np.int64)
    offsets = np.zeros(fg.count + 1, np.int64)
    # each run writes at a base past the most its slices can hold (a kept light passes its
    # column, row and slice tests there), and n more (its lists are written without a
    # branch, up to n entries past their end)
    n = len(lb)
    px, py = ((p & 1).sum(0, dtype=np.int64) for p in tables[:2])
    most = np.add.reduceat((tables[2] & 1).astype(np.int64) @ (px * py), cuts[:-1]) if n \
        else np.zeros(runs, np.int64)
    bound = most + n
    bases = np.concatenate([[0], np.cumsum(bound)[:-1]]).astype(np.int64)
    entries = np.empty(int(bound.sum()), np.uint32)
    def one(t):
        return _sets_run(lb.centre, lb.radius, *base[4:], FACES, *tables, cuts[t], cuts[t + 1],
                         from_cells, *cells, offsets, entries, bases[t])
    if runs == 1:
        parts = [one(0)]
    else:
        with ThreadPoolExecutor(threads()) as pool:
            parts = list(pool.map(one, range(runs)))
    sizes = np.array([p[0] for p in parts], np.int64)
    total = _compact(entries, offsets, bases, sizes, cuts * (w * h))
    return offsets, entries[:total], sum(int(p[1]) for p in parts)


def froxel_sets_all(fg: FroxelGrid, lb: LightBounds) -> FroxelSets:
    """brute: every visible light a candidate of every froxel, the exact test keeps it."""
    offsets, entries, _ = _sets(fg, lb)
    return FroxelSets(offsets, entries, fg.count * len(lb))


def cell_edges(grid: Grid):
    """(tile x edges, tile y edges, slice edges) of a cell grid: tile t spans pixels
    [edges[t], edges[t+1]), slice s depths [edges[s], edges[s+1]) (its slice_index() steps),
    the outer ones open to infinity (a cell takes whatever its binning clamped into it)."""
    tx = np.arange(grid.tiles_x + 1) * float(grid.tile)
    ty = np.arange(grid.tiles_y + 1) * float(grid.tile)
    tx[0] = ty[0] = -np.inf
    tx[-1] = ty[-1] = np.inf
    s = np.concatenate([[-np.inf], slice_edges(grid), [np.inf]])
    return tx, ty, s


def froxel_sets_from_cells(fg: FroxelGrid, grid: Grid, ranges, cell_entries,
                           lb: LightBounds) -> FroxelSets:
    """A cell technique: the union of the cells each froxel overlaps (ranges (cells, 2)
    first / count into cell_entries, cells of `grid`), then the exact test."""
    ranges = np.asarray(ranges, np.int64)
    spans = np.empty((len(ranges), 4))
    spans[:, 0], spans[:, 1], spans[:, 2], spans[:, 3] = ranges[:, 0], ranges[:, 1], -np.inf, np.inf
    cell_spans = np.stack([np.arange(len(ranges)), np.ones(len(ranges), np.int64)], 1)
    return froxel_sets_from_spans(fg, grid, cell_spans, spans, cell_entries, lb)


def froxel_sets_from_spans(fg: FroxelGrid, grid: Grid, cell_spans, spans, cell_entries,
                           lb: LightBounds) -> FroxelSets:
    """froxel_sets_from_cells() of cells whose lists are spans (a tree's leaves, each with
    its depth interval: a froxel takes the leaves whose interval overlaps its depths)."""
    tx, ty, s = cell_edges(grid)
    offsets, entries, cand = _sets(fg, lb, (
        _spans_of(fg.xs, tx), _spans_of(fg.ys, ty), _spans_of(fg.zs, s),
        np.ascontiguousarray(cell_spans, np.int64), np.ascontiguousarray(spans, np.float64),
        np.ascontiguousarray(cell_entries, np.int64), grid.tiles_x, grid.slices))
    return FroxelSets(offsets, entries, int(cand))


def tree_spans(ranges, nodes, count_mask: int = 0x7FFFFFFF):
    """(cell_spans, spans) of light trees (cpu_prep.tree: ranges[cell] = first node, node
    count (masked: hybrid's tree bit); TREE_NODE rows): each cell's leaves, in node order,
    each its lights' span of the entries and its bounding interval [min, max depth]."""
    ranges = np.asarray(ranges, np.int64)
    first, count = ranges[:, 0], ranges[:, 1] & count_mask
    cell_of = np.repeat(np.arange(len(ranges)), count)
    node = np.repeat(first - np.concatenate([[0], np.cumsum(count)[:-1]]), count) + np.arange(count.sum())
    from .layouts import unpack_node_bits
    leaf, lights, _ = unpack_node_bits(nodes["bits"][node])
    keep = leaf & (lights > 0)
    cell_of, node, lights = cell_of[keep], node[keep], lights[keep]
    spans = np.stack([nodes["first_light"][node].astype(np.float64), lights.astype(np.float64),
                      nodes["min_depth"][node].astype(np.float64),
                      nodes["max_depth"][node].astype(np.float64)], 1)
    per = np.bincount(cell_of, minlength=len(ranges))
    cell_spans = np.stack([np.concatenate([[0], np.cumsum(per)[:-1]]), per], 1)
    return cell_spans, spans


def centre_cell_sets(fg: FroxelGrid, grid: Grid, ranges, cell_entries) -> FroxelSets:
    """The shortcut the exact sets replace: each froxel takes the list of the one cell its
    centre falls in, as it is (no union, no test): right only where the froxel lies inside
    that cell (the matched grid); elsewhere it misses the lights of its other cells."""
    xc = 0.5 * (fg.xs[:-1] + fg.xs[1:])
    yc = 0.5 * (fg.ys[:-1] + fg.ys[1:])
    zc = 0.5 * (fg.zs[:-1] + fg.zs[1:])
    tx = np.minimum((xc // grid.tile).astype(np.int64), grid.tiles_x - 1)
    ty = np.minimum((yc // grid.tile).astype(np.int64), grid.tiles_y - 1)
    s = grid.slice_of(zc).astype(np.int64)
    cell = ((ty[None, :, None] * grid.tiles_x + tx[None, None, :]) * grid.slices
            + s[:, None, None]).ravel()
    first = np.asarray(ranges[cell, 0], np.int64)
    cnt = np.asarray(ranges[cell, 1], np.int64)
    offsets = np.concatenate([[0], np.cumsum(cnt)])
    idx = np.repeat(first - offsets[:-1], cnt) + np.arange(offsets[-1])
    return FroxelSets(offsets, np.asarray(cell_entries, np.uint32)[idx], int(cnt.sum()))


def set_figures(sets: FroxelSets, ids: np.ndarray, dims) -> tuple[np.ndarray, np.ndarray]:
    """(count, hash) per froxel, (D, H, W) with row 0 the top: the dump's froxel_count and
    froxel_hash (XOR of the contract's mix(id)) of these sets, computed on the CPU."""
    w, h, d = dims
    counts = sets.counts().astype(np.uint32)
    mixed = layouts.mix(np.asarray(ids, np.uint32)[sets.entries.astype(np.int64)])
    hashes = np.zeros(len(counts), np.uint32)
    nonempty = counts > 0
    if nonempty.any():
        red = np.bitwise_xor.reduceat(mixed, sets.offsets[:-1][nonempty]) if len(mixed) else []
        hashes[nonempty] = red
    shape = lambda a: a.reshape(d, h, w)[:, ::-1, :].copy()
    return shape(counts), shape(hashes)


