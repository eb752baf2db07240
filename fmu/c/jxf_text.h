/* Log text the FMUs hand to their importer: every message passes through jxf_escape, so that
 * bytes from outside (an instantiation token, a resource path, a damaged resource file) reach
 * the importer's log or terminal as text, never as control sequences. Printable ASCII and
 * well-formed UTF-8 (other than the C1 controls U+0080..U+009F) pass unchanged; every other
 * byte is written as \xNN. Used by jxf_log.c, the logging of every FMU (the part and the
 * trajectory source). */
#ifndef JXF_TEXT_H
#define JXF_TEXT_H

#include <stddef.h>

/* Length (2..4) of the well-formed UTF-8 sequence at `s`, or 0. */
static size_t jxf_utf8_length(const unsigned char *s) {
    size_t n, i;
    unsigned long code;
    if (s[0] >= 0xC2 && s[0] <= 0xDF) n = 2, code = s[0] & 0x1Fu;
    else if (s[0] >= 0xE0 && s[0] <= 0xEF) n = 3, code = s[0] & 0x0Fu;
    else if (s[0] >= 0xF0 && s[0] <= 0xF4) n = 4, code = s[0] & 0x07u;
    else return 0;
    for (i = 1; i < n; ++i) {
        if ((s[i] & 0xC0u) != 0x80u) return 0; /* also stops at the terminating NUL */
        code = code << 6 | (s[i] & 0x3Fu);
    }
    if ((n == 3 && (code < 0x800 || (code >= 0xD800 && code <= 0xDFFF))) ||
        (n == 4 && (code < 0x10000 || code > 0x10FFFF)) || (code >= 0x80 && code <= 0x9F))
        return 0; /* overlong, surrogate, beyond Unicode, or a C1 control */
    return n;
}

/* Copy `in` to `out` (`size` bytes, NUL-terminated, truncated if needed) with every byte that
 * is not printable text written as \xNN. */
static void jxf_escape(char *out, size_t size, const char *in) {
    static const char hex[] = "0123456789abcdef";
    const unsigned char *s = (const unsigned char *)in;
    size_t used = 0;
    while (*s && used + 1 < size) {
        size_t n = *s >= 0x20 && *s < 0x7F ? 1 : jxf_utf8_length(s);
        if (n == 0) {
            if (used + 5 > size) break;
            out[used++] = '\\';
            out[used++] = 'x';
            out[used++] = hex[*s >> 4];
            out[used++] = hex[*s & 0xFu];
            ++s;
            continue;
        }
        if (used + n + 1 > size) break;
        while (n--) out[used++] = (char)*s++;
    }
    out[used] = '\0';
}

#endif /* JXF_TEXT_H */
