/* jaxflex part FMU: the monitored points in blocks with bounds per block (the C form of
 * jaxflex._blocks), so that an output over every point evaluates only the blocks that can
 * decide it and still equals the evaluation of every point.
 *
 * When the model is loaded, the K points are ordered by a k-d bisection of their
 * coordinates (each segment of blocks split across its longest extent, half of its blocks'
 * points on either side, until nB = ceil(K / JXF_BLOCK_POINTS) segments of JXF_BLOCK_POINTS
 * points remain, the last one fewer), so a block is a compact patch of the part, and the
 * shapes (M + R rows psi_j: the modes, then the static residual) are stored
 * block by block. For coordinates x (u_p = sum_j psi_j(p) x_j) three bounds hold for every
 * member p of a block B with centre c (the member nearest the members' mean position):
 *     |u_p|       <= sum_j reach_Bj |x_j|,          reach_Bj = max_p |psi_j(p)|
 *     |u_p - u_c| <= sum_j rho_Bj |x_j|,            rho_Bj = max_p |psi_j(p) - psi_j(c)|
 *     |u_p - u_c| <= sum_l |G_l| s_l + sum_j eps_Bj |x_j|,   G = sum_j L_j x_j,
 * the last from the least-squares gradient L_j of psi_j over the block (G_l its column of
 * direction l, s_l the block's span along l, eps_Bj the largest residual of the linear fit:
 * first order in the block's size where the radius is zeroth order, and it keeps the
 * cancellation between the modes that the others lose). The first costs M + R products a
 * block, the second four times that, the third eleven times; each is tried only where the
 * cheaper ones leave the block in play (mode shapes are smooth over a part, so on the
 * built-in plate ~8 of its 246 blocks are evaluated).
 *
 * The deviation max_p |u_p| evaluates the block where it was largest the last time first,
 * then every block whose bounds (inflated by the rounding of every computed norm, see
 * bound_slack) all exceed the largest value found: a block left out cannot hold a larger
 * value, so the result is the maximum over every point to the last bit (each point's
 * value is computed by the same code whatever the others' fate). Built with
 * -DJXF_EVERY_POINT nothing is pruned: the reference the tests compare with. The
 * evaluated blocks' displacements stay in m->u (block by block) for the outputs that read
 * points (their stamp names the state), the others are evaluated when read.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "jxf_blocks.h"
#include "jxf_model.h"

#if defined(_MSC_VER)
#define JXF_RESTRICT __restrict
#else
#define JXF_RESTRICT restrict
#endif

/* Points per block: a step's work is about nB (M + R) products for the first bounds, more
 * for the blocks they leave in play, and 3 (M + R) JXF_BLOCK_POINTS per evaluated block. */
#ifndef JXF_BLOCK_POINTS
#define JXF_BLOCK_POINTS 32
#endif

/* ---- the kernel ---------------------------------------------------------------------- */

/* The kernel reads its rows grouped by eight values, so that it streams through memory:
 * for n values per row, group g < n / 8 holds (n_rows, 8) values (value 8 g + k of row r at
 * 8 n_rows g + 8 r + k), then the last n % 8 values of every row follow, (n_rows, n % 8).
 * Each group's eight sums stay in registers over every row (gcc -O2 packs them into SIMD
 * registers: ~2.4 instructions per product). Every value is summed over the rows in the
 * same order whatever n and the group are: a point's displacement is the same number
 * however it is evaluated. */
void jxf_combine(const double *JXF_RESTRICT data, const double *JXF_RESTRICT x, int n_rows,
                 size_t n, double *JXF_RESTRICT out) {
    const size_t full = n / 8, rest = n % 8;
    const double *s = data;
    size_t g, k;
    int r;
    for (g = 0; g < full; ++g) {
        double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0, a4 = 0.0, a5 = 0.0, a6 = 0.0, a7 = 0.0;
        for (r = 0; r < n_rows; ++r, s += 8) {
            const double c = x[r];
            a0 += s[0] * c, a1 += s[1] * c, a2 += s[2] * c, a3 += s[3] * c;
            a4 += s[4] * c, a5 += s[5] * c, a6 += s[6] * c, a7 += s[7] * c;
        }
        out[8 * g] = a0, out[8 * g + 1] = a1, out[8 * g + 2] = a2, out[8 * g + 3] = a3;
        out[8 * g + 4] = a4, out[8 * g + 5] = a5, out[8 * g + 6] = a6, out[8 * g + 7] = a7;
    }
    out += 8 * full;
    for (k = 0; k < rest; ++k) out[k] = 0.0;
    for (r = 0; r < n_rows && rest > 0; ++r, s += rest)
        for (k = 0; k < rest; ++k) out[k] += s[k] * x[r];
}

