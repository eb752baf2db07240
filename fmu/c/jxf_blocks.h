/* The part FMU's monitored points in blocks with a bound per block (jxf_blocks.c): the
 * outputs over every point (the deviation here, the distance to the obstacles in jxf_cell.c)
 * evaluate only the blocks that can decide them and equal the evaluation of every point.
 * SI units: m, and the shapes' m per coordinate unit. */
#ifndef JXF_BLOCKS_H
#define JXF_BLOCKS_H

#include <stddef.h>

#include "jxf_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Built with -DJXF_EVERY_POINT the outputs over the points prune nothing: the evaluation of
 * every point, which the tests compare the pruned one with. */
#ifdef JXF_EVERY_POINT
#define JXF_PRUNE 0
#else
#define JXF_PRUNE 1
#endif

/* Order the points into blocks, store the shapes block by block (m->shapes) and compute the
 * blocks' centres and radii (and, with obstacles, the extents of their rest positions).
 * 0, or -1 when memory runs out (nothing logged). */
int jxf_blocks_build(jxf_model *m);
void jxf_blocks_free(jxf_model *m);

/* out[k] = sum_r psi_r[k] x[r] for the `n_rows` rows of `n` values psi_r in the grouped
 * layout of jxf_group: the displacement of the points of a block (n = 3 n_B, x of its
 * members, then y, then z) or the blocks' bounds of it (n = nB). */
void jxf_combine(const double *data, const double *x, int n_rows, size_t n, double *out);

/* Rewrite `data`, (n_rows, n) row-major, in place into the grouped layout jxf_combine reads
 * (`scratch`: n_rows n values). */
void jxf_group(double *data, int n_rows, size_t n, double *scratch);

/* The displacement of block B's members for the coordinates x (M + R) into out (3 n_B:
 * x of its members in slot order, then y, then z); its size n_B is returned. */
int jxf_block_combine(const jxf_model *m, int block, const double *x, double *out);

/* max_p |u_p| (m) for the current coordinates m->coords: only the blocks whose bounds can
 * exceed the largest value found are evaluated (every block when built with
 * -DJXF_EVERY_POINT); the evaluated blocks' displacements are kept (jxf_block_displacement),
 * the block of the largest value becomes the next evaluation's first. */
double jxf_blocks_deviation(jxf_model *m);

/* The slack of a bound of the points' computed displacement (a bound B of the exact one
 * becomes B relative + absolute top, top = sum_j max_p |psi_j(p)| |x_j|), for M + R =
 * `rows` shape rows. */
void jxf_bound_slack(int rows, double *relative, double *absolute);

/* Block B's centre displacement `centre` (3) for the coordinates x and the bound
 * sum_j rho_Bj |x_j| of max_p |u_p - u_c| it returns (`magnitude`: |x_j|). */
double jxf_block_near(const jxf_model *m, int block, const double *x, const double *magnitude,
                      double centre[3]);

/* Block B's members' displacement for the current state (3 n_B: x of its members in slot
 * order, then y, then z; its place in m->u), evaluated now if the step left it out. */
const double *jxf_block_displacement(const jxf_model *m, int block);

/* The displacement u (3, m) of point k for the current state (its block evaluated now if the
 * step left it out). */
void jxf_point_displacement(const jxf_model *m, int k, double u[3]);

#ifdef __cplusplus
}
#endif

#endif /* JXF_BLOCKS_H */
