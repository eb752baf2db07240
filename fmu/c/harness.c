/* Test and benchmark harness for an exported jaxflex FMU (not shipped inside the FMU).
 *
 * Compile with -DHARNESS_FMI=2 or 3 and the FMI headers on the include path; it loads the
 * FMU's shared library (dlopen, or LoadLibrary when built for Windows) like an importer would.
 *
 *   harness LIBRARY RESOURCES TOKEN bench N_STEPS DT REPEATS
 *       time REPEATS instantiations and N_STEPS communication steps of back-to-back 1 s
 *       moves (BENCH_MOVE_S: the part always moving; inputs set and the scalar outputs
 *       deviation, settled and settle_time read every step, and min_distance when built
 *       with -DHARNESS_DISTANCE; built with -DHARNESS_TURNING, the pose inputs of a
 *       turning part too: a turn about z); prints one JSON line
 *   harness LIBRARY RESOURCES TOKEN check N_STEPS DT
 *       exercise the life cycle (two instances, NaN input, bad step, reset and re-run,
 *       missing resources); exit status 0 when every expectation holds
 *   harness LIBRARY RESOURCES TOKEN replay N_STEPS DT SWITCH OUTPUT...
 *       set the Boolean parameter with value reference SWITCH true during initialization
 *       ("-": none; e.g. use_embedded_trajectory), take N_STEPS steps of DT without setting
 *       inputs and print, at the start and after every step, one line: the time and the
 *       OUTPUTs, each "rVR" (a Real/Float64), "rVRxN" (an FMI 3.0 array of N values) or
 *       "bVR" (a Boolean, printed 0/1); reals with 17 significant digits
 *   harness LIBRARY - TOKEN fuzz N_STEPS DT SWITCH LIST
 *       for every resource location in the file LIST (one per line), in this one process:
 *       instantiate; if that succeeds, run N_STEPS steps of DT from rest (with the Boolean
 *       parameter SWITCH set, "-" for none), then hostile calls (non-finite inputs, steps
 *       that overflow the time or do not advance it, a step from far before the start over
 *       it), reset and step again. Prints per location "refused LOGGED" or "accepted LOGGED
 *       DEVIATION FAULTS": LOGGED messages, the deviation after the steps, and FAULTS the
 *       calls that broke a rule (a step accepted with a non-finite deviation, a hostile call
 *       accepted). Built with -fsanitize=address,undefined it is the resource-fuzz run.
 */
#include "harness_os.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if HARNESS_FMI == 2
#include "fmi2FunctionTypes.h"
#else
#include "fmi3FunctionTypes.h"
#endif

#define VR_AX 1u
#define VR_POSE 40u /* quat_w .. alpha_z of a turning part (fmu/variables.py), 10 inputs */
#ifdef HARNESS_TURNING
#define N_INPUTS 13
#else
#define N_INPUTS 3
#endif
#define VR_DEVIATION 10u
#define VR_SETTLE_TIME 11u
#define VR_SETTLED 12u
#define VR_MIN_DISTANCE 14u /* read every step by the bench when built with -DHARNESS_DISTANCE */
#define VR_DISPLACED_POINTS 30u /* FMI 3.0 array output (K x 3); read every step when the
                                   harness is built with -DHARNESS_ARRAY_POINTS=K */

static int logged = 0;
static int quiet = 1;

static void *need(void *lib, const char *name) {
    void *f = find_symbol(lib, name);
    if (f == NULL) {
        fprintf(stderr, "missing symbol %s\n", name);
        exit(2);
    }
    return f;
}

/* The FMI functions the harness calls: api.<field> = FMI<Function>, loaded from the library
 * (X-macro: X(field, Function); the names that differ between the versions are macros). */
#if HARNESS_FMI == 2
#define FMI fmi2
#define INSTANTIATE Instantiate
#define SET_REAL SetReal
#define GET_REAL GetReal
#define API_EXTRA(X) X(setup, SetupExperiment) X(set_rates, SetRealInputDerivatives)
#else
#define FMI fmi3
#define INSTANTIATE InstantiateCoSimulation
#define SET_REAL SetFloat64
#define GET_REAL GetFloat64
#define API_EXTRA(X)
#endif
#define API(X)                                                                             \
    X(instantiate, INSTANTIATE) X(free_instance, FreeInstance)                             \
    X(enter_init, EnterInitializationMode) X(exit_init, ExitInitializationMode)            \
    X(set_real, SET_REAL) X(get_real, GET_REAL) X(get_bool, GetBoolean)                    \
    X(set_bool, SetBoolean) X(do_step, DoStep) X(reset, Reset) X(terminate, Terminate)     \
    API_EXTRA(X)
