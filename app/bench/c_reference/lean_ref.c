/* A lean single-threaded C of the hybrid's CPU stage, written from the tree paper's
 * description alone (O'Donnell & Chajdas, "Tiled Light Trees", 3.2-3.3 and 4.1), not from
 * cpu_prep: point lights only, float32 throughout, no margins, no light shapes.  It is the
 * bar for what the design costs (hybrid_ref.c, a port of the lab's own steps, is the bar
 * for what the language costs).
 *
 *   cull    each light's centre in view space; its sphere against the six frustum planes
 *           (unit normals); the visible ones' (depth key << 32 | visible index), their
 *           sphere and scene id
 *   sort    LSD radix sort of those words on the key: 3 passes of 11 bits, the three
 *           histograms in one pass
 *   gather  in depth order: the frame's 32-byte light rows (view centre, radius, colour x
 *           intensity, scene id) the shader reads through the lists
 *   bin     per light its box of cells: tiles from the clipped, projected sphere bound
 *           (Mara & McGuire 2013, per axis: the tangents' closed form when the sphere is
 *           wholly in front of the near plane, their listing otherwise), slices from its depth extent (listing 4, the
 *           scale read as (S - 1) / (logMax - logMin)); the cells' counts by walking each
 *           box, a scan into CSR offsets, the fill in depth order
 *   plan    listing 2 per cell: the mean depth extent clipped to the cell against half the
 *           cell's depth extent (times radius_scale); the leaves of each cell and the scan
 *           of their node counts
 *   build   a list: one leaf; a tree: leaves of lights_per_leaf consecutive lights (fewer
 *           leaves, longer, past max_leaves), rounded up to a power of two, parents
 *           bottom-up breadth first, written depth first through a per-size table with
 *           skip counts (listing 1's node: min, max, first, isLeaf:1 | count:16 | skip:15)
 *
 * Cells are (ty * tiles_x + tx) * slices + slice, tiles from the bottom left (GL), so the
 * lists can be set beside the lab's.  Each step is timed here (clock_gettime).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {                 /* scenes.model.LIGHT_DTYPE (align=True): 84 bytes */
    uint8_t type;
    uint8_t pad_[3];
    float position[3];
    float radius;
    float color[3];
    float intensity;
    float rest_[12];
} light_rec;
_Static_assert(sizeof(light_rec) == 84, "LIGHT_DTYPE is 84 bytes");

typedef struct { float x, y, z, r; } sphere;
typedef struct { float x, y, z, r; float cr, cg, cb; uint32_t id; } row;   /* 32 B */
typedef struct { float lo, hi; } zrange;
typedef struct { uint16_t x0, x1, y0, y1, s0, s1; } box;
typedef struct { float min, max; uint32_t first, bits; } node;

#define MAX_TABLE 15              /* depth-first tables for 1 .. 2^14 leaves (skip: 15 bits) */

typedef struct { void *p; size_t cap; } buf;

enum { B_KEYS, B_TMP, B_SPH, B_IDS, B_ROWS, B_Z, B_BOX, B_COUNT, B_OFF, B_CUR, B_ENT,
       B_LEAVES, B_NOFF, B_RANGES, B_TREE, B_NODES, B_N };

typedef struct {
    buf b[B_N];
    uint32_t hist[3][2048];
    uint32_t *df[MAX_TABLE];      /* df[k][breadth-first index] = depth-first index */
    uint32_t *skip[MAX_TABLE];    /* skip[k][breadth-first index] = nodes in its subtree */
    node scratch[2 << MAX_TABLE];
} lean_ctx;

typedef struct {
    int64_t visible, cells, entries, nodes;
    const uint32_t *ids;          /* (visible,) scene ids in depth order */
    const row *rows;              /* (visible,) */
    const zrange *z;              /* (visible,) depth extent */
    const box *boxes;             /* (visible,) inclusive; x0 > x1 when nothing is on screen */
    const uint32_t *offsets;      /* (cells + 1,) */
    const uint32_t *entry;        /* (entries,) depth-order positions */
    const uint32_t *ranges;       /* (cells, 2) first node, count | tree bit */
    const node *node;             /* (nodes,) */
    const uint8_t *is_tree;       /* (cells,) */
    double ms[6];                 /* cull, sort, gather, bin, plan, build */
} lean_out;