void jxf_group(double *data, int n_rows, size_t n, double *scratch) {
    const size_t full = n / 8, rest = n % 8;
    double *out = data;
    size_t g, k;
    int r;
    memcpy(scratch, data, (size_t)n_rows * n * sizeof(double));
    for (g = 0; g < full; ++g)
        for (r = 0; r < n_rows; ++r)
            for (k = 0; k < 8; ++k) *out++ = scratch[(size_t)r * n + 8 * g + k];
    for (r = 0; r < n_rows; ++r)
        for (k = 0; k < rest; ++k) *out++ = scratch[(size_t)r * n + 8 * full + k];
}

int jxf_block_combine(const jxf_model *m, int block, const double *x, double *out) {
    const jxf_blocks *b = &m->blocks;
    const int rows = m->n_modes + m->n_static, size = b->start[block + 1] - b->start[block];
    jxf_combine(m->shapes + 3 * (size_t)rows * (size_t)b->start[block], x, rows,
                3 * (size_t)size, out);
    return size;
}

/* ---- building the blocks ------------------------------------------------------------- */

/* Point a before point b along `axis` (ties by index: a strict order). */
static int before(const double *points, int axis, int a, int b) {
    const double xa = points[3 * (size_t)a + axis], xb = points[3 * (size_t)b + axis];
    return xa < xb || (xa == xb && a < b);
}

/* Reorder idx[0 .. n) so that its first k entries are the k first along `axis`
 * (quickselect, Hoare partition). */
