/* jaxflex part FMU core: resource loading, exact modal step, outputs; the part's
 * implementation of the core interface jxf_model_* (jxf_fmu.h). The recursion and the state
 * are described in jxf_model.h. */
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "jxf_blocks.h"
#include "jxf_cell.h"
#include "jxf_config.h"
#include "jxf_fmu.h"
#include "jxf_model.h"
#include "jxf_turn_angle.h"
#include "jxf_turning.h"

#define JXF_PI 3.14159265358979323846

/* Resource file, format version 3, little-endian throughout:
 *   0   char[8]  magic "JXFLXFMU"
 *   8   u32      format version (3)
 *   12  u32      header size in bytes (128)
 *   16  char[64] instantiation token, NUL padded
 *   80  u32      K points, 84 u32 M modes, 88 u32 N trajectory samples, 92 u32 C cups
 *   96  f64      trajectory sample step in s (0 without a trajectory)
 *   104 u64      payload size in bytes
 *   112 u32      S stress points, 116 u32 O obstacle records, 120 u32 R static-residual
 *                coordinates (0, 3, or 12 turning), 124 u32 T turning (0 or 1)
 *   128 payload of f64: freq_hz (M), zeta (M), gamma (M, 3), shapes (M + R, 3, K: the
 *                       last R rows the static residual, driven by the base acceleration
 *                       and, R = 12, by the rotational load coefficients b),
 *                       points (K, 3), trajectory (N, 3), then, if C + S + O > 0:
 *                       gravity (3), cup safety factor (1), half thickness (1); cups:
 *                       normals (C, 3), radii (C), holding forces (C), friction (C),
 *                       Q (6C, M), V (6C, M), A (6C, 3), at rest (6C); stresses: Q (6S, M),
 *                       V (6S, M), A (6S, 3), at rest (6S); obstacles: points at rest (K, 3),
 *                       records (O, 16: fmu/obstacles.py, jxf_cell.c); then, if T = 1:
 *                       inertia shape integrals (M, 3, 3), pivot (3), world gravity (3),
 *                       the trajectory's poses (N, 10: quaternion body -> world w, x, y, z,
 *                       angular velocity 3, angular acceleration 3; body components), the
 *                       maps of the rotational loads A_rot of the cups (6C, 9) and of the
 *                       stresses (6S, 9)
 *   end u32 CRC-32 (IEEE, as zlib) of everything before it, u32 0
 * fmu/resource.py writes the same layout. */
#define JXF_MAGIC "JXFLXFMU"
#define JXF_FORMAT_VERSION 3u
#define JXF_HEADER_BYTES 128u
#define JXF_TOKEN_BYTES 64u
#define JXF_TRAILER_BYTES 8u

/* Series below this value of omega * h (as jaxflex._discretize). */
#define JXF_SERIES_LIMIT 0.1
#define JXF_SERIES_TERMS 16
/* Two step lengths within this relative distance share their coefficients. */
#define JXF_STEP_RTOL 1e-12
/* Trajectory breakpoints closer than this fraction of the sample step count as reached. */
#define JXF_SNAP 1e-9
/* the trajectory's sample step, s, as fmu.resource.TRAJECTORY_STEP_RANGE_S: steps outside
 * cannot be replayed against the FMU's time (5e-324 s: every time is past the end; 1e300 s:
 * the move never leaves its first sample) */
#define JXF_TRAJ_DT_MIN 1e-6
#define JXF_TRAJ_DT_MAX 1e3
/* Modal states below this magnitude are set to 0: a decaying high mode would otherwise reach
 * the subnormal range (after ~1400 free 10 ms steps at 400 Hz, zeta 0.02), where every
 * multiplication costs ~100x. 1e-250 kg^0.5 m is far below anything measurable. */
#define JXF_TINY 1e-250

/* ---- little-endian decoding and CRC-32 ----------------------------------------------- */

static uint32_t read_u32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t read_u64(const unsigned char *p) {
    return (uint64_t)read_u32(p) | (uint64_t)read_u32(p + 4) << 32;
}

static double read_f64(const unsigned char *p) {
    uint64_t bits = read_u64(p);
    double x;
    memcpy(&x, &bits, sizeof x);
    return x;
}

