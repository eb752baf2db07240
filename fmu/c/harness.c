/* Test and benchmark harness for an exported jaxflex FMU (not shipped inside the FMU).
 *
 * Compile with -DHARNESS_FMI=2 or 3 and the FMI headers on the include path; it loads the
 * FMU's shared library (dlopen, or LoadLibrary when built for Windows) like an importer would.
 *
 *   harness LIBRARY RESOURCES TOKEN bench N_STEPS DT REPEATS
 *       time REPEATS instantiations and N_STEPS communication steps (inputs set and the
 *       deviation read every step); prints one JSON line
 *   harness LIBRARY RESOURCES TOKEN check N_STEPS DT
 *       exercise the life cycle (two instances, NaN input, bad step, reset and re-run,
 *       missing resources); exit status 0 when every expectation holds
 *   harness LIBRARY RESOURCES TOKEN replay N_STEPS DT SWITCH OUTPUT...
 *       set the Boolean parameter with value reference SWITCH true during initialization
 *       ("-": none; e.g. use_embedded_trajectory), take N_STEPS steps of DT without setting
 *       inputs and print, at the start and after every step, one line: the time and the
 *       OUTPUTs, each "rVR" (a Real/Float64), "rVRxN" (an FMI 3.0 array of N values) or
 *       "bVR" (a Boolean, printed 0/1); reals with 17 significant digits
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
#define VR_DEVIATION 10u
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
static struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2SetRealInputDerivativesTYPE *set_rates;
    fmi2GetBooleanTYPE *get_bool;
    fmi2SetBooleanTYPE *set_bool;
    fmi2DoStepTYPE *do_step;
    fmi2ResetTYPE *reset;
    fmi2TerminateTYPE *terminate;
} api;
static void load(void *lib) {
    api.instantiate = (fmi2InstantiateTYPE *)need(lib, "fmi2Instantiate");
    api.free_instance = (fmi2FreeInstanceTYPE *)need(lib, "fmi2FreeInstance");
    api.setup = (fmi2SetupExperimentTYPE *)need(lib, "fmi2SetupExperiment");
    api.enter_init = (fmi2EnterInitializationModeTYPE *)need(lib, "fmi2EnterInitializationMode");
    api.exit_init = (fmi2ExitInitializationModeTYPE *)need(lib, "fmi2ExitInitializationMode");
    api.set_real = (fmi2SetRealTYPE *)need(lib, "fmi2SetReal");
    api.get_real = (fmi2GetRealTYPE *)need(lib, "fmi2GetReal");
    api.set_rates = (fmi2SetRealInputDerivativesTYPE *)need(lib, "fmi2SetRealInputDerivatives");
    api.get_bool = (fmi2GetBooleanTYPE *)need(lib, "fmi2GetBoolean");
    api.set_bool = (fmi2SetBooleanTYPE *)need(lib, "fmi2SetBoolean");
    api.do_step = (fmi2DoStepTYPE *)need(lib, "fmi2DoStep");
    api.reset = (fmi2ResetTYPE *)need(lib, "fmi2Reset");
    api.terminate = (fmi2TerminateTYPE *)need(lib, "fmi2Terminate");
}
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
static int set_inputs(void *c, const double a[3], const double rate[3]) {
    static const fmi2ValueReference vr[3] = {VR_AX, VR_AX + 1, VR_AX + 2};
    static const fmi2Integer order[3] = {1, 1, 1};
    return api.set_real(c, vr, 3, a) || api.set_rates(c, vr, 3, order, rate);
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
static struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3EnterInitializationModeTYPE *enter_init;
    fmi3ExitInitializationModeTYPE *exit_init;
    fmi3SetFloat64TYPE *set_real;
    fmi3GetFloat64TYPE *get_real;
    fmi3GetBooleanTYPE *get_bool;
    fmi3SetBooleanTYPE *set_bool;
    fmi3DoStepTYPE *do_step;
    fmi3ResetTYPE *reset;
    fmi3TerminateTYPE *terminate;
} api;
static void load(void *lib) {
    api.instantiate = (fmi3InstantiateCoSimulationTYPE *)need(lib, "fmi3InstantiateCoSimulation");
    api.free_instance = (fmi3FreeInstanceTYPE *)need(lib, "fmi3FreeInstance");
    api.enter_init = (fmi3EnterInitializationModeTYPE *)need(lib, "fmi3EnterInitializationMode");
    api.exit_init = (fmi3ExitInitializationModeTYPE *)need(lib, "fmi3ExitInitializationMode");
    api.set_real = (fmi3SetFloat64TYPE *)need(lib, "fmi3SetFloat64");
    api.get_real = (fmi3GetFloat64TYPE *)need(lib, "fmi3GetFloat64");
    api.get_bool = (fmi3GetBooleanTYPE *)need(lib, "fmi3GetBoolean");
    api.set_bool = (fmi3SetBooleanTYPE *)need(lib, "fmi3SetBoolean");
    api.do_step = (fmi3DoStepTYPE *)need(lib, "fmi3DoStep");
    api.reset = (fmi3ResetTYPE *)need(lib, "fmi3Reset");
    api.terminate = (fmi3TerminateTYPE *)need(lib, "fmi3Terminate");
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
static int set_inputs(void *c, const double a[3], const double rate[3]) {
    static const fmi3ValueReference vr[3] = {VR_AX, VR_AX + 1, VR_AX + 2};
    (void)rate; /* FMI 3.0: inputs are held over the step */
    return api.set_real(c, vr, 3, a, 3);
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

