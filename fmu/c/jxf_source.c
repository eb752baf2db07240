/* Trajectory source FMU core: samples, interpolation, life cycle. See jxf_source.h. */
#include "jxf_source.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "jxf_text.h"

/* JXF_SOURCE_FMI_VERSION, JXF_SOURCE_TOKEN, JXF_SOURCE_N (>= 2 samples), JXF_SOURCE_DT (s) and
 * jxf_source_samples[3 * JXF_SOURCE_N] (m/s^2, sample after sample) */
#include "jxf_source_data.h"

/* Communication points closer than this fraction of the sample step to a sample time count
 * as that sample time. */
#define JXF_SOURCE_SNAP 1e-9

void jxf_source_log(const jxf_source *s, int level, const char *format, ...) {
    char message[1024], text[4 * sizeof message];
    va_list args;
    if (s == NULL || s->log == NULL || (level == JXF_SOURCE_INFO && !s->debug)) return;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    jxf_escape(text, sizeof text, message);
    s->log(s->log_context, level, text);
}

int jxf_source_init(jxf_source *s, const char *token, jxf_source_log_fn log, void *log_context,
                    int debug) {
    memset(s, 0, sizeof *s);
    s->log = log;
    s->log_context = log_context;
    s->debug = debug;
    s->state = JXF_SOURCE_INSTANTIATED;
    if (token == NULL || strcmp(token, JXF_SOURCE_TOKEN) != 0) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "instantiation token / GUID '%s' does not match this "
                       "FMU (%s)", token ? token : "(null)", JXF_SOURCE_TOKEN);
        return -1;
    }
    jxf_source_log(s, JXF_SOURCE_INFO, "trajectory source: %d samples every %g s",
                   JXF_SOURCE_N, JXF_SOURCE_DT);
    return 0;
}

int jxf_source_allowed(jxf_source *s, const char *function, int states) {
    if (s == NULL) return 0;
    if (s->state & states) return 1;
    jxf_source_log(s, JXF_SOURCE_ERROR, "%s is not allowed in the current state", function);
    return 0;
}

int jxf_source_unsupported(jxf_source *s, const char *function) {
    jxf_source_log(s, JXF_SOURCE_ERROR, "%s is not supported by this FMU", function);
    return -1;
}

int jxf_source_set_logging(jxf_source *s, const char *function, int on) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_ANY_STATE)) return -1;
    s->debug = on;
    return 0;
}

int jxf_source_setup(jxf_source *s, const char *function, double start_time) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_INSTANTIATED)) return -1;
    if (!isfinite(start_time)) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "%s: start time must be finite", function);
        return -1;
    }
    s->start_time = s->time = start_time;
    return 0;
}

int jxf_source_enter_initialization(jxf_source *s, const char *function) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_INSTANTIATED)) return -1;
    s->state = JXF_SOURCE_INITIALIZATION;
    return 0;
}

int jxf_source_exit_initialization(jxf_source *s, const char *function) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_INITIALIZATION)) return -1;
    s->state = JXF_SOURCE_STEP;
    return 0;
}

int jxf_source_terminate(jxf_source *s, const char *function) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_STEP)) return -1;
    s->state = JXF_SOURCE_TERMINATED;
    return 0;
}

int jxf_source_reset(jxf_source *s, const char *function) {
    if (!jxf_source_allowed(s, function, JXF_SOURCE_ANY_STATE)) return -1;
    s->state = JXF_SOURCE_INSTANTIATED;
    s->start_time = s->time = 0.0;
    return 0;
}

/* Value and slope of axis `c` at `tau` s after the start (0 before it and after the last
 * sample; the slope is that of the segment beginning at `tau`). */
static void sample(double tau, int c, double *value, double *rate) {
    const double x = tau / JXF_SOURCE_DT, nearest = floor(x + 0.5);
    const int snapped = fabs(x - nearest) <= JXF_SOURCE_SNAP;
    const double k = snapped ? nearest : floor(x);
    const double *a;
    *value = *rate = 0.0;
    if (k < 0.0 || k > (double)(JXF_SOURCE_N - 1) || (!snapped && k == JXF_SOURCE_N - 1)) return;
    a = jxf_source_samples + 3 * (long)k;
    if (k == JXF_SOURCE_N - 1) {
        *value = a[c];
        return;
    }
    *rate = (a[3 + c] - a[c]) / JXF_SOURCE_DT;
    *value = snapped ? a[c] : a[c] + (x - k) * (a[3 + c] - a[c]);
}

int jxf_source_get(const jxf_source *s, unsigned vr, int order, double *value) {
    double v, r;
    if (JXF_SOURCE_FMI_VERSION == 3 && vr == JXF_SOURCE_VR_TIME && order == 0) {
        *value = s->time;
        return 0;
    }
    if (vr < JXF_SOURCE_VR_AX || vr > JXF_SOURCE_VR_AX + 2) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "no Real variable with value reference %u", vr);
        return -1;
    }
    if (order != 0 && order != 1) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "derivative order %d of value reference %u: only "
                       "the first derivative is provided (maxOutputDerivativeOrder = 1)", order,
                       vr);
        return -1;
    }
    sample(s->time - s->start_time, (int)(vr - JXF_SOURCE_VR_AX), &v, &r);
    *value = order == 0 ? v : r;
    return 0;
}

int jxf_source_do_step(jxf_source *s, double t, double h) {
    const double end = t + h;
    if (!(isfinite(h) && h > 0.0) || !isfinite(t) || !isfinite(end)) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "doStep(currentCommunicationPoint = %g s, step = %g "
                       "s): the step must be a finite number > 0 ending at a finite time; state "
                       "unchanged", t, h);
        return -1;
    }
    if (!(end > t)) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "doStep(currentCommunicationPoint = %.17g s, step = "
                       "%g s): the step is below the resolution of the time in double "
                       "precision, so the time would not advance; state unchanged", t, h);
        return -1;
    }
    if (fabs(t - s->time) > 1e-9 * (fabs(t) + h)) {
        jxf_source_log(s, JXF_SOURCE_WARNING, "doStep: currentCommunicationPoint %.17g s differs "
                       "from the end of the previous step %.17g s; continuing from %.17g s", t,
                       s->time, t);
    }
    s->time = end;
    return 0;
}