/* CRC-32 with the reflected polynomial 0xEDB88320, slicing by 8 bytes. */
static uint32_t crc32_bytes(const unsigned char *p, size_t n) {
    uint32_t table[8][256];
    uint32_t c;
    int i, k;
    for (i = 0; i < 256; ++i) {
        c = (uint32_t)i;
        for (k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[0][i] = c;
    }
    for (i = 0; i < 256; ++i)
        for (k = 1; k < 8; ++k)
            table[k][i] = (table[k - 1][i] >> 8) ^ table[0][table[k - 1][i] & 0xFFu];
    c = 0xFFFFFFFFu;
    while (n >= 8) {
        uint32_t a = c ^ read_u32(p), b = read_u32(p + 4);
        c = table[7][a & 0xFFu] ^ table[6][(a >> 8) & 0xFFu] ^ table[5][(a >> 16) & 0xFFu] ^
            table[4][a >> 24] ^ table[3][b & 0xFFu] ^ table[2][(b >> 8) & 0xFFu] ^
            table[1][(b >> 16) & 0xFFu] ^ table[0][b >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) c = table[0][(c ^ *p++) & 0xFFu] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

/* ---- resource location -> file name ------------------------------------------------- */

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* `location` is a file URI (file:///dir/, file:/dir/, file://localhost/dir/, percent-encoded;
 * FMI 2.0) or a plain directory path (FMI 3.0). Returns a malloc'ed file name or NULL. */
static char *resource_file(const jxf_model *m, const char *location) {
    const char *path = location;
    size_t n, len = 0;
    char *out;
    int is_uri = 0;
    if (location == NULL || location[0] == '\0') {
        jxf_log(m, JXF_LOG_ERROR,
                "no resource location given: the importer must pass the FMU's resources "
                "directory so that %s can be read", JXF_RESOURCE_FILE);
        return NULL;
    }
    if (strncmp(location, "file:", 5) == 0) {
        is_uri = 1;
        path = location + 5;
        if (strncmp(path, "//", 2) == 0) {
            const char *host = path + 2, *slash = strchr(host, '/');
            size_t host_len = slash ? (size_t)(slash - host) : strlen(host);
            if (host_len != 0 && !(host_len == 9 && strncmp(host, "localhost", 9) == 0)) {
                jxf_log(m, JXF_LOG_ERROR,
                        "resource location '%s': only local files are supported (host '%.*s')",
                        location, (int)host_len, host);
                return NULL;
            }
            path = slash ? slash : host + host_len;
        }
    } else if (strstr(location, "://") != NULL) {
        jxf_log(m, JXF_LOG_ERROR,
                "resource location '%s': unsupported URI scheme (expected file: or a path)",
                location);
        return NULL;
    }
    n = strlen(path);
    out = (char *)malloc(n + strlen(JXF_RESOURCE_FILE) + 2);
    if (out == NULL) {
        jxf_log(m, JXF_LOG_ERROR, "out of memory while reading the resource location");
        return NULL;
    }
    while (*path) {
        if (is_uri && *path == '%') {
            int hi = hex_value(path[1]), lo = hi < 0 ? -1 : hex_value(path[2]);
            if (hi < 0 || lo < 0) {
                jxf_log(m, JXF_LOG_ERROR,
                        "resource location '%s': malformed percent-encoding", location);
                free(out);
                return NULL;
            }
            out[len++] = (char)(hi * 16 + lo);
            path += 3;
        } else {
            out[len++] = *path++;
        }
    }
    out[len] = '\0';
#ifdef _WIN32
    /* file:///C:/dir -> C:/dir */
    if (is_uri && len >= 3 && out[0] == '/' && out[2] == ':') {
        memmove(out, out + 1, len);
        --len;
    }
    if (len > 0 && out[len - 1] != '/' && out[len - 1] != '\\') out[len++] = '/';
#else
    if (len > 0 && out[len - 1] != '/') out[len++] = '/';
#endif
    strcpy(out + len, JXF_RESOURCE_FILE);
    return out;
}

/* ---- loading ------------------------------------------------------------------------ */

/* Number of f64 values in the payload (layout above). */
static uint64_t payload_values(uint64_t K, uint64_t M, uint64_t N, uint64_t C, uint64_t S,
                               uint64_t O, uint64_t R, uint64_t T) {
    uint64_t count = 5u * M + 3u * (M + R) * K + 3u * K + 3u * N;
    if (C + S + O > 0) count += 5u;
    if (C > 0) count += 6u * C + 12u * C * M + 24u * C;
    if (S > 0) count += 12u * S * M + 24u * S;
    if (O > 0) count += 3u * K + (uint64_t)JXF_OBSTACLE_VALUES * O;
    if (T > 0) count += 9u * M + 6u + (uint64_t)JXF_POSE_VALUES * N + 54u * (C + S);
    return count;
}

/* Bytes of this build's resource file (its sizes are compiled in, jxf_config.h). */
static size_t resource_bytes(void) {
    return JXF_HEADER_BYTES + JXF_TRAILER_BYTES +
           8 * (size_t)payload_values(JXF_N_POINTS, JXF_N_MODES, JXF_N_TRAJ, JXF_N_CUPS,
                                      JXF_N_STRESS, JXF_N_OBSTACLES, JXF_N_STATIC,
                                      JXF_TURNING);
}

/* Read the resource file; never allocates more than this build's resource size, so a
 * padded or foreign file (or a directory) costs nothing. */
static unsigned char *read_file(const jxf_model *m, const char *name, size_t *size) {
    const size_t expected = resource_bytes();
    FILE *file = fopen(name, "rb");
    unsigned char *data;
    long end;
    if (file == NULL) {
        jxf_log(m, JXF_LOG_ERROR, "cannot open the resource file '%s' (missing or unreadable)",
                name);
        return NULL;
    }
    data = (unsigned char *)malloc(expected);
    if (data == NULL) {
        jxf_log(m, JXF_LOG_ERROR, "out of memory reading '%s' (%lu bytes)", name,
                (unsigned long)expected);
        fclose(file);
        return NULL;
    }
    /* a directory opens on some systems but cannot be read: try one byte first */
    if (fread(data, 1, 1, file) != 1 && ferror(file)) {
        jxf_log(m, JXF_LOG_ERROR, "the resource '%s' is not a readable file (a directory?)",
                name);
        free(data);
        fclose(file);
        return NULL;
    }
    if (fseek(file, 0, SEEK_END) != 0 || (end = ftell(file)) < 0 || fseek(file, 0, SEEK_SET)) {
        jxf_log(m, JXF_LOG_ERROR, "cannot determine the size of the resource file '%s'", name);
        free(data);
        fclose(file);
        return NULL;
    }
    if ((unsigned long)end > expected) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' is padded or belongs to another FMU: %ld bytes, this "
                "FMU's resource has %lu", name, end, (unsigned long)expected);
        free(data);
        fclose(file);
        return NULL;
    }
    if (fread(data, 1, (size_t)end, file) != (size_t)end) {
        jxf_log(m, JXF_LOG_ERROR, "cannot read the resource file '%s'", name);
        free(data);
        fclose(file);
        return NULL;
    }
    fclose(file);
    *size = (size_t)end;
    return data;
}

static int check_header(const jxf_model *m, const char *name, const unsigned char *data,
                        size_t size, const char *token) {
    char stored[JXF_TOKEN_BYTES + 1];
    uint32_t n_points, n_modes, n_traj, n_cups, n_stress, n_obstacles, n_static, turning;
    uint64_t payload, expected;
    if (size < JXF_HEADER_BYTES + JXF_TRAILER_BYTES || memcmp(data, JXF_MAGIC, 8) != 0) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' is not a jaxflex FMU resource (bad magic or too short, "
                "%lu bytes)", name, (unsigned long)size);
        return -1;
    }
    if (read_u32(data + 8) != JXF_FORMAT_VERSION) {
        jxf_log(m, JXF_LOG_ERROR, "'%s': resource format version %lu is not supported (this "
                "binary reads version %u); export the FMU again",
                name, (unsigned long)read_u32(data + 8), JXF_FORMAT_VERSION);
        return -1;
    }
    if (read_u32(data + 12) != JXF_HEADER_BYTES) {
        jxf_log(m, JXF_LOG_ERROR, "'%s': header size field says %lu bytes, version %u has %u; "
                "the file is damaged", name, (unsigned long)read_u32(data + 12),
                JXF_FORMAT_VERSION, JXF_HEADER_BYTES);
        return -1;
    }
    memcpy(stored, data + 16, JXF_TOKEN_BYTES);
    stored[JXF_TOKEN_BYTES] = '\0';
    if (strcmp(stored, JXF_TOKEN) != 0) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' belongs to another FMU (token %s, expected %s)", name,
                stored, JXF_TOKEN);
        return -1;
    }
    if (token == NULL || strcmp(token, JXF_TOKEN) != 0) {
        jxf_log(m, JXF_LOG_ERROR, "instantiation token / GUID '%s' does not match this FMU (%s)",
                token ? token : "(null)", JXF_TOKEN);
        return -1;
    }
    n_points = read_u32(data + 80);
    n_modes = read_u32(data + 84);
    n_traj = read_u32(data + 88);
    n_cups = read_u32(data + 92);
    n_stress = read_u32(data + 112);
    n_obstacles = read_u32(data + 116);
    n_static = read_u32(data + 120);
    turning = read_u32(data + 124);
    if (n_points != JXF_N_POINTS || n_modes != JXF_N_MODES || n_traj != JXF_N_TRAJ ||
        n_cups != JXF_N_CUPS || n_stress != JXF_N_STRESS || n_obstacles != JXF_N_OBSTACLES ||
        n_static != JXF_N_STATIC || turning != JXF_TURNING) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' holds %lu points, %lu modes, %lu trajectory samples, "
                "%lu cups, %lu stress points, %lu obstacle records, %lu static-residual "
                "coordinates, turning %lu but modelDescription.xml declares %d, %d, %d, %d, %d, "
                "%d, %d, %d", name, (unsigned long)n_points, (unsigned long)n_modes,
                (unsigned long)n_traj, (unsigned long)n_cups, (unsigned long)n_stress,
                (unsigned long)n_obstacles, (unsigned long)n_static, (unsigned long)turning,
                JXF_N_POINTS, JXF_N_MODES, JXF_N_TRAJ, JXF_N_CUPS, JXF_N_STRESS,
                JXF_N_OBSTACLES, JXF_N_STATIC, JXF_TURNING);
        return -1;
    }
    expected = 8u * payload_values(n_points, n_modes, n_traj, n_cups, n_stress, n_obstacles,
                                   n_static, turning);
    payload = read_u64(data + 104);
    if (payload != expected) {
        jxf_log(m, JXF_LOG_ERROR, "'%s': the header's payload size field says %lu bytes, the "
                "declared sizes need %lu; the file is damaged", name, (unsigned long)payload,
                (unsigned long)expected);
        return -1;
    }
    if (size != JXF_HEADER_BYTES + expected + JXF_TRAILER_BYTES) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' is truncated or padded: %lu bytes, expected %lu", name,
                (unsigned long)size,
                (unsigned long)(JXF_HEADER_BYTES + expected + JXF_TRAILER_BYTES));
        return -1;
    }
    if (crc32_bytes(data, size - JXF_TRAILER_BYTES) != read_u32(data + size - 8)) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' is corrupt (CRC-32 mismatch)", name);
        return -1;
    }
    return 0;
}

