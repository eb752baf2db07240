/* The cell's outputs of the part FMU at the communication point (jxf_cell.c), read from
 * the part's state (jxf_model.h). SI units. */
#ifndef JXF_CELL_H
#define JXF_CELL_H

#include "jxf_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Utilisation of cup c, von Mises stress at stress point s (Pa). */
double jxf_cup_utilisation(const jxf_model *m, int c);
/* The reaction `y` (6: force N, moment about the cup centre N m; the part's frame) of cup c
 * on the part. */
void jxf_cup_reaction(const jxf_model *m, int c, double y[6]);
double jxf_von_mises(const jxf_model *m, int s);
/* The distance of every point to the nearest obstacle into out (K), m. */
void jxf_point_distances(const jxf_model *m, double *out);
/* The smallest distance of a point to an obstacle, m: that of jxf_point_distances, over the
 * blocks (jxf_blocks.h) whose lower bound can undercut the smallest found. */
double jxf_min_distance(const jxf_model *m);
/* 0 if every obstacle record has a kind of the table (fmu/obstacles.py), else -1 after
 * logging the first that has not (`name`: the resource file, for the message). */
int jxf_check_obstacles(const jxf_model *m, const char *name);

#ifdef __cplusplus
}
#endif

#endif /* JXF_CELL_H */
