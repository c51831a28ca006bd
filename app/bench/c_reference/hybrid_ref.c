/* A plain single-threaded C version of the hybrid's (and clustered's) CPU stage for point
 * lights: the reference our numba kernels are held to ("at or under plain single-threaded
 * C").  Written as a first version: plain scalar loops, no SIMD intrinsics,
 * no prefetch, no streaming stores, no threads.  Every output is bit for bit what cpu_prep
 * gives (tests/app/bench/test_c_reference.py): the same IEEE operations in the same order
 * and precision as the kernels (float32 where they round to float32, float64 elsewhere).
 *
 *   cull    view transform of each light's position, its culling sphere (grow()), the
 *           sphere against the near/far planes and the four widened side planes
 *           (cpu_prep/lights.py _cull); the visible ones' key << 32 | id and depth
 *   sort    LSD radix sort of those uint64 on the key (3 passes of 11, 11, 10 bits; a pass
 *           whose digit is the same for every key is skipped): stable, ties keep scene order
 *   gather  in depth order: the scene record, the GPU_LIGHT row (cpu_prep/layouts.py, as
 *           _pack_chunks writes it for a point), the screen rectangle (Mara & McGuire's
 *           listing 1: the exact cheaper form in front of the near plane, the general one
 *           across it, cpu_prep/bounds.py) and the float32 depth range rounded outwards
 *   bin     each light's cell box (cpu_prep/grid.py _box: tile_of, the slice table), the
 *           per-cell counts by walking each box, prefix sums into the CSR offsets, the fill
 *           of the per-cell lists in depth order
 *   plan    hybrid: listing 2 per cell (the float64 sum in entry order, cpu_prep/tree.py scan)
 *   build   hybrid: each cell's nodes (a list: one leaf; a tree: the full bottom-up tree of
 *           _leaves, written depth-first with skip counts as _emit and depth_first_tables
 *           give it, TREE_NODE / node_bits), the cell ranges with the tree bit of
 *           app/techniques/hybrid.py; clustered: the list ranges (offset, count)
 *
 * Each step is timed here (clock_gettime), so no Python overhead is in the figures.
 *
 * Built by app/bench/c_reference/__init__.py with
 *     cc -O2 -march=native -ffp-contract=off -fno-fast-math -shared -fPIC
 * -march=native because numba compiles for the host CPU too (the same instruction set for
 * both); -ffp-contract=off and -fno-fast-math because the bits must match: no fused
 * multiply-add, no reassociation (numba's kernels use neither).  x86-64 evaluates float and
 * double in SSE registers at their own precision (FLT_EVAL_METHOD 0).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* scenes.model.LIGHT_DTYPE (align=True): 84 bytes; the loader checks every offset */
typedef struct {
    uint8_t type;
    uint8_t pad_[3];
    float position[3];
    float radius;
    float color[3];
    float intensity;
    float direction[3];
    float cos_inner;
    float cos_outer;
    float length;
    float up[3];
    float extent[3];
} light_rec;
_Static_assert(sizeof(light_rec) == 84, "LIGHT_DTYPE is 84 bytes");

enum { LIGHT_POINT = 0 };
#define RADIUS_REL_MARGIN 1e-5          /* cpu_prep/limits.py */
#define PIXEL_MARGIN 1.0
#define SLICE_DEPTH_REL_MARGIN 1e-4
#define F32_EPS 1.1920928955078125e-07  /* 2^-23 */
#define NODE_COUNT_BITS 16
#define NODE_MAX_LIGHTS 65535
#define CELL_TREE_BIT 0x80000000u       /* app/techniques/hybrid.py */
#define LIGHT_WORDS 24                  /* GPU_LIGHT: six vec4 */

/* Python's min/max as numba compiles them: the second argument when it compares less
 * (greater), else the first */
static inline double minf(double a, double b) { return b < a ? b : a; }
static inline double maxf(double a, double b) { return b > a ? b : a; }
static inline float minf32(float a, float b) { return b < a ? b : a; }
static inline float maxf32(float a, float b) { return b > a ? b : a; }