static int all_finite(const double *x, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* 1 if every value of `x` lies in [low, high] (the physical ranges of jaxflex._model_file,
 * compiled in as JXF_RANGE_*), else 0 after logging the first one outside. */
static int in_range(const jxf_model *m, const char *name, const char *what, const double *x,
                    size_t n, double low, double high) {
    size_t i;
    for (i = 0; i < n; ++i) {
        if (!(x[i] >= low && x[i] <= high)) {
            jxf_log(m, JXF_LOG_ERROR, "'%s': %s %g (value %lu) is outside the physical range "
                    "[%g, %g]", name, what, x[i], (unsigned long)i, low, high);
            return 0;
        }
    }
    return 1;
}

/* Point the model's arrays into the payload (converted to host order) and check values. */
static int attach_payload(jxf_model *m, const char *name, unsigned char *data) {
    const uint16_t probe = 1;
    const int K = JXF_N_POINTS, M = JXF_N_MODES, N = JXF_N_TRAJ, R = JXF_N_STATIC;
    const int C = JXF_N_CUPS, S = JXF_N_STRESS, O = JXF_N_OBSTACLES, T = JXF_TURNING;
    const size_t count = (size_t)payload_values(K, M, N, C, S, O, R, T);
    double *values = (double *)(void *)(data + JXF_HEADER_BYTES);
    const double *next;
    size_t i;
    int mode;
    if (*(const unsigned char *)&probe != 1) /* big-endian host: decode in place */
        for (i = 0; i < count; ++i) values[i] = read_f64(data + JXF_HEADER_BYTES + 8 * i);
    m->n_points = K;
    m->n_modes = M;
    m->n_static = R;
    m->n_traj = N;
    m->traj_dt = read_f64(data + 96);
    m->freq_hz = values;
    m->zeta = m->freq_hz + M;
    m->gamma = m->zeta + M;
    m->shapes = m->gamma + 3 * M;
    m->points = m->shapes + 3 * (size_t)(M + R) * K;
    m->traj = m->points + 3 * (size_t)K;
    m->n_cups = C;
    m->n_stress = S;
    m->n_obstacles = O;
    next = m->traj + 3 * (size_t)N;
    if (C + S + O > 0) {
        m->gravity = next;
        m->cup_safety = next[3];
        m->half_thickness = next[4];
        next += 5;
    }
    if (C > 0) {
        m->cup_normal = next;
        m->cup_radius = m->cup_normal + 3 * (size_t)C;
        m->cup_holding = m->cup_radius + C;
        m->cup_friction = m->cup_holding + C;
        m->cup_q = m->cup_friction + C;
        m->cup_v = m->cup_q + 6 * (size_t)C * M;
        m->cup_a = m->cup_v + 6 * (size_t)C * M;
        m->cup_rest = m->cup_a + 18 * (size_t)C;
        next = m->cup_rest + 6 * (size_t)C;
    }
    if (S > 0) {
        m->stress_q = next;
        m->stress_v = m->stress_q + 6 * (size_t)S * M;
        m->stress_a = m->stress_v + 6 * (size_t)S * M;
        m->stress_rest = m->stress_a + 18 * (size_t)S;
        next = m->stress_rest + 6 * (size_t)S;
    }
    if (O > 0) {
        m->rest_points = next;
        m->obstacles = m->rest_points + 3 * (size_t)K;
        next = m->obstacles + (size_t)JXF_OBSTACLE_VALUES * O;
    }
    m->turning = T;
    if (T > 0) {
        m->shape_integrals = next;
        m->pivot = m->shape_integrals + 9 * (size_t)M;
        m->world_gravity = m->pivot + 3;
        m->traj_pose = m->world_gravity + 3;
        m->cup_rot = m->traj_pose + (size_t)JXF_POSE_VALUES * N;
        m->stress_rot = m->cup_rot + 54 * (size_t)C;
    }
    if (!all_finite(values, count)) {
        jxf_log(m, JXF_LOG_ERROR, "'%s' contains NaN or infinite values", name);
        return -1;
    }
    if (!in_range(m, name, "frequency (Hz)", m->freq_hz, M, JXF_RANGE_FREQ_HZ) ||
        !in_range(m, name, "participation factor", m->gamma, 3 * (size_t)M, JXF_RANGE_GAMMA) ||
        !in_range(m, name, "mode shape value", m->shapes, 3 * (size_t)(M + R) * K,
                  JXF_RANGE_SHAPES) ||
        !in_range(m, name, "point coordinate", m->points, 3 * (size_t)K, JXF_RANGE_POINTS) ||
        jxf_check_obstacles(m, name) != 0)
        return -1;
    for (mode = 0; mode < M; ++mode) {
        if (!(m->zeta[mode] >= 0.0 && m->zeta[mode] < 1.0)) {
            jxf_log(m, JXF_LOG_ERROR, "'%s': mode %d has damping ratio %g (need 0 <= zeta < 1)",
                    name, mode, m->zeta[mode]);
            return -1;
        }
    }
    if (N == 0 && m->traj_dt != 0.0) {
        jxf_log(m, JXF_LOG_ERROR, "'%s': no trajectory but a sample step of %g s (need 0)",
                name, m->traj_dt);
        return -1;
    }
    for (i = 0; T > 0 && i < (size_t)N; ++i) {
        const double *quat = m->traj_pose + JXF_POSE_VALUES * i;
        if (!(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3] >
              0.0)) {
            jxf_log(m, JXF_LOG_ERROR, "'%s': the orientation quaternion of trajectory sample %lu "
                    "is zero (it has no direction)", name, (unsigned long)i);
            return -1;
        }
    }
    if (N > 0 && !(N >= 2 && m->traj_dt >= JXF_TRAJ_DT_MIN && m->traj_dt <= JXF_TRAJ_DT_MAX)) {
        jxf_log(m, JXF_LOG_ERROR, "'%s': trajectory of %d samples with step %g s (need >= 2 "
                "samples and a step of %g ... %g s)", name, N, m->traj_dt, JXF_TRAJ_DT_MIN,
                JXF_TRAJ_DT_MAX);
        return -1;
    }
    return 0;
}

