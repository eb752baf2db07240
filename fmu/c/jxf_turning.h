/* The modal forces of the part FMU's inputs, straight or turning (jxf_turning.c). */
#ifndef JXF_TURNING_H
#define JXF_TURNING_H

#include "jxf_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The modal forces `f` (M) of the drive `in` (JXF_IN_COUNT inputs), the acceleration of the
 * model frame's origin `a_body` and gravity `g_body` (body components, m/s^2; zero for a part
 * that does not turn, whose state is measured from its sag), the rotational
 * load coefficients `b` (9: b[3 i + j] = B_ji, B = [alpha]_x + w w^T - |w|^2 I, 1/s^2, as
 * jaxflex._rotation_residual.load_coefficients; zero for a part that does not turn) and
 * the orientation `rotation` (9, row-major, body -> world; the identity for a part that
 * does not turn). 0, or -1 after logging when the orientation quaternion has no direction
 * (zero or not finite). */
int jxf_drive_forces(const jxf_model *m, const double in[JXF_IN_COUNT], double *f,
                     double a_body[3], double g_body[3], double b[9], double rotation[9]);

#ifdef __cplusplus
}
#endif

#endif /* JXF_TURNING_H */