#define CAT3_(a, b, c) a##b##c
#define CAT3(a, b, c) CAT3_(a, b, c)
#define NAME_(x) #x
#define NAME(x) NAME_(x)
#define API_FIELD(field, function) CAT3(FMI, function, TYPE) *field;
#define API_LOAD(field, function) \
    api.field = (CAT3(FMI, function, TYPE) *)need(lib, NAME(CAT3(FMI, function, )));

static struct {
    API(API_FIELD)
} api;

static void load(void *lib) { API(API_LOAD) }

#if HARNESS_FMI == 2
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env, (void)name, (void)status, (void)category;
    ++logged;
    if (quiet) return;
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}
static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
static void *instantiate(const char *resources, const char *token) {
    return api.instantiate("harness", fmi2CoSimulation, token, resources, &callbacks, fmi2False,
                           fmi2False);
}
static int enter(void *c) {
    return api.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) || api.enter_init(c);
}
static int start(void *c) { return enter(c) || api.exit_init(c); }
static int set_flag(void *c, unsigned vr, int value) {
    const fmi2ValueReference ref = vr;
    const fmi2Boolean flag = value ? fmi2True : fmi2False;
    return api.set_bool(c, &ref, 1, &flag);
}
static int get_flag(void *c, unsigned vr, int *value) {
    const fmi2ValueReference ref = vr;
    fmi2Boolean flag = fmi2False;
    int status = api.get_bool(c, &ref, 1, &flag);
    *value = flag != fmi2False;
    return status;
}
static int get_values(void *c, unsigned vr, int n, double *out) {
    const fmi2ValueReference ref = vr;
    return n != 1 || api.get_real(c, &ref, 1, out); /* FMI 2.0 has scalars only */
}
static void drive(const double a[3], const double rate[3], double in[], double in_rate[]);
static int set_inputs(void *c, const double a[3], const double rate[3]) {
    fmi2ValueReference vr[N_INPUTS];
    fmi2Integer order[N_INPUTS];
    double in[N_INPUTS], in_rate[N_INPUTS];
    int i;
    for (i = 0; i < N_INPUTS; ++i) vr[i] = i < 3 ? VR_AX + i : VR_POSE + (i - 3), order[i] = 1;
    drive(a, rate, in, in_rate);
    return api.set_real(c, vr, N_INPUTS, in) || api.set_rates(c, vr, N_INPUTS, order, in_rate);
}
static int step(void *c, double t, double h) { return api.do_step(c, t, h, fmi2True); }
static double deviation(void *c) {
    const fmi2ValueReference vr = VR_DEVIATION;
    double d = NAN;
    api.get_real(c, &vr, 1, &d);
    return d;
}
static int reset(void *c) { return api.reset(c); }
static void finish(void *c) {
    api.terminate(c);
    api.free_instance(c);
}
#else
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void)env, (void)status, (void)category;
    ++logged;
    if (!quiet) fprintf(stderr, "%s\n", message);
}
static void *instantiate(const char *resources, const char *token) {
    return api.instantiate("harness", token, resources, fmi3False, fmi3False, fmi3False,
                           fmi3False, NULL, 0, NULL, logger, NULL);
}
static int enter(void *c) { return api.enter_init(c, fmi3False, 0.0, 0.0, fmi3False, 0.0); }
static int start(void *c) { return enter(c) || api.exit_init(c); }
static int set_flag(void *c, unsigned vr, int value) {
    const fmi3ValueReference ref = vr;
    const fmi3Boolean flag = value != 0;
    return api.set_bool(c, &ref, 1, &flag, 1);
}
static int get_flag(void *c, unsigned vr, int *value) {
    const fmi3ValueReference ref = vr;
    fmi3Boolean flag = fmi3False;
    int status = api.get_bool(c, &ref, 1, &flag, 1);
    *value = flag != fmi3False;
    return status;
}
static int get_values(void *c, unsigned vr, int n, double *out) {
    const fmi3ValueReference ref = vr;
    return api.get_real(c, &ref, 1, out, (size_t)n);
}
static void drive(const double a[3], const double rate[3], double in[], double in_rate[]);
static int set_inputs(void *c, const double a[3], const double rate[3]) {
    fmi3ValueReference vr[N_INPUTS];
    double in[N_INPUTS], in_rate[N_INPUTS]; /* FMI 3.0: inputs are held over the step */
    int i;
    for (i = 0; i < N_INPUTS; ++i) vr[i] = i < 3 ? VR_AX + i : VR_POSE + (i - 3);
    drive(a, rate, in, in_rate);
    return api.set_real(c, vr, N_INPUTS, in, N_INPUTS);
}
static int step(void *c, double t, double h) {
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    return api.do_step(c, t, h, fmi3True, &event, &terminate, &early, &last);
}
static double deviation(void *c) {
    const fmi3ValueReference vr = VR_DEVIATION;
    double d = NAN;
    api.get_real(c, &vr, 1, &d, 1);
#ifdef HARNESS_ARRAY_POINTS
    {
        static double points[3 * (size_t)HARNESS_ARRAY_POINTS];
        const fmi3ValueReference array = VR_DISPLACED_POINTS;
        if (api.get_real(c, &array, 1, points, 3 * (size_t)HARNESS_ARRAY_POINTS)) return NAN;
    }
#endif
    return d;
}
static int reset(void *c) { return api.reset(c); }
static void finish(void *c) {
    api.terminate(c);
    api.free_instance(c);
}
#endif