static int allocate_work(jxf_model *m) {
    const size_t M = (size_t)m->n_modes;
    int s;
    m->q = (double *)calloc(7 * M, sizeof(double));
    m->u = (double *)calloc(3 * (size_t)m->n_points, sizeof(double));
    m->coords = (double *)calloc(M + (size_t)m->n_static, sizeof(double));
    if (m->q == NULL || m->u == NULL || m->coords == NULL) return -1;
    m->saved = m->q + 2 * M;
    m->v = m->q + M;
    m->f0 = m->q + 4 * M;
    m->f1 = m->q + 5 * M;
    m->f_next = m->q + 6 * M;
    for (s = 0; s < JXF_CACHE_SLOTS; ++s) {
        jxf_coeffs *c = &m->cache[s];
        c->p11 = (double *)calloc(8 * M, sizeof(double));
        if (c->p11 == NULL) return -1;
        c->p12 = c->p11 + M;
        c->p21 = c->p12 + M;
        c->p22 = c->p21 + M;
        c->g0q = c->p22 + M;
        c->g0v = c->g0q + M;
        c->g1q = c->g0v + M;
        c->g1v = c->g1q + M;
    }
    return 0;
}

static void restart(jxf_model *m);

jxf_model *jxf_model_create(const char *resource_location, const char *token,
                            const jxf_logger *log) {
    jxf_model *m = (jxf_model *)calloc(1, sizeof(jxf_model));
    char *name;
    size_t size = 0;
    if (m == NULL) {
        jxf_logf(log, JXF_LOG_ERROR, "out of memory creating the instance");
        return NULL;
    }
    m->log = log;
    name = resource_file(m, resource_location);
    if (name == NULL) {
        jxf_model_free(m);
        return NULL;
    }
    m->buffer = read_file(m, name, &size);
    if (m->buffer == NULL || check_header(m, name, m->buffer, size, token) != 0 ||
        attach_payload(m, name, m->buffer) != 0) {
        free(name);
        jxf_model_free(m);
        return NULL;
    }
    if (allocate_work(m) != 0 || jxf_blocks_build(m) != 0) {
        jxf_log(m, JXF_LOG_ERROR, "out of memory allocating the state of %d modes, %d points",
                m->n_modes, m->n_points);
        free(name);
        jxf_model_free(m);
        return NULL;
    }
    jxf_log(m, JXF_LOG_INFO, "loaded '%s': %d points, %d modes, %d trajectory samples", name,
            m->n_points, m->n_modes, m->n_traj);
    free(name);
    restart(m);
    return m;
}

void jxf_model_free(jxf_model *m) {
    int s;
    if (m == NULL) return;
    for (s = 0; s < JXF_CACHE_SLOTS; ++s) free(m->cache[s].p11);
    jxf_blocks_free(m);
    free(m->q);
    free(m->u);
    free(m->coords);
    free(m->buffer);
    free(m);
}

/* ---- the forcing: of the inputs, of the embedded move ----------------------------- */

/* What the forcing at one instant gives besides the modal forces: the gripper's (pivot's)
 * acceleration `acc` (world, m/s^2; the path), the model frame origin's acceleration and
 * gravity in body components, the rotational load coefficients and the orientation
 * (jxf_turning.h). */
typedef struct {
    double acc[3], a_body[3], g_body[3], b[9], rotation[9];
} jxf_loads;

/* The modal forces `f` (M) and the loads of the drive `d` (JXF_IN_COUNT inputs); 0, or -1
 * (logged) when the orientation has no direction. */
static int drive_loads(const jxf_model *m, const double d[JXF_IN_COUNT], double *f,
                       jxf_loads *l) {
    memcpy(l->acc, d + JXF_IN_ACC, sizeof l->acc);
    return jxf_drive_forces(m, d, f, l->a_body, l->g_body, l->b, l->rotation);
}

/* The drive of sample k of the embedded move: its acceleration and, for a turning part, its
 * pose (quaternion, angular velocity and acceleration); `moving` 0: at rest in that pose
 * (acceleration and rates 0), as before the start and after the last sample. */