/* min / max as compare and select (libm's fminf / fmaxf are calls: NaN rules) */
static inline float minf(float a, float b) { return b < a ? b : a; }
static inline float maxf(float a, float b) { return b > a ? b : a; }

static void *need(buf *b, size_t bytes) {
    if (bytes == 0) bytes = 64;
    if (bytes > b->cap) {
        void *p = realloc(b->p, bytes + bytes / 4);
        if (!p) return NULL;
        b->p = p;
        b->cap = bytes + bytes / 4;
    }
    return b->p;
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

/* depth-first position and subtree size of each breadth-first node of a full tree */
static void df_table(uint32_t *df, uint32_t *skip, uint32_t q, uint32_t size, uint32_t *pos) {
    df[q] = (*pos)++;
    skip[q] = size;
    if (size > 1) {
        df_table(df, skip, 2 * q + 1, size / 2, pos);
        df_table(df, skip, 2 * q + 2, size / 2, pos);
    }
}

lean_ctx *lean_new(void) {
    lean_ctx *c = calloc(1, sizeof(lean_ctx));
    if (!c) return NULL;
    for (int k = 0; k < MAX_TABLE; k++) {
        uint32_t n = (2u << k) - 1, pos = 0;
        c->df[k] = malloc(n * 4);
        c->skip[k] = malloc(n * 4);
        if (!c->df[k] || !c->skip[k]) return NULL;
        df_table(c->df[k], c->skip[k], 0, n, &pos);
    }
    return c;
}

void lean_free(lean_ctx *c) {
    if (!c) return;
    for (int k = 0; k < B_N; k++) free(c->b[k].p);
    for (int k = 0; k < MAX_TABLE; k++) { free(c->df[k]); free(c->skip[k]); }
    free(c);
}

int lean_struct_sizes(int64_t *out) {
    out[0] = sizeof(light_rec);
    out[1] = sizeof(lean_out);
    out[2] = sizeof(row);
    out[3] = sizeof(box);
    return 0;
}

/* Mara & McGuire's bound of the sphere (c on the axis, cz; r) in the axis-z plane, clipped
 * at nearz < 0, as normalized device coordinates lo..hi (proj: 1 / tan of the half angle) */
static inline void axis_bound(float ca, float cz, float r, float nearz, float proj, float *lo, float *hi) {
    float t2 = ca * ca + cz * cz - r * r;
    if (cz + r < nearz) {          /* wholly in front of the near plane: the two tangents */
        float t = sqrtf(t2), tca = t * ca, tcz = t * cz, rca = r * ca, rcz = r * cz;
        float n0 = proj * (tca + rcz) / (rca - tcz), n1 = proj * (tca - rcz) / (-rca - tcz);
        *lo = minf(n0, n1);
        *hi = maxf(n0, n1);
        return;
    }
    int inside = t2 <= 0.0f;
    float vx = 0.0f, vy = 0.0f;
    if (!inside) {
        float il = 1.0f / sqrtf(ca * ca + cz * cz);
        vx = sqrtf(t2) * il;
        vy = r * il;
    }
    int clip = cz + r >= nearz;
    float dz = nearz - cz, k = sqrtf(maxf(r * r - dz * dz, 0.0f));
    float b[2];
    for (int s = 0; s < 2; s++) {
        float sy = s ? -vy : vy;
        float ba = (vx * ca + sy * cz) * vx, bz = (-sy * ca + vx * cz) * vx;
        if (clip && (inside || bz > nearz)) {
            ba = s ? ca + k : ca - k;
            bz = nearz;
        }
        b[s] = proj * ba / -bz;
    }
    *lo = minf(b[0], b[1]);
    *hi = maxf(b[0], b[1]);
}

/* the first and last tile of a bound's ends f (in tiles): an end off screen gives an empty
 * range (first > last) */
static inline int tile_lo(float f, int tiles) { return f < 0.0f ? 0 : f >= tiles ? tiles : (int)f; }
static inline int tile_hi(float f, int tiles) { return f < 0.0f ? -1 : f >= tiles ? tiles - 1 : (int)f; }

static inline int slice_of(float d, float scale, float bias, int slices) {
    if (d <= 0.0f) return 0;
    float s = logf(d) * scale + bias;
    return s <= 0.0f ? 0 : s >= slices - 1 ? slices - 1 : (int)s;
}

static inline uint32_t pow2_ceil(uint32_t x) {
    uint32_t p = 1;
    while (p < x) p <<= 1;
    return p;
}

static inline int log2u(uint32_t p) { return 31 - __builtin_clz(p); }

/* One frame.  view: 4x4 view_from_world, row-major; log_min / log_max: the grid's slice
 * range (slice 0 ends at exp(log_min)); max_depth: where listing 2 clips the last slice.
 * Returns 0, -1 when memory ran out, -2 when a tree would need more leaves than the tables. */
int lean_frame(lean_ctx *ctx, const light_rec *lights, int64_t n, const double *view,
               float near, float far, float tan_half_x, float tan_half_y, int width,
               int height, int tile, int slices, float log_min, float log_max,
               float max_depth, float radius_scale, int lights_per_leaf, int max_leaves,
               lean_out *out) {
    buf *B = ctx->b;
    memset(out, 0, sizeof(*out));
    float m[12];
    for (int i = 0; i < 12; i++) m[i] = (float)view[i];
    double t0 = now_ms();

    /* -- cull: six planes, unit normals; view space looks down -z ---------------------- */
    uint64_t *keys = need(&B[B_KEYS], n * 8);
    sphere *sph = need(&B[B_SPH], n * sizeof(sphere));
    uint32_t *vid = need(&B[B_IDS], n * 4);
    if (!keys || !sph || !vid) return -1;
    float nx = 1.0f / sqrtf(1.0f + tan_half_x * tan_half_x);
    float ny = 1.0f / sqrtf(1.0f + tan_half_y * tan_half_y);
    float ax = nx, bx = tan_half_x * nx, ay = ny, by = tan_half_y * ny;
    uint32_t k = 0;
    for (int64_t i = 0; i < n; i++) {
        const float *p = lights[i].position;
        float x = m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3];
        float y = m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7];
        float z = m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11];
        float r = lights[i].radius, d = -z;
        int in = (d + r >= near) & (d - r <= far)
               & (ax * x + bx * d >= -r) & (-ax * x + bx * d >= -r)
               & (ay * y + by * d >= -r) & (-ay * y + by * d >= -r);
        uint32_t bits;
        memcpy(&bits, &d, 4);
        bits = (bits >> 31) ? ~bits : bits | 0x80000000u;     /* order of the floats */
        keys[k] = (uint64_t)bits << 32 | k;
        sph[k] = (sphere){x, y, z, r};
        vid[k] = (uint32_t)i;
        k += in;                       /* branch-free: a rejected light is overwritten */
    }
    double t1 = now_ms();

    /* -- sort: 3 LSD passes of 11 bits on the key ------------------------------------- */
    uint64_t *tmp = need(&B[B_TMP], (size_t)k * 8);
    if (!tmp) return -1;
    memset(ctx->hist, 0, sizeof(ctx->hist));
    for (uint32_t j = 0; j < k; j++) {
        uint32_t key = (uint32_t)(keys[j] >> 32);
        ctx->hist[0][key & 2047]++;
        ctx->hist[1][(key >> 11) & 2047]++;
        ctx->hist[2][key >> 22]++;
    }
    uint64_t *src = keys, *dst = tmp;
    for (int pass = 0; pass < 3; pass++) {
        uint32_t *h = ctx->hist[pass], sum = 0;
        for (int d = 0; d < 2048; d++) { uint32_t c = h[d]; h[d] = sum; sum += c; }
        int shift = 32 + 11 * pass;
        for (uint32_t j = 0; j < k; j++) {
            uint64_t v = src[j];
            dst[h[(v >> shift) & 2047]++] = v;
        }
        uint64_t *t = src; src = dst; dst = t;
    }
    double t2 = now_ms();

    /* -- gather: the light rows in depth order ---------------------------------------- */
    row *rows = need(&B[B_ROWS], (size_t)k * sizeof(row));
    uint32_t *ids = (uint32_t *)dst;          /* the sort's other buffer, free now */
    if (!rows) return -1;
    for (uint32_t j = 0; j < k; j++) {
        uint32_t v = (uint32_t)src[j], id = vid[v];
        const light_rec *li = &lights[id];
        sphere s = sph[v];
        float w = li->intensity;
        rows[j] = (row){s.x, s.y, s.z, s.r, li->color[0] * w, li->color[1] * w,
                        li->color[2] * w, id};
        ids[j] = id;
    }
    double t3 = now_ms();

    /* -- bin: boxes and counts, the scan, the fill ------------------------------------ */
    int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
    int64_t cells = (int64_t)tiles_x * tiles_y * slices;
    zrange *zr = need(&B[B_Z], (size_t)k * sizeof(zrange));
    box *boxes = need(&B[B_BOX], (size_t)k * sizeof(box));
    uint32_t *count = need(&B[B_COUNT], cells * 4);
    uint32_t *off = need(&B[B_OFF], (cells + 1) * 4);
    uint32_t *cur = need(&B[B_CUR], cells * 4);
    if (!zr || !boxes || !count || !off || !cur) return -1;
    memset(count, 0, cells * 4);
    float scale = slices > 1 ? (slices - 1) / (log_max - log_min) : 0.0f;
    float bias = slices > 1 ? 1.0f - log_min * scale : 0.0f;
    float px = 1.0f / tan_half_x, py = 1.0f / tan_half_y, itile = 1.0f / tile;
    for (uint32_t j = 0; j < k; j++) {
        row s = rows[j];
        float lx, hx, ly, hy, d = -s.z;
        axis_bound(s.x, s.z, s.r, -near, px, &lx, &hx);
        axis_bound(s.y, s.z, s.r, -near, py, &ly, &hy);
        box b = {1, 0, 1, 0, 0, 0};              /* empty: nothing of it on screen */
        int x0 = tile_lo((lx * 0.5f + 0.5f) * width * itile, tiles_x);
        int x1 = tile_hi((hx * 0.5f + 0.5f) * width * itile, tiles_x);
        int y0 = tile_lo((ly * 0.5f + 0.5f) * height * itile, tiles_y);
        int y1 = tile_hi((hy * 0.5f + 0.5f) * height * itile, tiles_y);
        zr[j] = (zrange){d - s.r, d + s.r};
        if (x0 <= x1 && y0 <= y1)
            b = (box){x0, x1, y0, y1, slice_of(d - s.r, scale, bias, slices),
                      slice_of(d + s.r, scale, bias, slices)};
        boxes[j] = b;
        for (int ty = b.y0; ty <= b.y1; ty++)
            for (int tx = b.x0; tx <= b.x1; tx++) {
                uint32_t *c = count + ((int64_t)ty * tiles_x + tx) * slices;
                for (int sl = b.s0; sl <= b.s1; sl++) c[sl]++;
            }
    }
    uint32_t total = 0;
    for (int64_t c = 0; c < cells; c++) { off[c] = cur[c] = total; total += count[c]; }
    off[cells] = total;
    uint32_t *ent = need(&B[B_ENT], (size_t)total * 4);
    if (!ent) return -1;
    for (uint32_t j = 0; j < k; j++) {
        box b = boxes[j];
        for (int ty = b.y0; ty <= b.y1; ty++)
            for (int tx = b.x0; tx <= b.x1; tx++) {
                uint32_t *c = cur + ((int64_t)ty * tiles_x + tx) * slices;
                for (int sl = b.s0; sl <= b.s1; sl++) ent[c[sl]++] = j;
            }
    }
    double t4 = now_ms();

    /* -- plan: listing 2, each cell's leaves and first node --------------------------- */
    uint32_t *leaves = need(&B[B_LEAVES], cells * 4);
    uint32_t *noff = need(&B[B_NOFF], (cells + 1) * 4);
    uint8_t *is_tree = need(&B[B_TREE], cells);
    if (!leaves || !noff || !is_tree) return -1;
    float slo[64], shi[64];            /* each slice's depth range (the last to max_depth) */
    if (slices > 64) return -2;
    for (int s = 0; s < slices; s++) {
        slo[s] = s == 0 ? 0.0f : expf((s - bias) / scale);
        shi[s] = s + 1 < slices ? expf((s + 1 - bias) / scale) : maxf(max_depth, slo[s]);
    }
    uint32_t nodes_total = 0;
    for (int64_t c = 0; c < cells; c++) {
        uint32_t o = off[c], cn = off[c + 1] - o;
        int s = (int)(c % slices);
        float lo = slo[s], hi = shi[s], sum = 0.0f;
        for (uint32_t e = o; e < o + cn; e++) {
            zrange z = zr[ent[e]];
            sum += maxf(minf(z.hi, hi) - maxf(z.lo, lo), 0.0f);
        }
        int tree = cn > 0 && sum < cn * 0.5f * (hi - lo) * radius_scale;
        uint32_t L = pow2_ceil((cn + 65534) / 65535);            /* a leaf holds 2^16 - 1 */
        if (tree) {
            uint32_t want = pow2_ceil((cn + lights_per_leaf - 1) / lights_per_leaf);
            want = want < (uint32_t)max_leaves ? want : (uint32_t)max_leaves;
            L = want > L ? want : L;
        }
        if (L > (1u << (MAX_TABLE - 1))) return -2;
        is_tree[c] = (uint8_t)tree;
        leaves[c] = cn ? L : 0;
        noff[c] = nodes_total;
        nodes_total += cn ? 2 * L - 1 : 0;
    }
    noff[cells] = nodes_total;
    double t5 = now_ms();

    /* -- build: leaves, parents bottom-up, out depth first ---------------------------- */
    node *nodes = need(&B[B_NODES], (size_t)nodes_total * sizeof(node));
    uint32_t *ranges = need(&B[B_RANGES], cells * 8);
    if (!nodes || !ranges) return -1;
    node *bf = ctx->scratch;
    for (int64_t c = 0; c < cells; c++) {
        uint32_t o = off[c], cn = off[c + 1] - o, L = leaves[c], base = noff[c];
        ranges[2 * c] = base;
        ranges[2 * c + 1] = (cn ? 2 * L - 1 : 0) | (is_tree[c] ? 0x80000000u : 0u);
        if (cn == 0) continue;
        uint32_t per = (cn + L - 1) / L, lg = log2u(L);
        for (uint32_t j = 0; j < L; j++) {         /* leaves: breadth-first L-1 .. 2L-2 */
            uint32_t a = o + j * per < o + cn ? o + j * per : o + cn;
            uint32_t b = a + per < o + cn ? a + per : o + cn;
            float lo = INFINITY, hi = -INFINITY;
            for (uint32_t e = a; e < b; e++) {
                zrange z = zr[ent[e]];
                lo = minf(lo, z.lo);
                hi = maxf(hi, z.hi);
            }
            bf[L - 1 + j] = (node){lo, hi, a, b - a};
        }
        for (int64_t q = (int64_t)L - 2; q >= 0; q--) {
            node l = bf[2 * q + 1], r = bf[2 * q + 2];
            bf[q] = (node){minf(l.min, r.min), maxf(l.max, r.max), l.first, l.bits + r.bits};
        }
        const uint32_t *df = ctx->df[lg], *skip = ctx->skip[lg];
        for (uint32_t q = 0; q < 2 * L - 1; q++) {
            uint32_t leaf = q >= L - 1;
            node v = bf[q];
            v.bits = leaf | (leaf ? v.bits : 0) << 1 | skip[q] << 17;
            nodes[base + df[q]] = v;
        }
    }
    double t6 = now_ms();

    out->visible = k;
    out->cells = cells;
    out->entries = total;
    out->nodes = nodes_total;
    out->ids = ids;
    out->rows = rows;
    out->z = zr;
    out->boxes = boxes;
    out->offsets = off;
    out->entry = ent;
    out->ranges = ranges;
    out->node = nodes;
    out->is_tree = is_tree;
    double t[7] = {t0, t1, t2, t3, t4, t5, t6};
    for (int s = 0; s < 6; s++) out->ms[s] = t[s + 1] - t[s];
    return 0;
}