/* A smooth rest-to-rest acceleration profile sampled at step k of n (m/s^2). */
static void profile(int k, int n, double a[3], double rate[3], double dt) {
    const double two_pi = 6.283185307179586;
    int c;
    for (c = 0; c < 3; ++c) {
        const double amp = 1.0 + c;
        double a0 = k < n ? amp * sin(two_pi * k / n) : 0.0;
        double a1 = k + 1 < n ? amp * sin(two_pi * (k + 1) / n) : 0.0;
        a[c] = a0;
        rate[c] = (a1 - a0) / dt;
    }
}

/* Run steps [k0, k1) of an n-step move from rest, storing the deviation after each step. */
static int run_steps(void *c, int k0, int k1, int n, double dt, double *out) {
    double a[3], rate[3];
    int k;
    for (k = k0; k < k1; ++k) {
        profile(k, n / 2, a, rate, dt);
        if (set_inputs(c, a, rate) || step(c, k * dt, dt)) return -1;
        out[k] = deviation(c);
    }
    return 0;
}

static int run(void *c, int n, double dt, double *out) { return run_steps(c, 0, n, n, dt, out); }

static int cmp_double(const void *x, const void *y) {
    const double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

#define CHUNK 100 /* steps timed together */

static int bench(const char *resources, const char *token, int n, double dt, int repeats) {
    const int n_chunks = n / CHUNK;
    double *times = (double *)malloc(sizeof(double) * (size_t)repeats);
    double *chunks = (double *)malloc(sizeof(double) * (size_t)n_chunks);
    double *dev = (double *)malloc(sizeof(double) * (size_t)n);
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
    if (c == NULL || start(c) || run(c, 200, dt, dev)) return 1; /* warm-up */
    reset(c);
    start(c);
    total = 0.0;
    for (k = 0; k < n_chunks; ++k) {
        t0 = now_us();
        if (run_steps(c, k * CHUNK, (k + 1) * CHUNK, n_chunks * CHUNK, dt, dev)) return 1;
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

int main(int argc, char **argv) {
    void *lib;
    int status;
    if (argc < 7 || (strcmp(argv[4], "replay") == 0 && argc < 8)) {
        fprintf(stderr, "usage: %s LIBRARY RESOURCES TOKEN bench|check N_STEPS DT [REPEATS]\n"
                "       %s LIBRARY RESOURCES TOKEN replay N_STEPS DT SWITCH OUTPUT...\n",
                argv[0], argv[0]);
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
    else if (strcmp(argv[4], "replay") == 0)
        status = replay(argv[2], argv[3], atoi(argv[5]), atof(argv[6]), argv[7], argv + 8,
                        argc - 8);
    else
        status = check(argv[2], argv[3], atoi(argv[5]), atof(argv[6]));
    close_library(lib);
    return status;
}