static void sample_drive(const jxf_model *m, long k, int moving, double d[JXF_IN_COUNT]) {
    int c;
    memset(d, 0, JXF_IN_COUNT * sizeof(double));
    d[JXF_IN_QUAT] = 1.0;
    if (moving)
        for (c = 0; c < 3; ++c) d[JXF_IN_ACC + c] = m->traj[3 * k + c];
    if (m->turning) {
        const double *pose = m->traj_pose + JXF_POSE_VALUES * k;
        memcpy(d + JXF_IN_QUAT, pose, 4 * sizeof(double));
        if (moving) memcpy(d + JXF_IN_OMEGA, pose + 4, 6 * sizeof(double));
    }
}

/* The orientation `r` (9, row-major, body -> world; it holds sample k's on entry) at the
 * fraction `w` of the step after sample k of the embedded move: R_k exp([phi]_x) with
 * phi = w_k s + alpha_k s^2 / 2 + (alpha_k+1 - alpha_k) s^3 / (6 dt), s = w dt (body
 * components; exact for a turn about a fixed axis, as jaxflex._turning_collision). */
static void turn_between(const jxf_model *m, long k, double w, double r[9]) {
    const double *now = m->traj_pose + JXF_POSE_VALUES * k, *next = now + JXF_POSE_VALUES;
    const double s = w * m->traj_dt;
    double phi[3], angle, sn, cs, e[9], out[9];
    int i, j, c;
    jxf_turn_angle(now + 4, now + 7, next + 7, m->traj_dt, s, phi, NULL);
    angle = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    if (angle == 0.0) return;
    for (i = 0; i < 3; ++i) phi[i] /= angle;
    sn = sin(angle), cs = 1.0 - cos(angle);
    for (i = 0; i < 3; ++i) /* Rodrigues: I + sin [n]_x + (1 - cos) (n n^T - I) */
        for (j = 0; j < 3; ++j)
            e[3 * i + j] = (i == j ? 1.0 : 0.0) + cs * (phi[i] * phi[j] - (i == j ? 1.0 : 0.0));
    e[1] -= sn * phi[2], e[2] += sn * phi[1], e[3] += sn * phi[2];
    e[5] -= sn * phi[0], e[6] -= sn * phi[1], e[7] += sn * phi[0];
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j)
            for (out[3 * i + j] = 0.0, c = 0; c < 3; ++c)
                out[3 * i + j] += r[3 * i + c] * e[3 * c + j];
    memcpy(r, out, sizeof out);
}

/* The embedded move at `tau` s after the start: the modal forces `f` (M) and the loads,
 * linear in time between those of the samples (the first-order hold of the forcing that
 * jaxflex's recursion assumes; the orientation turns exactly, turn_between), at rest in the
 * first / last sample's pose outside. The
 * samples' quaternions are checked when the resource is loaded, so this cannot fail. */
static void trajectory_at(jxf_model *m, double tau, double *f, jxf_loads *l) {
    const double x = tau / m->traj_dt;
    double d[JXF_IN_COUNT], w;
    jxf_loads next;
    long k;
    int i;
    if (!(x >= 0.0) || x > (double)(m->n_traj - 1) * (1.0 + JXF_SNAP)) {
        sample_drive(m, x > 0.0 ? m->n_traj - 1 : 0, 0, d);
        (void)drive_loads(m, d, f, l);
        return;
    }
    k = (long)floor(x);
    if (k >= m->n_traj - 1) k = m->n_traj - 2;
    w = x - (double)k;
    if (w > 1.0) w = 1.0;
    sample_drive(m, k, 1, d);
    (void)drive_loads(m, d, f, l);
    if (w == 0.0) return;
    sample_drive(m, k + 1, 1, d);
    (void)drive_loads(m, d, m->f_next, &next);
    for (i = 0; i < m->n_modes; ++i) f[i] = (1.0 - w) * f[i] + w * m->f_next[i];
    for (i = 0; i < 3; ++i) {
        l->acc[i] = (1.0 - w) * l->acc[i] + w * next.acc[i];
        l->a_body[i] = (1.0 - w) * l->a_body[i] + w * next.a_body[i];
        l->g_body[i] = (1.0 - w) * l->g_body[i] + w * next.g_body[i];
    }
    for (i = 0; i < 9; ++i) l->b[i] = (1.0 - w) * l->b[i] + w * next.b[i];
    if (m->turning) turn_between(m, k, w, l->rotation);
}

/* ---- outputs ------------------------------------------------------------------------ */

static void update_settled(jxf_model *m) {
    const int now = m->deviation <= m->threshold;
    if (now && !m->settled) m->settle_time = m->time;
    m->settled = now;
}

/* Modal sag of mode i under gravity in the current pose (0 for a part that does not turn:
 * its state is measured from the sag), kg^0.5 m. */
static double sag(const jxf_model *m, int i) {
    const double omega = 2.0 * JXF_PI * m->freq_hz[i], *g = m->gamma + 3 * i;
    if (!m->turning) return 0.0;
    return (g[0] * m->g_now[0] + g[1] * m->g_now[1] + g[2] * m->g_now[2]) / (omega * omega);
}

/* The outputs of a new state: its stamp, the deviation (over the blocks that can decide it,
 * jxf_blocks.c) and the settled flag. */
static void update_outputs(jxf_model *m) {
    int i;
    ++m->state;
    /* the coordinates of the shapes: q (a turning part: less its sag in the current pose,
     * Omega^-2 gamma . g_b), then the base acceleration (the static residual) and, R = 12,
     * the rotational load coefficients (jaxflex._rotation_residual) */
    for (i = 0; i < m->n_modes; ++i) m->coords[i] = m->q[i] - sag(m, i);
    for (i = 0; i < m->n_static; ++i)
        m->coords[m->n_modes + i] = i < 3 ? m->a_now[i] : m->b_now[i - 3];
    m->deviation = jxf_blocks_deviation(m);
    update_settled(m);
}

/* At rest at `start_time`, outputs evaluated. A turning part rests sagging in the pose of
 * its inputs (their orientation; the identity, with a warning, when it has no direction) or,
 * replaying its embedded move, in the move's first pose, so that its deviation starts at 0. */