static void select_first(int *idx, int n, int k, const double *points, int axis) {
    int lo = 0, hi = n - 1;
    while (hi > lo) {
        const int pivot = idx[lo + (hi - lo) / 2];
        int i = lo, j = hi, t;
        while (i <= j) {
            while (before(points, axis, idx[i], pivot)) ++i;
            while (before(points, axis, pivot, idx[j])) --j;
            if (i <= j) t = idx[i], idx[i++] = idx[j], idx[j--] = t;
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return;
    }
}

/* The axis (0, 1, 2) along which the points idx[0 .. n) extend furthest. */
static int longest_axis(const double *points, const int *idx, int n) {
    double low[3], high[3];
    int c, i, axis = 0;
    for (c = 0; c < 3; ++c) low[c] = high[c] = points[3 * (size_t)idx[0] + c];
    for (i = 1; i < n; ++i)
        for (c = 0; c < 3; ++c) {
            const double v = points[3 * (size_t)idx[i] + c];
            low[c] = v < low[c] ? v : low[c];
            high[c] = v > high[c] ? v : high[c];
        }
    for (c = 1; c < 3; ++c)
        if (high[c] - low[c] > high[axis] - low[axis]) axis = c;
    return axis;
}

/* Split the n points idx[0 ..) into n_blocks = ceil(n / JXF_BLOCK_POINTS) blocks of
 * consecutive entries, every one of JXF_BLOCK_POINTS points but the last (3 x 32 values a
 * row: whole groups of the kernel), writing the block sizes to sizes[0 .. n_blocks). */
static void bisect(const double *points, int *idx, int n, int n_blocks, int *sizes) {
    int left_blocks, left;
    if (n_blocks <= 1) {
        sizes[0] = n;
        return;
    }
    left_blocks = n_blocks / 2;
    left = left_blocks * JXF_BLOCK_POINTS;
    select_first(idx, n, left, points, longest_axis(points, idx, n));
    bisect(points, idx, left, left_blocks, sizes);
    bisect(points, idx + left, n - left, n_blocks - left_blocks, sizes + left_blocks);
}

/* The member of block B nearest the members' mean position. */
static int centre_of(const jxf_model *m, int block) {
    const jxf_blocks *b = &m->blocks;
    double mean[3] = {0.0, 0.0, 0.0}, best = HUGE_VAL;
    int s, c, centre = b->point[b->start[block]];
    for (s = b->start[block]; s < b->start[block + 1]; ++s)
        for (c = 0; c < 3; ++c) mean[c] += m->points[3 * (size_t)b->point[s] + c];
    for (c = 0; c < 3; ++c) mean[c] /= (double)(b->start[block + 1] - b->start[block]);
    for (s = b->start[block]; s < b->start[block + 1]; ++s) {
        const double *p = m->points + 3 * (size_t)b->point[s];
        const double d = (p[0] - mean[0]) * (p[0] - mean[0]) +
                         (p[1] - mean[1]) * (p[1] - mean[1]) + (p[2] - mean[2]) * (p[2] - mean[2]);
        if (d < best) best = d, centre = b->point[s];
    }
    return centre;
}

/* max_p |X_p - X_c| per axis over block B's members of the positions X (K, 3). */
static void spread_of(const jxf_model *m, int block, const double *positions, double out[3]) {
    const jxf_blocks *b = &m->blocks;
    const double *centre = positions + 3 * (size_t)b->centre[block];
    int s, c;
    for (c = 0; c < 3; ++c) out[c] = 0.0;
    for (s = b->start[block]; s < b->start[block + 1]; ++s)
        for (c = 0; c < 3; ++c) {
            const double d = fabs(positions[3 * (size_t)b->point[s] + c] - centre[c]);
            out[c] = d > out[c] ? d : out[c];
        }
}

/* Blocks rearranged together by store_by_block: their rows stay in the cache while every
 * row of the resource is read once per tile of them. */
#define JXF_TILE_BLOCKS 16

/* Copy the shapes (M + R, 3, K) into the block layout, row-major per block, in place
 * (through one copy). */
static int store_by_block(jxf_model *m) {
    const jxf_blocks *b = &m->blocks;
    const size_t K = (size_t)m->n_points, rows = (size_t)(m->n_modes + m->n_static);
    double *shapes = (double *)m->shapes; /* the model's own buffer, read-only after this */
    double *copy = (double *)malloc(3 * rows * K * sizeof(double));
    size_t j;
    int tile, block, s;
    if (copy == NULL) return -1;
    memcpy(copy, shapes, 3 * rows * K * sizeof(double));
    for (tile = 0; tile < b->count; tile += JXF_TILE_BLOCKS) {
        const int last = tile + JXF_TILE_BLOCKS < b->count ? tile + JXF_TILE_BLOCKS : b->count;
        for (j = 0; j < 3 * rows; ++j) {
            const double *row = copy + j * K;
            for (block = tile; block < last; ++block) {
                const int first = b->start[block], size = b->start[block + 1] - first;
                double *out = shapes + 3 * rows * (size_t)first + j * (size_t)size;
                for (s = 0; s < size; ++s) out[s] = row[b->point[first + s]];
            }
        }
    }
    free(copy);
    return 0;
}

/* (A + lambda I)^-1 of the second moment A = sum_p dX_p dX_p^T of the offsets dX (n, 3)
 * (lambda = 1e-9 trace A: a block in a plane, or on a line, has a singular A); zero when
 * the offsets are all zero. Any matrix serves: the fit's residual is measured, not
 * assumed. */
static void moment_inverse(const double *dx, int n, double inverse[9]) {
    double a[9] = {0.0}, lambda, det;
    int s, i, k;
    for (s = 0; s < n; ++s)
        for (i = 0; i < 3; ++i)
            for (k = 0; k < 3; ++k) a[3 * i + k] += dx[3 * s + i] * dx[3 * s + k];
    lambda = 1e-9 * (a[0] + a[4] + a[8]);
    for (i = 0; i < 9; ++i) inverse[i] = 0.0;
    if (!(lambda > 0.0)) return;
    a[0] += lambda, a[4] += lambda, a[8] += lambda;
    inverse[0] = a[4] * a[8] - a[5] * a[7], inverse[1] = a[2] * a[7] - a[1] * a[8];
    inverse[2] = a[1] * a[5] - a[2] * a[4], inverse[3] = a[5] * a[6] - a[3] * a[8];
    inverse[4] = a[0] * a[8] - a[2] * a[6], inverse[5] = a[2] * a[3] - a[0] * a[5];
    inverse[6] = a[3] * a[7] - a[4] * a[6], inverse[7] = a[1] * a[6] - a[0] * a[7];
    inverse[8] = a[0] * a[4] - a[1] * a[3];
    det = a[0] * inverse[0] + a[1] * inverse[3] + a[2] * inverse[6];
    for (i = 0; i < 9; ++i) inverse[i] /= det;
}

/* The bounds of one shape row over a block of n members (jxf_model.h): `row` its values
 * (3, n: x of the members, then y, then z), `dx` the members' offsets from the centre
 * (n, 3), `centre` the centre's slot in the block, `span` the block's spans; writes
 * near (4) and slope (12) and returns the reach. */
static double measure_row(const double *row, const double *dx, int n, int centre,
                          const double inverse[9], const double span[3], double *near,
                          double *slope) {
    const double *x = row, *y = row + n, *z = row + 2 * n;
    const double cx = x[centre], cy = y[centre], cz = z[centre];
    double m0 = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0, m4 = 0.0, m5 = 0.0, m6 = 0.0, m7 = 0.0;
    double m8 = 0.0, reach = 0.0, radius = 0.0, residual = 0.0, l[9];
    int s, c, k;
    for (s = 0; s < n; ++s) { /* sum_p D_p dX_p^T ([3 c + l]), the reach and the radius */
        const double dx0 = dx[3 * s], dx1 = dx[3 * s + 1], dx2 = dx[3 * s + 2];
        const double d0 = x[s] - cx, d1 = y[s] - cy, d2 = z[s] - cz;
        const double size = x[s] * x[s] + y[s] * y[s] + z[s] * z[s];
        const double gap = d0 * d0 + d1 * d1 + d2 * d2;
        m0 += d0 * dx0, m1 += d0 * dx1, m2 += d0 * dx2;
        m3 += d1 * dx0, m4 += d1 * dx1, m5 += d1 * dx2;
        m6 += d2 * dx0, m7 += d2 * dx1, m8 += d2 * dx2;
        reach = size > reach ? size : reach;
        radius = gap > radius ? gap : radius;
    }
    for (k = 0; k < 3; ++k) { /* L[c][k] = (moment . inverse)[c][k], at 3 k + c */
        l[3 * k] = m0 * inverse[k] + m1 * inverse[3 + k] + m2 * inverse[6 + k];
        l[3 * k + 1] = m3 * inverse[k] + m4 * inverse[3 + k] + m5 * inverse[6 + k];
        l[3 * k + 2] = m6 * inverse[k] + m7 * inverse[3 + k] + m8 * inverse[6 + k];
    }
    for (s = 0; s < n; ++s) { /* the fit's largest residual */
        const double dx0 = dx[3 * s], dx1 = dx[3 * s + 1], dx2 = dx[3 * s + 2];
        const double e0 = x[s] - cx - (l[0] * dx0 + l[3] * dx1 + l[6] * dx2);
        const double e1 = y[s] - cy - (l[1] * dx0 + l[4] * dx1 + l[7] * dx2);
        const double e2 = z[s] - cz - (l[2] * dx0 + l[5] * dx1 + l[8] * dx2);
        const double miss = e0 * e0 + e1 * e1 + e2 * e2;
        residual = miss > residual ? miss : residual;
    }
    near[0] = cx, near[1] = cy, near[2] = cz, near[3] = sqrt(radius);
    for (c = 0; c < 9; ++c) slope[c] = l[c];
    slope[9] = sqrt(residual);
    for (slope[10] = 0.0, k = 0; k < 3; ++k)
        slope[10] += sqrt(l[3 * k] * l[3 * k] + l[3 * k + 1] * l[3 * k + 1] +
                          l[3 * k + 2] * l[3 * k + 2]) * span[k];
    slope[11] = 0.0;
    return sqrt(reach);
}

/* Block B's centre, spans and bounds from its shapes (row-major in the block layout), then
 * its shapes grouped for the kernel; `dx`: scratch of 3 largest values, `scratch` of
 * 3 (M + R) largest. */
static void measure(jxf_model *m, int block, double *dx, double *scratch) {
    jxf_blocks *b = &m->blocks;
    const size_t rows = (size_t)(m->n_modes + m->n_static), nB = (size_t)b->count;
    const int first = b->start[block], n = b->start[block + 1] - first;
    double *shapes = (double *)m->shapes + 3 * rows * (size_t)first; /* the model's own */
    const double *centre;
    double inverse[9], reach;
    size_t j;
    int s, l;
    b->centre[block] = centre_of(m, block);
    centre = m->points + 3 * (size_t)b->centre[block];
    spread_of(m, block, m->points, b->span + 3 * (size_t)block);
    if (b->extent != NULL)
        spread_of(m, block, m->turning ? m->points : m->rest_points,
                  b->extent + 3 * (size_t)block);
    for (s = 0; s < n; ++s)
        for (l = 0; l < 3; ++l)
            dx[3 * s + l] = m->points[3 * (size_t)b->point[first + s] + l] - centre[l];
    moment_inverse(dx, n, inverse);
    for (j = 0; j < rows; ++j) {
        reach = measure_row(shapes + 3 * (size_t)n * j, dx, n, b->slot[b->centre[block]] - first,
                            inverse, b->span + 3 * (size_t)block,
                            b->near + 4 * (rows * (size_t)block + j),
                            b->slope + 12 * (rows * (size_t)block + j));
        b->reach[j * nB + (size_t)block] = reach;
        b->top[j] = reach > b->top[j] ? reach : b->top[j];
    }
    jxf_group(shapes, (int)rows, 3 * (size_t)n, scratch); /* while it is in the cache */
}

/* Measure every block (and group its shapes), then group the reaches; -1 when memory runs
 * out. */
static int measure_all(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    const size_t rows = (size_t)(m->n_modes + m->n_static), nB = (size_t)b->count;
    const size_t largest = 3 * rows * (size_t)b->largest;
    double *scratch = (double *)malloc((largest > rows * nB ? largest : rows * nB) *
                                       sizeof(double));
    int block;
    if (scratch == NULL) return -1;
    for (block = 0; block < b->count; ++block)
        measure(m, block, b->work + b->count, scratch); /* dx: a block's displacement scratch */
    jxf_group(b->reach, (int)rows, nB, scratch);
    free(scratch);
    return 0;
}

/* Allocate the blocks' arrays (zeroed) but the scratch; -1 when memory runs out. */
static int allocate(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    const size_t K = (size_t)m->n_points, nB = (size_t)b->count;
    const size_t rows = (size_t)(m->n_modes + m->n_static);
    b->start = (int *)calloc(nB + 1, sizeof(int));
    b->point = (int *)calloc(K, sizeof(int));
    b->slot = (int *)calloc(K, sizeof(int));
    b->centre = (int *)calloc(nB, sizeof(int));
    b->reach = (double *)calloc(rows * nB, sizeof(double));
    b->near = (double *)calloc(4 * rows * nB, sizeof(double));
    b->slope = (double *)calloc(12 * rows * nB, sizeof(double));
    b->span = (double *)calloc(3 * nB, sizeof(double));
    b->top = (double *)calloc(rows, sizeof(double));
    b->stamp = (uint64_t *)calloc(nB, sizeof(uint64_t));
    if (m->n_obstacles > 0 && (b->extent = (double *)calloc(3 * nB, sizeof(double))) == NULL)
        return -1;
    return b->start && b->point && b->slot && b->centre && b->reach && b->near && b->slope &&
                   b->span && b->top && b->stamp
               ? 0
               : -1;
}

/* The scratch of the evaluation (and of the distances), for blocks of `largest` points. */
static int allocate_scratch(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    const size_t nB = (size_t)b->count, L = (size_t)b->largest;
    const size_t rows = (size_t)(m->n_modes + m->n_static);
    b->work = (double *)calloc(nB + 3 * L + rows, sizeof(double));
    if (m->n_obstacles > 0)
        b->cell_work = (double *)calloc(2 * nB + 4 * L + 2 * rows, sizeof(double));
    return b->work != NULL && (m->n_obstacles == 0 || b->cell_work != NULL) ? 0 : -1;
}

int jxf_blocks_build(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    const int K = m->n_points;
    int *sizes, block, s;
    b->count = (K + JXF_BLOCK_POINTS - 1) / JXF_BLOCK_POINTS;
    if (allocate(m) != 0) return -1;
    for (s = 0; s < K; ++s) b->point[s] = s;
    bisect(m->points, b->point, K, b->count, b->start + 1); /* sizes, summed below */
    sizes = b->start + 1;
    for (b->largest = 0, block = 0; block < b->count; ++block) {
        b->largest = sizes[block] > b->largest ? sizes[block] : b->largest;
        sizes[block] += b->start[block];
    }
    for (s = 0; s < K; ++s) b->slot[b->point[s]] = s;
    if (allocate_scratch(m) != 0 || store_by_block(m) != 0) return -1;
    return measure_all(m);
}

void jxf_blocks_free(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    if (b->offered > 0.0)
        jxf_log(m, JXF_LOG_INFO, "the deviation evaluated %.0f of %.0f blocks (%.1f %%; %d "
                "blocks of up to %d points, the others ruled out by their bounds)", b->evaluated,
                b->offered, 100.0 * b->evaluated / b->offered, b->count, b->largest);
    free(b->start);
    free(b->point);
    free(b->slot);
    free(b->centre);
    free(b->reach);
    free(b->near);
    free(b->slope);
    free(b->span);
    free(b->extent);
    free(b->top);
    free(b->stamp);
    free(b->work);
    free(b->cell_work);
    memset(b, 0, sizeof *b);
}

/* ---- the bounds ---------------------------------------------------------------------- */

/* The inflation of a bound so that it bounds the computed norms, not only the exact ones:
 * a computed component of u_p is within gamma_n sum_j |psi_j(p)| |x_j| <= gamma_n top
 * (top = sum_j max_p |psi_j(p)| |x_j|) of the exact one (n = M + R terms, gamma_n =
 * n eps / (1 - n eps); Higham, Accuracy and Stability of Numerical Algorithms, 3.1), its
 * norm within a few eps more; the centre's computed norm likewise, and each computed sum of
 * the bound within gamma_n of itself (a sum of terms of one sign) or of its sum of absolute
 * terms (the gradient's G: its lever). Twice these amounts and the rounding of the bound's
 * own few operations are covered by (M + R + 8) DBL_EPSILON (DBL_EPSILON = 2 eps). */
void jxf_bound_slack(int rows, double *relative, double *absolute) {
    *relative = 1.0 + 2.0 * (rows + 8) * DBL_EPSILON;
    *absolute = 4.0 * (rows + 8) * DBL_EPSILON;
}

double jxf_block_near(const jxf_model *m, int block, const double *x, const double *magnitude,
                      double centre[3]) {
    const int rows = m->n_modes + m->n_static;
    const double *near = m->blocks.near + 4 * (size_t)rows * (size_t)block;
    double spread = 0.0;
    int j;
    centre[0] = centre[1] = centre[2] = 0.0;
    for (j = 0; j < rows; ++j, near += 4) {
        centre[0] += near[0] * x[j];
        centre[1] += near[1] * x[j];
        centre[2] += near[2] * x[j];
        spread += near[3] * magnitude[j];
    }
    return spread;
}

/* The first-order bound of block B: max_p |u_p - u_c| <= sum_l |G_l| span_l + sum_j
 * eps_j |x_j| (module docstring); `lever` gets sum_j lever_j |x_j|, which bounds the
 * rounding of the first term. */
static double block_slope(const jxf_model *m, int block, const double *x,
                          const double *magnitude, double *lever) {
    const int rows = m->n_modes + m->n_static;
    const double *slope = m->blocks.slope + 12 * (size_t)rows * (size_t)block;
    const double *span = m->blocks.span + 3 * (size_t)block;
    double g[9] = {0.0}, residual = 0.0, bound = 0.0;
    int j, k;
    *lever = 0.0;
    for (j = 0; j < rows; ++j, slope += 12) {
        for (k = 0; k < 9; ++k) g[k] += slope[k] * x[j];
        residual += slope[9] * magnitude[j];
        *lever += slope[10] * magnitude[j];
    }
    for (k = 0; k < 3; ++k)
        bound += sqrt(g[3 * k] * g[3 * k] + g[3 * k + 1] * g[3 * k + 1] +
                      g[3 * k + 2] * g[3 * k + 2]) * span[k];
    return bound + residual;
}

/* ---- evaluating ---------------------------------------------------------------------- */

/* Block B's displacement for the current coordinates into its place in m->u; max |u_p|^2
 * of its members (a NaN wins: never hidden). */
static double evaluate(const jxf_model *m, int block) {
    const jxf_blocks *b = &m->blocks;
    double *u = m->u + 3 * (size_t)b->start[block], best = 0.0;
    const int size = jxf_block_combine(m, block, m->coords, u);
    int s;
    for (s = 0; s < size; ++s) {
        const double x = u[s], y = u[size + s], z = u[2 * size + s], sq = x * x + y * y + z * z;
        best = sq > best || sq != sq ? sq : best;
    }
    b->stamp[block] = m->state;
    return best;
}

const double *jxf_block_displacement(const jxf_model *m, int block) {
    if (m->blocks.stamp[block] != m->state) (void)evaluate(m, block);
    return m->u + 3 * (size_t)m->blocks.start[block];
}

void jxf_point_displacement(const jxf_model *m, int k, double u[3]) {
    const int slot = m->blocks.slot[k], block = slot / JXF_BLOCK_POINTS;
    const int first = m->blocks.start[block], size = m->blocks.start[block + 1] - first;
    const double *values = jxf_block_displacement(m, block);
    u[0] = values[slot - first];
    u[1] = values[size + slot - first];
    u[2] = values[2 * size + slot - first];
}

/* 1 if block B may hold a value above `best` (|u|^2) for the coordinates x (their
 * magnitudes |x_j| in `magnitude`): each bound, inflated by the slack (relative, and
 * `absolute` times the sum of absolute terms `top`, jxf_bound_slack), is tried in turn
 * from the cheapest; `reach` is B's first bound. */
static int in_play(const jxf_model *m, int block, const double *x, const double *magnitude,
                   double reach, double best, double top) {
    const int rows = m->n_modes + m->n_static;
    double relative, absolute, centre[3], at_centre, bound, lever;
    jxf_bound_slack(rows, &relative, &absolute);
    bound = reach * relative + absolute * top;
    if (bound * bound <= best) return 0;
    bound = jxf_block_near(m, block, x, magnitude, centre);
    at_centre = sqrt(centre[0] * centre[0] + centre[1] * centre[1] + centre[2] * centre[2]);
    bound = (at_centre + bound) * relative + absolute * top;
    if (bound * bound <= best) return 0;
    bound = block_slope(m, block, x, magnitude, &lever);
    bound = (at_centre + bound) * relative + absolute * (top + lever);
    return !(bound * bound <= best);
}

/* Where the bounds leave most blocks in play (shapes without spatial order: random shapes)
 * trying them costs more than it saves: after an evaluation that evaluated more than half
 * of the blocks, the next JXF_UNBOUNDED_STEPS evaluate every block without trying them
 * (the result is the same either way). */
#define JXF_UNBOUNDED_STEPS 15

double jxf_blocks_deviation(jxf_model *m) {
    jxf_blocks *b = &m->blocks;
    const int rows = m->n_modes + m->n_static, nB = b->count, seed = b->seed;
    const int bounded = JXF_PRUNE && b->unbounded == 0;
    double *reach = b->work, *magnitude = b->work + nB + 3 * (size_t)b->largest;
    double top = 0.0, best = evaluate(m, seed), sq;
    int j, block, evaluated = 1;
    if (b->unbounded > 0) --b->unbounded;
    if (bounded) {
        for (j = 0; j < rows; ++j) {
            magnitude[j] = fabs(m->coords[j]);
            top += b->top[j] * magnitude[j];
        }
        jxf_combine(b->reach, magnitude, rows, (size_t)nB, reach);
    }
    for (block = 0; block < nB; ++block) {
        if (block == seed ||
            (bounded && !in_play(m, block, m->coords, magnitude, reach[block], best, top)))
            continue;
        sq = evaluate(m, block);
        ++evaluated;
        if (sq > best || sq != sq) best = sq, b->seed = block;
    }
    if (bounded && 2 * evaluated > nB) b->unbounded = JXF_UNBOUNDED_STEPS;
    b->offered += nB;
    b->evaluated += evaluated;
    return sqrt(best);
}