/* The inputs (and their rates) of the acceleration a (m/s^2) and its rate: a itself and,
 * for a turning part, a turn about z whose angle, rate and angular acceleration follow a
 * (quaternion w, x, y, z; angular velocity; angular acceleration). */
static void drive(const double a[3], const double rate[3], double in[], double in_rate[]) {
    int i;
    for (i = 0; i < N_INPUTS; ++i) in[i] = in_rate[i] = 0.0;
    for (i = 0; i < 3; ++i) in[i] = a[i], in_rate[i] = rate[i];
#ifdef HARNESS_TURNING
    in[3] = cos(0.05 * a[0]), in[6] = sin(0.05 * a[0]);
    in_rate[3] = -0.05 * rate[0] * in[6], in_rate[6] = 0.05 * rate[0] * in[3];
    in[9] = 0.1 * a[0], in_rate[9] = 0.1 * rate[0];
    in[12] = 0.1 * rate[0];
#endif
}

/* A smooth rest-to-rest acceleration profile of `period` steps sampled at step k, repeated
 * (m/s^2): one sine period per axis, amplitudes 1, 2, 3 m/s^2. */
static void profile(int k, int period, double a[3], double rate[3], double dt) {
    const double two_pi = 6.283185307179586;
    int c;
    for (c = 0; c < 3; ++c) {
        const double amp = 1.0 + c;
        const double a0 = amp * sin(two_pi * (k % period) / period);
        const double a1 = amp * sin(two_pi * ((k + 1) % period) / period);
        a[c] = a0;
        rate[c] = (a1 - a0) / dt;
    }
}

/* Run steps [k0, k1) of moves of `period` steps from rest (at rest from step `stop` on),
 * storing the deviation after each step. */
static int run_steps(void *c, int k0, int k1, int period, int stop, double dt, double *out) {
    const double zero[3] = {0.0, 0.0, 0.0};
    double a[3], rate[3];
    int k;
    for (k = k0; k < k1; ++k) {
        profile(k, period, a, rate, dt);
        if (set_inputs(c, k < stop ? a : zero, k < stop ? rate : zero) || step(c, k * dt, dt))
            return -1;
        out[k] = deviation(c);
    }
    return 0;
}

/* One move of n / 2 steps, then rest until step n. */
static int run(void *c, int n, double dt, double *out) {
    return run_steps(c, 0, n, n / 2 > 0 ? n / 2 : 1, n / 2, dt, out);
}