static void rest(jxf_model *m, double start_time) {
    int i;
    memset(m->q, 0, 2 * (size_t)m->n_modes * sizeof(double));
    memset(m->a_now, 0, sizeof m->a_now);
    memset(m->g_now, 0, sizeof m->g_now);
    memset(m->b_now, 0, sizeof m->b_now);
    memset(m->rot_now, 0, sizeof m->rot_now);
    m->rot_now[0] = m->rot_now[4] = m->rot_now[8] = 1.0;
    if (m->turning) {
        double pose[JXF_IN_COUNT];
        jxf_loads l;
        memcpy(pose, m->in, sizeof pose);
        if (m->use_trajectory && m->n_traj > 0) {
            trajectory_at(m, 0.0, m->f0, &l); /* the embedded move's first pose */
        } else if (drive_loads(m, pose, m->f0, &l) != 0) {
            jxf_log(m, JXF_LOG_WARNING, "at rest in the identity orientation instead");
            memset(pose + JXF_IN_QUAT, 0, 4 * sizeof(double));
            pose[JXF_IN_QUAT] = 1.0;
            (void)drive_loads(m, pose, m->f0, &l);
        }
        memcpy(m->a_now, l.a_body, sizeof m->a_now);
        memcpy(m->g_now, l.g_body, sizeof m->g_now);
        memcpy(m->b_now, l.b, sizeof m->b_now);
        memcpy(m->rot_now, l.rotation, sizeof m->rot_now);
        for (i = 0; i < m->n_modes; ++i) m->q[i] = sag(m, i);
    }
    memset(m->pos, 0, sizeof m->pos);
    memset(m->vel, 0, sizeof m->vel);
    m->start_time = start_time;
    m->time = start_time;
    m->settled = 0;
    m->settle_time = start_time;
    update_outputs(m);
}

static void restart(jxf_model *m) {
    int s;
    m->threshold = JXF_START_THRESHOLD;
    m->damping_scale = JXF_START_DAMPING_SCALE;
    m->use_trajectory = 0;
    memset(m->in, 0, sizeof m->in);
    memset(m->in_rate, 0, sizeof m->in_rate);
    m->in[JXF_IN_QUAT] = 1.0; /* the identity orientation */
    for (s = 0; s < JXF_CACHE_SLOTS; ++s) {
        m->cache[s].h = 0.0;
        m->cache[s].stamp = 0;
    }
    m->clock = 0;
    m->recomputations = 0;
    m->started = 0;
    rest(m, 0.0);
}

void jxf_model_reset(jxf_model *m) { restart(m); }

void jxf_model_start(jxf_model *m, double start_time) {
    rest(m, start_time);
    m->started = 1;
}

double jxf_model_time(const jxf_model *m) { return m->time; }

/* ---- variables --------------------------------------------------------------------- */

typedef struct {
    unsigned vr;
    const char *name;
} variable_name;

/* What the importer reads (jxf_values.c, listed in jxf_config.h): `size` values. */
typedef struct {
    unsigned vr;
    size_t size;
    void (*get)(const jxf_model *m, double *out);
} real_value;

typedef struct {
    unsigned vr;
    void (*get)(const jxf_model *m, int *out);
} bool_value;

static const real_value REAL_VALUES[] = JXF_REAL_VALUES;
static const bool_value BOOL_VALUES[] = JXF_BOOL_VALUES;

static const real_value *real_value_of(unsigned vr) {
    size_t i;
    for (i = 0; i < sizeof REAL_VALUES / sizeof REAL_VALUES[0]; ++i)
        if (REAL_VALUES[i].vr == vr) return &REAL_VALUES[i];
    return NULL;
}

static const char *name_of(unsigned vr) {
    static const variable_name names[] = JXF_VARIABLE_TABLE;
    size_t i;
    for (i = 0; i < sizeof names / sizeof names[0]; ++i)
        if (names[i].vr == vr) return names[i].name;
    return "(unknown)";
}

/* The input's index in the drive (JXF_IN_*), -1 if `vr` is not an input. */
static int input_of(unsigned vr) {
    static const unsigned inputs[] = JXF_INPUT_VRS;
    int i;
    for (i = 0; i < (int)(sizeof inputs / sizeof inputs[0]); ++i)
        if (inputs[i] == vr) return i;
    return -1;
}

static int not_finite(const jxf_model *m, unsigned vr, const char *what, double value) {
    jxf_log(m, JXF_LOG_ERROR, "%s%s = %g is not finite: value rejected, state unchanged",
            what, name_of(vr), value);
    return -1;
}

static int no_such(const jxf_model *m, const char *action, const char *type, unsigned vr) {
    jxf_log(m, JXF_LOG_ERROR, "cannot %s a %s variable with value reference %u (%s)", action,
            type, vr, name_of(vr));
    return -1;
}

size_t jxf_model_real_size(unsigned vr) {
    const real_value *v = real_value_of(vr);
    return v == NULL ? 1 : v->size;
}

int jxf_model_get_real(const jxf_model *m, unsigned vr, double *value) {
    const real_value *v = real_value_of(vr);
    if (v == NULL) return no_such(m, "get", "real", vr);
    v->get(m, value);
    return 0;
}

static double largest_zeta(const jxf_model *m) {
    double zeta_max = 0.0;
    int i;
    for (i = 0; i < m->n_modes; ++i) zeta_max = m->zeta[i] > zeta_max ? m->zeta[i] : zeta_max;
    return zeta_max;
}

int jxf_model_set_real(jxf_model *m, unsigned vr, double value, int apply) {
    const int input = input_of(vr);
    if (input >= 0) {
        if (!isfinite(value)) return not_finite(m, vr, "input ", value);
        if (apply) m->in[input] = value;
    } else if (vr == JXF_VR_THRESHOLD) {
        if (!(isfinite(value) && value > 0.0)) {
            jxf_log(m, JXF_LOG_ERROR, "threshold = %g m: must be a finite number > 0", value);
            return -1;
        }
        if (apply) {
            m->threshold = value;
            update_settled(m);
        }
    } else if (vr == JXF_VR_DAMPING_SCALE) {
        const double zeta_max = largest_zeta(m);
        if (!(isfinite(value) && value >= 0.0 && value * zeta_max < 1.0)) {
            jxf_log(m, JXF_LOG_ERROR, "damping_scale = %g: must be >= 0 and keep every damping "
                    "ratio below 1 (the largest is %g, so damping_scale < %g)", value, zeta_max,
                    zeta_max > 0.0 ? 1.0 / zeta_max : HUGE_VAL);
            return -1;
        }
        if (apply) m->damping_scale = value;
    } else {
        return no_such(m, "set", "real", vr);
    }
    return 0;
}

int jxf_model_set_input_rate(jxf_model *m, unsigned vr, int order, double value,
                             int apply) {
    const int input = input_of(vr);
    if (input < 0 || order != 1) {
        jxf_log(m, JXF_LOG_ERROR, "input derivatives: only the first derivative of an input "
                "(ax, ay, az%s) is accepted (got value reference %u (%s), order %d)",
                m->turning ? ", the quaternion, angular velocity and acceleration" : "", vr,
                name_of(vr), order);
        return -1;
    }
    if (!isfinite(value)) return not_finite(m, vr, "time derivative of input ", value);
    if (apply) m->in_rate[input] = value;
    return 0;
}

