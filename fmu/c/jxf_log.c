/* Logging of every jaxflex FMU. See jxf_log.h. */
#include "jxf_log.h"

#include <stdio.h>

#include "jxf_text.h"

void jxf_vlogf(const jxf_logger *log, int level, const char *format, va_list args) {
    char message[1024], text[4 * sizeof message];
    if (log == NULL || log->emit == NULL || (level == JXF_LOG_INFO && !log->debug)) return;
    vsnprintf(message, sizeof message, format, args);
    jxf_escape(text, sizeof text, message);
    log->emit(log->context, level, text);
}

void jxf_logf(const jxf_logger *log, int level, const char *format, ...) {
    va_list args;
    va_start(args, format);
    jxf_vlogf(log, level, format, args);
    va_end(args);
}