static inline uint32_t f32_bits(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static inline float bits_f32(uint32_t u) { float f; memcpy(&f, &u, 4); return f; }

/* nextafterf(f, +inf) / (f, -inf) */
static inline float next_up(float f) {
    if (f != f || f == INFINITY) return f;
    if (f == 0.0f) return bits_f32(1u);
    uint32_t u = f32_bits(f);
    return bits_f32(f > 0.0f ? u + 1u : u - 1u);
}
static inline float next_down(float f) {
    if (f != f || f == -INFINITY) return f;
    if (f == 0.0f) return bits_f32(0x80000001u);
    uint32_t u = f32_bits(f);
    return bits_f32(f > 0.0f ? u - 1u : u + 1u);
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

/* ---- the frame's buffers: grown when a frame needs more, kept for the next ---------- */

typedef struct {
    void *p;
    size_t cap;
} buf;

static void *need(buf *b, size_t bytes) {
    if (bytes > b->cap) {
        size_t cap = bytes + bytes / 4 + 64;
        void *p = realloc(b->p, cap);
        if (!p) return NULL;
        b->p = p;
        b->cap = cap;
    }
    return b->p;
}

enum { B_KEYED, B_DEPTH, B_SCRATCH, B_ROWS, B_RECT, B_LO, B_HI, B_BOXES, B_COUNTS, B_OFFSETS,
       B_CURSOR, B_ENTRIES, B_IS_TREE, B_LEAVES, B_RANGES, B_NODES, B_BF, B_COUNT_ };

typedef struct {
    buf b[B_COUNT_];
    int64_t hist[3][2048];      /* the sort's digit counts */
} ref_ctx;

/* what one frame made (pointers into the context's buffers, valid until the next frame) */
typedef struct {
    int64_t visible, cells, entries, nodes;
    const uint64_t *sorted;     /* (visible,) key << 32 | scene id, depth order */
    const float *rows;          /* (visible, 24) GPU_LIGHT */
    const double *rect;         /* (visible, 4) x0, x1, y0, y1 */
    const float *depth_lo, *depth_hi;
    const int64_t *offsets;     /* (cells + 1,) */
    const uint32_t *entry;      /* (entries,) */
    const uint32_t *ranges;     /* (cells, 2) */
    const uint32_t *node;       /* (nodes, 4) TREE_NODE */
    const uint8_t *is_tree;     /* (cells,) */
    double ms[6];               /* cull, sort, gather, bin, plan, build */
} ref_out;

ref_ctx *ref_new(void) { return calloc(1, sizeof(ref_ctx)); }

void ref_free(ref_ctx *c) {
    if (!c) return;
    for (int k = 0; k < B_COUNT_; k++) free(c->b[k].p);
    free(c);
}

int ref_struct_sizes(int64_t *out) {
    out[0] = sizeof(light_rec);
    out[1] = sizeof(ref_out);
    return 0;
}

/* ---- the shared float functions ---------------------------------------------------- */

/* cpu_prep/bounds.py grow(): culling radius with the float32 margins */
static inline double grow(double radius, double cx, double cy, double cz) {
    return radius * (1.0 + RADIUS_REL_MARGIN) + 4.0 * F32_EPS * sqrt(cx * cx + cy * cy + cz * cz);
}

/* a world position in view space, as stored: float64 transform rounded to float32 */
static inline void view_position(const double *m, const light_rec *li, float *p) {
    double x = li->position[0], y = li->position[1], z = li->position[2];
    p[0] = (float)(m[0] * x + m[1] * y + m[2] * z + m[3]);
    p[1] = (float)(m[4] * x + m[5] * y + m[6] * z + m[7]);
    p[2] = (float)(m[8] * x + m[9] * y + m[10] * z + m[11]);
}

/* bounds.py project_axis_ahead: a sphere wholly in front of the near plane */
static inline void axis_ahead(double ca, double cz, double r, double tan_half, double *lo, double *hi) {
    double t = sqrt(ca * ca + cz * cz - r * r);
    double tca = t * ca, tcz = t * cz, rca = r * ca, rcz = r * cz;
    double n0 = (tca + rcz) / ((rca - tcz) * tan_half);
    double n1 = (tca - rcz) / ((-rca - tcz) * tan_half);
    *lo = minf(n0, n1);
    *hi = maxf(n0, n1);
}

/* bounds.py project_axis_general: listing 1, clipped at the near plane near_z < 0 */
static void axis_general(double ca, double cz, double r, double near_z, double tan_half,
                         double *out_lo, double *out_hi) {
    double length2 = ca * ca + cz * cz;
    double t2 = length2 - r * r;
    int inside = t2 <= 0.0;
    double vx = 0.0, vy = 0.0;
    if (!inside) {
        double length = sqrt(length2);
        vx = sqrt(t2) / length;
        vy = r / length;
    }
    int clip_sphere = cz + r >= near_z;
    double k = sqrt(maxf(r * r - (near_z - cz) * (near_z - cz), 0.0));
    double lo = INFINITY, hi = -INFINITY;
    for (int s = 0; s < 2; s++) {
        double sign = s == 0 ? 1.0 : -1.0;
        double sy = sign * vy;
        double ba = (vx * ca + sy * cz) * vx;
        double bz = (-sy * ca + vx * cz) * vx;
        if (clip_sphere && (inside || bz > near_z)) {
            ba = ca - sign * k;
            bz = near_z;
        }
        double n = ba / (-bz * tan_half);
        lo = minf(lo, n);
        hi = maxf(hi, n);
    }
    *out_lo = lo;
    *out_hi = hi;
}

/* grid.py tile_of: floor(x / tile) from the product with the reciprocal, corrected */
static inline double tile_of(double x, double tile, double inv_tile) {
    double q = floor(x * inv_tile);
    q = q * tile > x ? q - 1.0 : q;
    return (q + 1.0) * tile <= x ? q + 1.0 : q;
}

/* grid.py slice_from_table: the table's steps at or below depth (binary search; the table
 * is padded with NaN to 2^k - 1 entries) */
static inline int slice_of(double depth, const double *table, int64_t table_len) {
    int64_t s = 0;
    int64_t step = (table_len + 1) >> 1;
    while (step > 0) {
        if (depth >= table[s + step - 1]) s += step;
        step >>= 1;
    }
    return (int)s;
}

static inline int64_t pow2_at_least(int64_t x) {
    int64_t p = 1;
    while (p < x) p <<= 1;
    return p;
}

static inline int log2i(int64_t x) {
    int k = 0;
    while (((int64_t)1 << k) < x) k++;
    return k;
}

/* tree.py tree_leaves / list_leaves */
static inline int64_t tree_leaves(int64_t n, int64_t per_leaf, int64_t max_leaves) {
    int64_t want = pow2_at_least((n + per_leaf - 1) / per_leaf);
    if (want > max_leaves) want = max_leaves;
    int64_t need_ = pow2_at_least((n + NODE_MAX_LIGHTS - 1) / NODE_MAX_LIGHTS);
    return want > need_ ? want : need_;
}
static inline int64_t list_leaves(int64_t n) {
    return pow2_at_least((n + NODE_MAX_LIGHTS - 1) / NODE_MAX_LIGHTS);
}

static inline uint32_t node_bits(uint32_t leaf, uint32_t count, uint32_t skip) {
    return (leaf & 1u) | (count << 1) | (skip << (1 + NODE_COUNT_BITS));
}

/* the breadth-first scratch tree of one cell */
typedef struct {
    float *min, *max;
    int64_t *first, *count;
} bf_tree;

/* node q of the scratch tree and its subtree (`size` nodes), depth-first from out[*pos]:
 * the order and skip counts of tree.py depth_first_tables */
static void emit(const bf_tree *bf, int64_t q, int64_t size, uint32_t *out, int64_t *pos) {
    uint32_t *nd = out + 4 * *pos;
    uint32_t leaf = size == 1;
    memcpy(&nd[0], &bf->min[q], 4);
    memcpy(&nd[1], &bf->max[q], 4);
    nd[2] = (uint32_t)bf->first[q];
    nd[3] = node_bits(leaf, (uint32_t)(bf->count[q] * leaf), (uint32_t)size);
    (*pos)++;
    if (size > 1) {
        emit(bf, 2 * q + 1, size / 2, out, pos);
        emit(bf, 2 * q + 2, size / 2, out, pos);
    }
}

/* ---- the frame --------------------------------------------------------------------- */

/* One frame.  view: the 4x4 view_from_world, row-major; tan_x/tan_y: the cull's side
 * planes (the camera's, widened by PIXEL_MARGIN, as cpu_prep.lights.cull passes them);
 * tan_half_x/y, width, height: the pack's projection; table: grid.slice_table (NaN-padded,
 * table_len entries); slice_lo/hi: cpu_prep.hybrid.cell_depth_ranges; hybrid 0: clustered
 * (no plan, no build: list ranges).  Returns 0, or -1 when memory ran out. */
int ref_frame(ref_ctx *ctx, const light_rec *lights, int64_t n, const double *view,
              double near, double far, double tan_x, double tan_y,
              double tan_half_x, double tan_half_y, double width, double height,
              double tile, int64_t tiles_x, int64_t tiles_y, int64_t slices,
              const double *table, int64_t table_len, const double *slice_lo,
              const double *slice_hi, double radius_scale, int64_t lights_per_leaf,
              int64_t max_leaves, int hybrid, ref_out *out) {
    buf *B = ctx->b;
    const double *m = view;
    memset(out, 0, sizeof(*out));
    double t0 = now_ms();

    /* -- cull ------------------------------------------------------------------------ */
    uint64_t *keyed = need(&B[B_KEYED], (size_t)(n ? n : 1) * 8);
    double *depth = need(&B[B_DEPTH], (size_t)(n ? n : 1) * 8);
    if (!keyed || !depth) return -1;
    double norm_x = sqrt(1.0 + tan_x * tan_x), norm_y = sqrt(1.0 + tan_y * tan_y);
    double near_lo = near * (1 - RADIUS_REL_MARGIN), far_hi = far * (1 + RADIUS_REL_MARGIN);
    int64_t k = 0;
    for (int64_t i = 0; i < n; i++) {
        float p[3];
        view_position(m, &lights[i], p);
        double cx = p[0], cy = p[1], cz = p[2];
        double r = grow((double)lights[i].radius, cx, cy, cz);
        double d = -cz;
        double rx = r * norm_x, ry = r * norm_y;
        int out_ = (d + r < near_lo) || (d - r > far_hi) ||
                   (cx + tan_x * d < -rx) || (-cx + tan_x * d < -rx) ||
                   (cy + tan_y * d < -ry) || (-cy + tan_y * d < -ry);
        if (out_) continue;
        uint32_t bits = f32_bits((float)d);
        uint32_t key = (bits >> 31) ? ~bits : (bits | 0x80000000u);
        keyed[k] = ((uint64_t)key << 32) | (uint64_t)i;
        depth[k] = d;
        k++;
    }
    double t1 = now_ms();

    /* -- sort ------------------------------------------------------------------------ */
    uint64_t *scratch = need(&B[B_SCRATCH], (size_t)(k ? k : 1) * 8);
    if (!scratch) return -1;
    int64_t (*hist)[2048] = ctx->hist;
    memset(hist, 0, sizeof(ctx->hist));
    for (int64_t j = 0; j < k; j++) {
        uint32_t key = (uint32_t)(keyed[j] >> 32);
        hist[0][key & 2047]++;
        hist[1][(key >> 11) & 2047]++;
        hist[2][key >> 22]++;
    }
    uint64_t *src = keyed, *dst = scratch;
    for (int pass = 0; pass < 3; pass++) {
        int64_t *h = hist[pass];
        int trivial = 0;
        for (int d = 0; d < 2048; d++) if (h[d] == k) trivial = 1;
        if (trivial) continue;             /* every key has this digit: nothing moves */
        int64_t total = 0;
        for (int d = 0; d < 2048; d++) {
            int64_t c = h[d];
            h[d] = total;
            total += c;
        }
        int shift = 32 + 11 * pass;
        for (int64_t j = 0; j < k; j++) {
            uint64_t v = src[j];
            dst[h[(v >> shift) & 2047]++] = v;
        }
        uint64_t *t = src; src = dst; dst = t;
    }
    const uint64_t *sorted = src;
    double t2 = now_ms();

    /* -- gather into depth order: rows, rectangles, depth ranges ---------------------- */
    float *rows = need(&B[B_ROWS], (size_t)(k ? k : 1) * LIGHT_WORDS * 4);
    double *rect = need(&B[B_RECT], (size_t)(k ? k : 1) * 4 * 8);
    float *dlo = need(&B[B_LO], (size_t)(k ? k : 1) * 4);
    float *dhi = need(&B[B_HI], (size_t)(k ? k : 1) * 4);
    if (!rows || !rect || !dlo || !dhi) return -1;
    double zn = -near;
    for (int64_t j = 0; j < k; j++) {
        uint32_t id = (uint32_t)(sorted[j] & 0xFFFFFFFFu);
        const light_rec *li = &lights[id];
        float p[3];
        view_position(m, li, p);
        double x = li->direction[0], y = li->direction[1], z = li->direction[2];
        double ux = m[0] * x + m[1] * y + m[2] * z;
        double uy = m[4] * x + m[5] * y + m[6] * z;
        double uz = m[8] * x + m[9] * y + m[10] * z;
        double inv = 1.0 / maxf(sqrt(ux * ux + uy * uy + uz * uz), 1e-30);
        float *row = rows + j * LIGHT_WORDS;
        row[0] = p[0]; row[1] = p[1]; row[2] = p[2]; row[3] = li->radius;
        row[4] = li->color[0] * li->intensity;
        row[5] = li->color[1] * li->intensity;
        row[6] = li->color[2] * li->intensity;
        row[7] = li->cos_inner;
        row[8] = (float)(ux * inv); row[9] = (float)(uy * inv); row[10] = (float)(uz * inv);
        row[11] = li->cos_outer;
        uint32_t idt[4] = {id, li->type, 0, 0};
        memcpy(&row[12], idt, 16);
        row[16] = li->extent[0]; row[17] = li->extent[1]; row[18] = li->extent[2];
        row[19] = li->length;
        row[20] = row[21] = row[22] = row[23] = 0.0f;
        double cx = p[0], cy = p[1], cz = p[2];
        double r = grow((double)li->radius, cx, cy, cz);
        double lx, hx, ly, hy;
        if (cz + r < zn) {
            axis_ahead(cx, cz, r, tan_half_x, &lx, &hx);
            axis_ahead(cy, cz, r, tan_half_y, &ly, &hy);
        } else {
            axis_general(cx, cz, r, zn, tan_half_x, &lx, &hx);
            axis_general(cy, cz, r, zn, tan_half_y, &ly, &hy);
        }
        double *rc = rect + 4 * j;
        rc[0] = (lx * 0.5 + 0.5) * width - PIXEL_MARGIN;
        rc[1] = (hx * 0.5 + 0.5) * width + PIXEL_MARGIN;
        rc[2] = (ly * 0.5 + 0.5) * height - PIXEL_MARGIN;
        rc[3] = (hy * 0.5 + 0.5) * height + PIXEL_MARGIN;
        dlo[j] = next_down((float)(-cz - r));
        dhi[j] = next_up((float)(-cz + r));
    }
    double t3 = now_ms();

    /* -- bin ------------------------------------------------------------------------- */
    int64_t cells = tiles_x * tiles_y * slices;
    int32_t *boxes = need(&B[B_BOXES], (size_t)(k ? k : 1) * 6 * 4);
    uint32_t *counts = need(&B[B_COUNTS], (size_t)cells * 4);
    int64_t *offsets = need(&B[B_OFFSETS], (size_t)(cells + 1) * 8);
    uint32_t *cursor = need(&B[B_CURSOR], (size_t)cells * 4);
    if (!boxes || !counts || !offsets || !cursor) return -1;
    memset(counts, 0, (size_t)cells * 4);
    double inv_tile = 1.0 / tile;
    for (int64_t j = 0; j < k; j++) {
        const double *rc = rect + 4 * j;
        double x0 = rc[0], x1 = rc[1], y0 = rc[2], y1 = rc[3];
        double lo = dlo[j], hi = dhi[j];
        int32_t *bx = boxes + 6 * j;
        if (!(x0 <= x1 && y0 <= y1 && lo <= hi)) {     /* nothing of the light can be seen */
            bx[0] = 1; bx[1] = 0; bx[2] = 1; bx[3] = 0; bx[4] = 1; bx[5] = 0;
            continue;
        }
        bx[0] = (int32_t)(int64_t)maxf(tile_of(x0, tile, inv_tile), 0.0);
        bx[1] = (int32_t)(int64_t)minf(tile_of(x1, tile, inv_tile), tiles_x - 1.0);
        bx[2] = (int32_t)(int64_t)maxf(tile_of(y0, tile, inv_tile), 0.0);
        bx[3] = (int32_t)(int64_t)minf(tile_of(y1, tile, inv_tile), tiles_y - 1.0);
        bx[4] = slice_of(lo * (1.0 - SLICE_DEPTH_REL_MARGIN), table, table_len);
        bx[5] = slice_of(hi * (1.0 + SLICE_DEPTH_REL_MARGIN), table, table_len);
        for (int64_t ty = bx[2]; ty <= bx[3]; ty++)
            for (int64_t tx = bx[0]; tx <= bx[1]; tx++)
                for (int64_t s = bx[4]; s <= bx[5]; s++)
                    counts[(ty * tiles_x + tx) * slices + s]++;
    }
    offsets[0] = 0;
    for (int64_t c = 0; c < cells; c++) {
        cursor[c] = (uint32_t)offsets[c];
        offsets[c + 1] = offsets[c] + counts[c];
    }
    int64_t total = offsets[cells];
    uint32_t *entries = need(&B[B_ENTRIES], (size_t)(total ? total : 1) * 4);
    if (!entries) return -1;
    for (int64_t j = 0; j < k; j++) {
        const int32_t *bx = boxes + 6 * j;
        for (int64_t ty = bx[2]; ty <= bx[3]; ty++)
            for (int64_t tx = bx[0]; tx <= bx[1]; tx++)
                for (int64_t s = bx[4]; s <= bx[5]; s++)
                    entries[cursor[(ty * tiles_x + tx) * slices + s]++] = (uint32_t)j;
    }
    uint32_t *ranges = need(&B[B_RANGES], (size_t)(cells ? cells : 1) * 8);
    uint8_t *is_tree = need(&B[B_IS_TREE], (size_t)(cells ? cells : 1));
    int64_t *leaves = need(&B[B_LEAVES], (size_t)(cells ? cells : 1) * 8);
    if (!ranges || !is_tree || !leaves) return -1;
    if (!hybrid) {                 /* clustered: each cell's list (offset, count) */
        for (int64_t c = 0; c < cells; c++) {
            ranges[2 * c] = (uint32_t)offsets[c];
            ranges[2 * c + 1] = (uint32_t)(offsets[c + 1] - offsets[c]);
        }
    }
    double t4 = now_ms();
    double t5 = t4, t6 = t4;
    int64_t node_total = 0;

    if (hybrid) {
        /* -- plan: listing 2 per cell ------------------------------------------------ */
        for (int64_t c = 0; c < cells; c++) {
            int64_t o = offsets[c], cn = offsets[c + 1] - o;
            if (cn == 0) {
                is_tree[c] = 0;
                leaves[c] = 0;
                continue;
            }
            int64_t s = c % slices;             /* cells are tile-major */
            double lo_s = slice_lo[s], hi_s = slice_hi[s];
            double sum = 0.0;
            for (int64_t e = o; e < o + cn; e++) {
                uint32_t i = entries[e];
                sum += maxf(minf((double)dhi[i], hi_s) - maxf((double)dlo[i], lo_s), 0.0);
            }
            int tree = sum / (double)cn < 0.5 * (hi_s - lo_s) * radius_scale;
            is_tree[c] = (uint8_t)tree;
            leaves[c] = tree ? tree_leaves(cn, lights_per_leaf, max_leaves) : list_leaves(cn);
            node_total += 2 * leaves[c] - 1;
        }
        t5 = now_ms();

        /* -- build: each cell's nodes ---------------------------------------------- */
        uint32_t *nodes = need(&B[B_NODES], (size_t)(node_total ? node_total : 1) * 16);
        int64_t w_max = 1;
        for (int64_t c = 0; c < cells; c++) if (leaves[c] > w_max) w_max = leaves[c];
        char *bfp = need(&B[B_BF], (size_t)(2 * w_max - 1) * 24);
        if (!nodes || !bfp) return -1;
        bf_tree bf = {(float *)bfp, (float *)(bfp + (2 * w_max - 1) * 4),
                      (int64_t *)(bfp + (2 * w_max - 1) * 8), (int64_t *)(bfp + (2 * w_max - 1) * 16)};
        int64_t base = 0;
        for (int64_t c = 0; c < cells; c++) {
            int64_t o = offsets[c], cn = offsets[c + 1] - o, L = leaves[c];
            if (cn == 0) {
                ranges[2 * c] = (uint32_t)base;
                ranges[2 * c + 1] = 0;
                continue;
            }
            int64_t count;
            if (L == 1) {          /* a list: one leaf over all the cell's lights */
                float lo = INFINITY, hi = -INFINITY;
                for (int64_t e = o; e < o + cn; e++) {
                    uint32_t i = entries[e];
                    lo = minf32(lo, dlo[i]);
                    hi = maxf32(hi, dhi[i]);
                }
                uint32_t *nd = nodes + 4 * base;
                memcpy(&nd[0], &lo, 4);
                memcpy(&nd[1], &hi, 4);
                nd[2] = (uint32_t)o;
                nd[3] = node_bits(1, (uint32_t)cn, 1);
                count = 1;
            } else {               /* a tree: balanced leaves, parents bottom-up, depth-first */
                int sh = log2i(L);
                int64_t b = o;
                for (int64_t j = 0; j < L; j++) {
                    int64_t a = b;
                    b = o + (((j + 1) * cn) >> sh);
                    float lo = INFINITY, hi = -INFINITY;
                    for (int64_t e = a; e < b; e++) {
                        uint32_t i = entries[e];
                        lo = minf32(lo, dlo[i]);
                        hi = maxf32(hi, dhi[i]);
                    }
                    int64_t q = L - 1 + j;
                    bf.min[q] = lo; bf.max[q] = hi; bf.first[q] = a; bf.count[q] = b - a;
                }
                for (int64_t q = L - 2; q >= 0; q--) {
                    bf.min[q] = minf32(bf.min[2 * q + 1], bf.min[2 * q + 2]);
                    bf.max[q] = maxf32(bf.max[2 * q + 1], bf.max[2 * q + 2]);
                    bf.first[q] = bf.first[2 * q + 1];
                    bf.count[q] = bf.count[2 * q + 1] + bf.count[2 * q + 2];
                }
                int64_t pos = base;
                emit(&bf, 0, 2 * L - 1, nodes, &pos);
                count = 2 * L - 1;
            }
            ranges[2 * c] = (uint32_t)base;
            ranges[2 * c + 1] = (uint32_t)count | (is_tree[c] ? CELL_TREE_BIT : 0u);
            base += count;
        }
        t6 = now_ms();
        out->node = nodes;
    }

    out->visible = k;
    out->cells = cells;
    out->entries = total;
    out->nodes = node_total;
    out->sorted = sorted;
    out->rows = rows;
    out->rect = rect;
    out->depth_lo = dlo;
    out->depth_hi = dhi;
    out->offsets = offsets;
    out->entry = entries;
    out->ranges = ranges;
    out->is_tree = is_tree;
    out->ms[0] = t1 - t0;
    out->ms[1] = t2 - t1;
    out->ms[2] = t3 - t2;
    out->ms[3] = t4 - t3;
    out->ms[4] = t5 - t4;
    out->ms[5] = t6 - t5;
    return 0;
}