int jxf_model_get_output_rate(const jxf_model *m, unsigned vr, int order, double *value) {
    (void)value;
    jxf_log(m, JXF_LOG_ERROR, "no output derivatives (maxOutputDerivativeOrder is 0): "
            "derivative of order %d of value reference %u (%s)", order, vr, name_of(vr));
    return -1;
}

int jxf_model_get_bool(const jxf_model *m, unsigned vr, int *value) {
    size_t i;
    for (i = 0; i < sizeof BOOL_VALUES / sizeof BOOL_VALUES[0]; ++i) {
        if (BOOL_VALUES[i].vr == vr) {
            BOOL_VALUES[i].get(m, value);
            return 0;
        }
    }
    return no_such(m, "get", "Boolean", vr);
}

int jxf_model_set_bool(jxf_model *m, unsigned vr, int value, int apply) {
#ifdef JXF_VR_USE_TRAJECTORY
    if (vr == JXF_VR_USE_TRAJECTORY) {
        if (m->started) {
            jxf_log(m, JXF_LOG_ERROR, "use_embedded_trajectory is a fixed parameter: set it "
                    "before leaving initialization mode");
            return -1;
        }
        if (apply) m->use_trajectory = value != 0;
        return 0;
    }
#endif
    (void)value, (void)apply;
    return no_such(m, "set", "Boolean", vr);
}

/* ---- the exact step ----------------------------------------------------------------- */

static void closed_form(double omega, double zeta, double h, jxf_coeffs *c, int i) {
    const double sigma = zeta * omega, omega_d = omega * sqrt(1.0 - zeta * zeta);
    const double decay = exp(-sigma * h), x = omega_d * h, cs = cos(x);
    const double sin_over_wd = x != 0.0 ? h * (sin(x) / x) : h;
    const double p11 = decay * (cs + sigma * sin_over_wd), p12 = decay * sin_over_wd;
    const double p22 = decay * (cs - sigma * sin_over_wd), w2 = omega * omega;
    const double j0q = (1.0 - p11) / w2, j0v = p12;
    const double j1v = h * p12 - j0q;
    const double j1q = (-2.0 * sigma * j1v - (h * p22 - j0v)) / w2;
    c->p11[i] = p11;
    c->p12[i] = p12;
    c->p21[i] = -w2 * p12;
    c->p22[i] = p22;
    c->g0q[i] = j1q / h;
    c->g0v[i] = j1v / h;
    c->g1q[i] = j0q - c->g0q[i];
    c->g1v[i] = j0v - c->g0v[i];
}

static void series(double omega, double zeta, double h, jxf_coeffs *c, int i) {
    const double a21 = -omega * omega * h, a22 = -2.0 * zeta * omega * h;
    double w1 = 1.0, w2 = 0.0, v1 = 0.0, v2 = 1.0;
    double p11 = w1, p21 = w2, p12 = v1, p22 = v2;
    double j0q = v1, j0v = v2, j1q = v1 / 2.0, j1v = v2 / 2.0, factorial = 1.0;
    int k;
    for (k = 1; k < JXF_SERIES_TERMS; ++k) {
        double t1, t2;
        factorial *= k;
        t1 = h * w2;
        t2 = a21 * w1 + a22 * w2;
        w1 = t1;
        w2 = t2;
        t1 = h * v2;
        t2 = a21 * v1 + a22 * v2;
        v1 = t1;
        v2 = t2;
        p11 += w1 / factorial;
        p21 += w2 / factorial;
        p12 += v1 / factorial;
        p22 += v2 / factorial;
        j0q += v1 / (factorial * (k + 1));
        j0v += v2 / (factorial * (k + 1));
        j1q += v1 / (factorial * (k + 2));
        j1v += v2 / (factorial * (k + 2));
    }
    c->p11[i] = p11;
    c->p12[i] = p12;
    c->p21[i] = p21;
    c->p22[i] = p22;
    j0q *= h;
    j0v *= h;
    c->g0q[i] = h * h * j1q / h;
    c->g0v[i] = h * h * j1v / h;
    c->g1q[i] = j0q - c->g0q[i];
    c->g1v[i] = j0v - c->g0v[i];
}

/* Coefficients for step `h`, from the cache when a slot matches within JXF_STEP_RTOL; NULL
 * (logged) if they are not finite, e.g. omega h beyond the range of double. */
static const jxf_coeffs *coefficients(jxf_model *m, double h) {
    jxf_coeffs *slot = &m->cache[0];
    int s, i;
    for (s = 0; s < JXF_CACHE_SLOTS; ++s) {
        jxf_coeffs *c = &m->cache[s];
        if (c->h > 0.0 && fabs(c->h - h) <= JXF_STEP_RTOL * h && c->damping == m->damping_scale) {
            c->stamp = ++m->clock;
            return c;
        }
        if (c->stamp < slot->stamp) slot = c;
    }
    for (i = 0; i < m->n_modes; ++i) {
        const double omega = 2.0 * JXF_PI * m->freq_hz[i], zeta = m->zeta[i] * m->damping_scale;
        double entries[8];
        if (omega * h < JXF_SERIES_LIMIT)
            series(omega, zeta, h, slot, i);
        else
            closed_form(omega, zeta, h, slot, i);
        entries[0] = slot->p11[i], entries[1] = slot->p12[i], entries[2] = slot->p21[i];
        entries[3] = slot->p22[i], entries[4] = slot->g0q[i], entries[5] = slot->g0v[i];
        entries[6] = slot->g1q[i], entries[7] = slot->g1v[i];
        if (!all_finite(entries, 8)) {
            slot->h = 0.0;
            slot->stamp = 0;
            jxf_log(m, JXF_LOG_ERROR, "a step of %g s is beyond what the exact step of mode %d "
                    "(%g Hz) can represent in double precision", h, i, m->freq_hz[i]);
            return NULL;
        }
    }
    slot->h = h;
    slot->damping = m->damping_scale;
    slot->stamp = ++m->clock;
    ++m->recomputations;
    jxf_log(m, JXF_LOG_INFO, "discrete matrices recomputed for a step of %.17g s", h);
    return slot;
}