/* What the bench reads after every step: the scalar outputs (deviation, settled,
 * settle_time and, built with -DHARNESS_DISTANCE, min_distance); their sum (a checksum of
 * the run: equal sums, equal outputs in all likelihood). */
static double read_scalars(void *c) {
    double sum = deviation(c), value = NAN;
    int flag = 0;
    if (get_flag(c, VR_SETTLED, &flag) || get_values(c, VR_SETTLE_TIME, 1, &value)) return NAN;
    sum += flag + value;
#ifdef HARNESS_DISTANCE
    if (get_values(c, VR_MIN_DISTANCE, 1, &value)) return NAN;
    sum += value;
#endif
    return sum;
}

/* Steps [k0, k1) of back-to-back moves of `period` steps, the scalar outputs read after
 * each; their checksum into out[k]. */
static int bench_steps(void *c, int k0, int k1, int period, double dt, double *out) {
    double a[3], rate[3];
    int k;
    for (k = k0; k < k1; ++k) {
        profile(k, period, a, rate, dt);
        if (set_inputs(c, a, rate) || step(c, k * dt, dt)) return -1;
        out[k] = read_scalars(c);
    }
    return 0;
}

static int cmp_double(const void *x, const void *y) {
    const double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

#define CHUNK 100     /* steps timed together */
#define BENCH_MOVE_S 1.0 /* duration of each move of the bench, s */
#define WARM_UP 200      /* steps run (and discarded) before the timed ones */

static int bench(const char *resources, const char *token, int n, double dt, int repeats) {
    const int n_chunks = n / CHUNK;
    double *times = (double *)malloc(sizeof(double) * (size_t)repeats);
    double *chunks = (double *)malloc(sizeof(double) * (size_t)n_chunks);
    double *dev = (double *)malloc(sizeof(double) * (size_t)(n > WARM_UP ? n : WARM_UP));
    const int period = (int)(BENCH_MOVE_S / dt + 0.5) > 1 ? (int)(BENCH_MOVE_S / dt + 0.5) : 2;
    double t0, total, checksum = 0.0;
    void *c;
    int r, k;
    for (r = 0; r < repeats; ++r) {
        t0 = now_us();
        c = instantiate(resources, token);
        times[r] = now_us() - t0;
        if (c == NULL) return 1;
        api.free_instance(c);
    }
    qsort(times, (size_t)repeats, sizeof(double), cmp_double);
    c = instantiate(resources, token);
    if (c == NULL || start(c) || run(c, WARM_UP, dt, dev)) return 1;
    reset(c);
    start(c);
    total = 0.0;
    for (k = 0; k < n_chunks; ++k) {
        t0 = now_us();
        if (bench_steps(c, k * CHUNK, (k + 1) * CHUNK, period, dt, dev)) return 1;
        chunks[k] = (now_us() - t0) / CHUNK;
        total += chunks[k] * CHUNK;
    }
    for (k = 0; k < n_chunks * CHUNK; ++k) checksum += dev[k];
    qsort(chunks, (size_t)n_chunks, sizeof(double), cmp_double);
    finish(c);
    printf("{\"instantiate_us_min\": %.3f, \"instantiate_us_median\": %.3f, "
           "\"step_us_min\": %.4f, \"step_us_median\": %.4f, \"step_us_mean\": %.4f, "
           "\"n_steps\": %d, \"repeats\": %d, \"checksum\": %.17g}\n",
           times[0], times[repeats / 2], chunks[0], chunks[n_chunks / 2],
           total / (n_chunks * CHUNK), n_chunks * CHUNK, repeats, checksum);
    free(times);
    free(chunks);
    free(dev);
    return 0;
}

#define EXPECT(cond, what)                            \
    do {                                              \
        if (!(cond)) {                                \
            fprintf(stderr, "check failed: %s\n", what); \
            return 1;                                 \
        }                                             \
    } while (0)

static int check(const char *resources, const char *token, int n, double dt) {
    double *first = (double *)calloc((size_t)n, sizeof(double));
    double *again = (double *)calloc((size_t)n, sizeof(double));
    double *other = (double *)calloc((size_t)n, sizeof(double));
    const double bad[3] = {0.0, NAN, 0.0}, zero[3] = {0.0, 0.0, 0.0};
    void *a = instantiate(resources, token), *b = instantiate(resources, token);
    double before;
    int k, before_logged;
    EXPECT(a != NULL && b != NULL, "two instances");
    EXPECT(instantiate("/nonexistent/dir/", token) == NULL, "missing resources give NULL");
    EXPECT(instantiate(resources, "{not-the-token}") == NULL, "wrong token gives NULL");
    EXPECT(!start(a) && !start(b), "initialization");
    EXPECT(!run(a, n, dt, first), "run a");
    before = deviation(a);
    before_logged = logged;
    EXPECT(set_inputs(a, bad, zero) != 0 && logged > before_logged, "NaN input rejected, logged");
    EXPECT(step(a, n * dt, -dt) != 0, "negative step rejected");
    EXPECT(deviation(a) == before, "state untouched after errors");
    EXPECT(deviation(b) == 0.0, "second instance unaffected");
    EXPECT(!reset(a) && !start(a) && !run(a, n, dt, again), "reset and re-run");
    EXPECT(!run(b, n, dt, other), "run b");
    for (k = 0; k < n; ++k) {
        EXPECT(first[k] == again[k], "re-run after reset is identical");
        EXPECT(first[k] == other[k], "instances agree");
    }
    EXPECT(first[n / 4] > 0.0, "the part moves");
    finish(a);
    finish(b);
    free(first);
    free(again);
    free(other);
    printf("{\"checks\": \"passed\", \"logged\": %d}\n", logged);
    return 0;
}

/* One output of the replay mode: "rVR", "rVRxN" or "bVR". */
typedef struct {
    unsigned vr;
    int count;
    int boolean;
} output_spec;

static int parse_output(const char *text, output_spec *out) {
    char kind = 0;
    int fields = sscanf(text, "%c%ux%d", &kind, &out->vr, &out->count);
    if (fields < 2 || (kind != 'r' && kind != 'b')) return -1;
    if (fields == 2) out->count = 1;
    out->boolean = kind == 'b';
    return out->count < 1 || (out->boolean && out->count != 1) ? -1 : 0;
}

static int print_outputs(void *c, double t, const output_spec *outputs, int n, double *buffer) {
    int i, j, flag;
    printf("%.17g", t);
    for (i = 0; i < n; ++i) {
        if (outputs[i].boolean) {
            if (get_flag(c, outputs[i].vr, &flag)) return -1;
            printf(" %d", flag);
            continue;
        }
        if (get_values(c, outputs[i].vr, outputs[i].count, buffer)) return -1;
        for (j = 0; j < outputs[i].count; ++j) printf(" %.17g", buffer[j]);
    }
    putchar('\n');
    return 0;
}

static int replay(const char *resources, const char *token, int n_steps, double dt,
                  const char *switch_vr, char **specs, int n_specs) {
    output_spec *outputs = (output_spec *)calloc((size_t)n_specs + 1, sizeof(output_spec));
    double *buffer;
    void *c;
    int i, k, largest = 1;
    for (i = 0; i < n_specs; ++i) {
        if (parse_output(specs[i], &outputs[i])) {
            fprintf(stderr, "bad output '%s' (expected rVR, rVRxN or bVR)\n", specs[i]);
            return 2;
        }
        if (outputs[i].count > largest) largest = outputs[i].count;
    }
    buffer = (double *)malloc(sizeof(double) * (size_t)largest);
    c = instantiate(resources, token);
    EXPECT(c != NULL, "instantiation");
    EXPECT(!enter(c), "enter initialization");
    if (strcmp(switch_vr, "-") != 0)
        EXPECT(!set_flag(c, (unsigned)atoi(switch_vr), 1), "set the switch parameter");
    EXPECT(!api.exit_init(c), "exit initialization");
    EXPECT(!print_outputs(c, 0.0, outputs, n_specs, buffer), "read outputs");
    for (k = 0; k < n_steps; ++k) {
        EXPECT(!step(c, k * dt, dt), "step");
        EXPECT(!print_outputs(c, (k + 1) * dt, outputs, n_specs, buffer), "read outputs");
    }
    finish(c);
    free(outputs);
    free(buffer);
    return 0;
}

/* Hostile calls on a started instance: each must be refused (and leave it usable). */
static int hostile(void *c, double t) {
    const double bad[3] = {NAN, 0.0, INFINITY}, zero[3] = {0.0, 0.0, 0.0};
    int faults = 0;
    faults += set_inputs(c, bad, zero) == 0;        /* non-finite input */
    faults += step(c, t, 1e308) == 0 && !isfinite(deviation(c)); /* huge step: refused or exact */
    faults += step(c, 1e308, 1e308) == 0;           /* the time overflows */
    faults += step(c, 1e20, 1e-3) == 0;             /* below the resolution of the time */
    faults += step(c, t, NAN) == 0;
    faults += step(c, t, -1.0) == 0;
    return faults;
}

static int fuzz_one(const char *resources, const char *token, int n_steps, double dt,
                    const char *switch_vr) {
    const double a[3] = {0.5, -1.0, 2.0}, rate[3] = {0.0, 0.0, 0.0};
    double dev = NAN;
    int k, faults = 0, before = logged;
    void *c = instantiate(resources, token);
    if (c == NULL) {
        printf("refused %d\n", logged - before);
        return 0;
    }
    if (enter(c) || (strcmp(switch_vr, "-") != 0 && set_flag(c, (unsigned)atoi(switch_vr), 1)) ||
        api.exit_init(c)) {
        ++faults; /* a loaded model must start */
    } else {
        if (strcmp(switch_vr, "-") == 0) faults += set_inputs(c, a, rate) != 0;
        for (k = 0; k < n_steps; ++k) {
            if (step(c, k * dt, dt)) break; /* refused steps are logged, counted by LOGGED */
            dev = deviation(c);
            faults += !isfinite(dev);
        }
        faults += hostile(c, n_steps * dt);
        if (step(c, -1e7, 1e7 + n_steps * dt) == 0) faults += !isfinite(deviation(c));
        if (!reset(c) && !start(c) && !step(c, 0.0, dt)) faults += !isfinite(deviation(c));
    }
    finish(c);
    printf("accepted %d %.17g %d\n", logged - before, dev, faults);
    return 0;
}

static int fuzz(const char *token, int n_steps, double dt, const char *switch_vr,
                const char *list) {
    char line[4096];
    FILE *file = fopen(list, "r");
    if (file == NULL) {
        fprintf(stderr, "cannot read %s\n", list);
        return 2;
    }
    while (fgets(line, sizeof line, file) != NULL) {
        line[strcspn(line, "\r\n")] = '\0';
        if (line[0] == '\0') continue;
        fuzz_one(line, token, n_steps, dt, switch_vr);
        fflush(stdout);
    }
    fclose(file);
    return 0;
}

int main(int argc, char **argv) {
    void *lib;
    int status;
    if (argc < 7 || (strcmp(argv[4], "replay") == 0 && argc < 8) ||
        (strcmp(argv[4], "fuzz") == 0 && argc < 9)) {
        fprintf(stderr, "usage: %s LIBRARY RESOURCES TOKEN bench|check N_STEPS DT [REPEATS]\n"
                "       %s LIBRARY RESOURCES TOKEN replay N_STEPS DT SWITCH OUTPUT...\n"
                "       %s LIBRARY - TOKEN fuzz N_STEPS DT SWITCH LIST\n",
                argv[0], argv[0], argv[0]);
        return 2;
    }
    quiet = getenv("HARNESS_VERBOSE") == NULL;
    lib = open_library(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s: %s\n", argv[1], library_error());
        return 2;
    }
    load(lib);
    if (strcmp(argv[4], "bench") == 0)
        status = bench(argv[2], argv[3], atoi(argv[5]), atof(argv[6]),
                       argc > 7 ? atoi(argv[7]) : 20);
    else if (strcmp(argv[4], "fuzz") == 0)
        status = fuzz(argv[3], atoi(argv[5]), atof(argv[6]), argv[7], argv[8]);
    else if (strcmp(argv[4], "replay") == 0)
        status = replay(argv[2], argv[3], atoi(argv[5]), atof(argv[6]), argv[7], argv + 8,
                        argc - 8);
    else
        status = check(argv[2], argv[3], atoi(argv[5]), atof(argv[6]));
    close_library(lib);
    return status;
}
