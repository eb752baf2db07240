/* Logging of every jaxflex FMU: messages formatted (printf-style), escaped (jxf_text.h) and
 * sent to the logger the FMI binding set up (the importer's callback). The instance
 * (jxf_fmu.c) and the cores (jxf_core.c and the part's modules, jxf_source.c) log through it;
 * it depends on nothing else of the FMU.
 */
#ifndef JXF_LOG_H
#define JXF_LOG_H

#include <stdarg.h>

#ifdef __cplusplus
extern "C" {
#endif

enum { JXF_LOG_INFO = 0, JXF_LOG_WARNING = 1, JXF_LOG_ERROR = 2 };

/* Receives every message (already escaped, see jxf_text.h); level is one of JXF_LOG_*. */
typedef void (*jxf_log_fn)(void *context, int level, const char *message);

typedef struct {
    jxf_log_fn emit;
    void *context;
    int debug; /* pass JXF_LOG_INFO messages too */
} jxf_logger;

/* Format a message (printf-style) and send it to `log` (NULL: dropped). */
void jxf_logf(const jxf_logger *log, int level, const char *format, ...);
void jxf_vlogf(const jxf_logger *log, int level, const char *format, va_list args);

#ifdef __cplusplus
}
#endif

#endif /* JXF_LOG_H */