/* One exact step of `h` s with the modal forces linear between m->f0 and m->f1 (first-order
 * hold) and the loads l0, l1 at its ends; the path (position and velocity of the gripper,
 * from the start) follows exactly as well, and the loads at the end become the current
 * ones. -1 (logged) if the coefficients or the new state are not finite (the caller restores
 * the state). */
static int advance(jxf_model *m, double h, const jxf_loads *l0, const jxf_loads *l1) {
    const jxf_coeffs *c = coefficients(m, h);
    const double *a0 = l0->acc, *a1 = l1->acc;
    int i;
    if (c == NULL) return -1;
    memcpy(m->a_now, l1->a_body, sizeof m->a_now);
    memcpy(m->g_now, l1->g_body, sizeof m->g_now);
    memcpy(m->b_now, l1->b, sizeof m->b_now);
    memcpy(m->rot_now, l1->rotation, sizeof m->rot_now);
    for (i = 0; i < 3; ++i) {
        m->pos[i] += h * m->vel[i] + h * h * (2.0 * a0[i] + a1[i]) / 6.0;
        m->vel[i] += 0.5 * h * (a0[i] + a1[i]);
    }
    for (i = 0; i < m->n_modes; ++i) {
        const double f0 = m->f0[i], f1 = m->f1[i];
        const double q = m->q[i], v = m->v[i];
        const double qn = c->p11[i] * q + c->p12[i] * v + (c->g0q[i] * f0 + c->g1q[i] * f1);
        const double vn = c->p21[i] * q + c->p22[i] * v + (c->g0v[i] * f0 + c->g1v[i] * f1);
        if (!isfinite(qn) || !isfinite(vn)) {
            jxf_log(m, JXF_LOG_ERROR, "the state of mode %d is not finite after a step of %g s "
                    "(inputs %g, %g / %g, %g / %g, %g m/s^2 at its ends)", i, h, a0[0], a1[0],
                    a0[1], a1[1], a0[2], a1[2]);
            return -1;
        }
        m->q[i] = fabs(qn) < JXF_TINY ? 0.0 : qn;
        m->v[i] = fabs(vn) < JXF_TINY ? 0.0 : vn;
    }
    return 0;
}

/* Replay the embedded trajectory over [tau, tau + h] (s after the start), split at its
 * sample times k dt, k = 0 .. N-1, that lie inside (breakpoints within JXF_SNAP dt of an end
 * count as that end). The breakpoints are integers times dt, so the number of exact steps is
 * at most N + 1 whatever tau and h are (before the start and after the last sample the part
 * rests in the end pose: one step). */
static int replay(jxf_model *m, double tau, double h) {
    const double dt = m->traj_dt, end = tau + h, last = (double)(m->n_traj - 1);
    const double first_x = floor(tau / dt + JXF_SNAP) + 1.0; /* first breakpoint after tau */
    const double last_x = ceil(end / dt - JXF_SNAP) - 1.0;   /* last one before the end */
    const size_t forces = (size_t)m->n_modes * sizeof(double);
    jxf_loads l0, l1;
    double from = tau;
    long k, k_first, k_last;
    k_first = first_x < 0.0 ? 0 : first_x > last ? m->n_traj : (long)first_x;
    k_last = last_x > last ? m->n_traj - 1 : last_x < 0.0 ? -1 : (long)last_x;
    trajectory_at(m, tau, m->f0, &l0);
    for (k = k_first; k <= k_last; ++k) {
        const double next = (double)k * dt;
        trajectory_at(m, next, m->f1, &l1);
        if (advance(m, next - from, &l0, &l1)) return -1;
        memcpy(m->f0, m->f1, forces);
        l0 = l1;
        from = next;
    }
    trajectory_at(m, end, m->f1, &l1);
    return advance(m, end - from, &l0, &l1);
}

/* One step of `h` s driven by the inputs: linear from their values to the values their
 * slopes give at the end (held without slopes); -1 (logged) as advance, or when an
 * orientation has no direction. */
static int input_step(jxf_model *m, double h) {
    double d1[JXF_IN_COUNT];
    jxf_loads l0, l1;
    int c;
    for (c = 0; c < JXF_IN_COUNT; ++c) d1[c] = m->in[c] + h * m->in_rate[c];
    if (drive_loads(m, m->in, m->f0, &l0) != 0 || drive_loads(m, d1, m->f1, &l1) != 0)
        return -1;
    return advance(m, h, &l0, &l1);
}

/* Refused (the state restored, logged) when the exact solution is not finite. The work is
 * bounded: one exact step per embedded trajectory sample crossed (integer sample indices,
 * never accumulated time), at most N + 1. */
int jxf_model_do_step(jxf_model *m, double t, double h) {
    const size_t M = (size_t)m->n_modes;
    const double end = t + h, time = m->time;
    double settle_time, path[4][3]; /* pos, vel, a_now, g_now before the step */
    double loads[2][9];             /* b_now, rot_now before the step */
    int status, settled;
    memcpy(m->saved, m->q, 2 * M * sizeof(double));
    memcpy(path[0], m->pos, sizeof path[0]);
    memcpy(path[1], m->vel, sizeof path[1]);
    memcpy(path[2], m->a_now, sizeof path[2]);
    memcpy(path[3], m->g_now, sizeof path[3]);
    memcpy(loads[0], m->b_now, sizeof loads[0]);
    memcpy(loads[1], m->rot_now, sizeof loads[1]);
    settled = m->settled;
    settle_time = m->settle_time;
    status = m->use_trajectory ? replay(m, t - m->start_time, h) : input_step(m, h);
    if (status == 0) {
        m->time = end;
        update_outputs(m);
        if (!isfinite(m->deviation)) {
            jxf_log(m, JXF_LOG_ERROR, "the displacement after the step is not finite (it "
                    "overflows double precision)");
            status = -1;
        }
    }
    if (status != 0) { /* back to the state before the call, outputs included */
        memcpy(m->q, m->saved, 2 * M * sizeof(double));
        memcpy(m->pos, path[0], sizeof path[0]);
        memcpy(m->vel, path[1], sizeof path[1]);
        memcpy(m->a_now, path[2], sizeof path[2]);
        memcpy(m->g_now, path[3], sizeof path[3]);
        memcpy(m->b_now, loads[0], sizeof loads[0]);
        memcpy(m->rot_now, loads[1], sizeof loads[1]);
        m->time = time;
        update_outputs(m);
        m->settled = settled;
        m->settle_time = settle_time;
        jxf_log(m, JXF_LOG_ERROR, "doStep(currentCommunicationPoint = %g s, step = %g s) "
                "refused; state unchanged", t, h);
        return -1;
    }
    return 0;
}
