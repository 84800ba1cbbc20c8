/* The soak's native driver: loads an FMU's binary (dlopen, or LoadLibrary under Windows/Wine), instantiates it
 * once and runs the cycle of the FMU's life many times over (reset, set an order, initialise, step over the
 * horizon, read the outputs), printing the process's resident memory every so many cycles. No importer library
 * sits between it and the binary, so what grows is the FMU's.
 *
 * driver FMI(2|3) INTERFACE(cs|me) BINARY TOKEN RESOURCES STATES INDICATORS CYCLES SAMPLE_EVERY HORIZON
 *        ME_STEPS MATERIAL_VRS OUTPUT_VRS
 * (value references comma-separated; MATERIAL_VRS "VR*N" is one FMI 3 array of N values; the materials take the
 * permutations of 1..N, N = len(MATERIAL_VRS) for scalars, in turn).
 * Output lines: "rss CYCLE BYTES", then "done CYCLES FAILED_CALLS".
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#include <psapi.h>
#define LOAD(path) ((void *)LoadLibraryA(path))
#define SYMBOL(lib, name) ((void *)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#include <unistd.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYMBOL(lib, name) dlsym(lib, name)
#endif

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

static long failed_calls = 0;

static void check(int status, const char *call) {
    if (status > 1) { /* fmi2OK/fmi3OK 0, Warning 1 */
        if (failed_calls < 5) fprintf(stderr, "%s returned %d\n", call, status);
        failed_calls++;
    }
}

static unsigned long long resident_bytes(void) {
#ifdef _WIN32
    PROCESS_MEMORY_COUNTERS counters;
    if (!GetProcessMemoryInfo(GetCurrentProcess(), &counters, sizeof counters)) return 0;
    return (unsigned long long)counters.WorkingSetSize;
#else
    unsigned long long pages_total = 0, pages_resident = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (!f) return 0;
    if (fscanf(f, "%llu %llu", &pages_total, &pages_resident) != 2) pages_resident = 0;
    fclose(f);
    return pages_resident * (unsigned long long)sysconf(_SC_PAGESIZE);
#endif
}

static size_t parse_list(const char *text, unsigned int *out, size_t capacity) {
    size_t n = 0;
    const char *p = text;
    while (*p && n < capacity) {
        char *end;
        out[n++] = (unsigned int)strtoul(p, &end, 10);
        p = (*end == ',') ? end + 1 : end;
        if (end == p && *p) break;
    }
    return n;
}

/* The next permutation of order[0..n-1] in lexicographic order, wrapping round to the first. */
static void next_order(int *order, size_t n) {
    size_t i, j;
    if (n < 2) return;
    i = n - 1;
    while (i > 0 && order[i - 1] >= order[i]) i--;
    if (i == 0) {
        for (j = 0; j < n / 2; j++) { int t = order[j]; order[j] = order[n - 1 - j]; order[n - 1 - j] = t; }
        return;
    }
    j = n - 1;
    while (order[j] <= order[i - 1]) j--;
    { int t = order[i - 1]; order[i - 1] = order[j]; order[j] = t; }
    for (j = n - 1; i < j; i++, j--) { int t = order[i]; order[i] = order[j]; order[j] = t; }
}

static void *need(void *lib, const char *name) {
    void *f = SYMBOL(lib, name);
    if (!f) { fprintf(stderr, "the binary exports no %s\n", name); exit(3); }
    return f;
}

static void log_fmi2(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                 fmi2String message, ...) {
    (void)env; (void)instance; (void)category;
    if (status > fmi2Warning) fprintf(stderr, "FMU: %s\n", message);
}

static void log_fmi3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env; (void)category;
    if (status > fmi3Warning) fprintf(stderr, "FMU: %s\n", message);
}

int main(int argc, char **argv) {
    int fmi, model_exchange, *order;
    const char *binary, *token, *resources;
    size_t states, indicators, n_material_vrs, n_materials, n_outputs, k;
    const char *array_length;
    long cycles, sample_every, me_steps, cycle, step;
    double horizon, *x, *dx, *z, *outputs;
    unsigned int material_vrs[256], output_vrs[256];
    void *lib;

    if (argc != 14) {
        fprintf(stderr, "usage: %s FMI INTERFACE BINARY TOKEN RESOURCES STATES INDICATORS CYCLES SAMPLE_EVERY "
                        "HORIZON ME_STEPS MATERIAL_VRS OUTPUT_VRS\n", argv[0]);
        return 2;
    }
    fmi = atoi(argv[1]);
    model_exchange = strcmp(argv[2], "me") == 0;
    binary = argv[3]; token = argv[4]; resources = argv[5];
    states = (size_t)atol(argv[6]); indicators = (size_t)atol(argv[7]);
    cycles = atol(argv[8]); sample_every = atol(argv[9]); horizon = atof(argv[10]); me_steps = atol(argv[11]);
    n_material_vrs = parse_list(argv[12], material_vrs, 256);
    array_length = strchr(argv[12], '*');
    n_materials = array_length ? (size_t)atol(array_length + 1) : n_material_vrs;
    n_outputs = parse_list(argv[13], output_vrs, 256);
    if ((fmi != 2 && fmi != 3) || sample_every < 1 || me_steps < 1 || (array_length && fmi != 3) || n_materials < 1) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }

    order = calloc(n_materials, sizeof *order);
    x = calloc(states + 1, sizeof *x); dx = calloc(states + 1, sizeof *dx);
    z = calloc(indicators + 1, sizeof *z); outputs = calloc(n_outputs + 1, sizeof *outputs);
    for (k = 0; k < n_materials; k++) order[k] = (int)k + 1;

    lib = LOAD(binary);
    if (!lib) { fprintf(stderr, "cannot load %s\n", binary); return 3; }

    if (fmi == 2) {
        fmi2CallbackFunctions callbacks = {log_fmi2, calloc, free, NULL, NULL};
        fmi2InstantiateTYPE *instantiate = need(lib, "fmi2Instantiate");
        fmi2FreeInstanceTYPE *free_instance = need(lib, "fmi2FreeInstance");
        fmi2ResetTYPE *reset = need(lib, "fmi2Reset");
        fmi2SetIntegerTYPE *set_integer = need(lib, "fmi2SetInteger");
        fmi2SetupExperimentTYPE *setup = need(lib, "fmi2SetupExperiment");
        fmi2EnterInitializationModeTYPE *enter_init = need(lib, "fmi2EnterInitializationMode");
        fmi2ExitInitializationModeTYPE *exit_init = need(lib, "fmi2ExitInitializationMode");
        fmi2GetRealTYPE *get_real = need(lib, "fmi2GetReal");
        fmi2Component c = instantiate("soak", model_exchange ? fmi2ModelExchange : fmi2CoSimulation, token,
                                      resources, &callbacks, fmi2False, fmi2False);
        if (!c) { fprintf(stderr, "fmi2Instantiate failed\n"); return 4; }
        for (cycle = 0; cycle < cycles; cycle++) {
            if (cycle % sample_every == 0) printf("rss %ld %llu\n", cycle, resident_bytes());
            if (cycle > 0) check(reset(c), "fmi2Reset");
            check(set_integer(c, material_vrs, n_materials, order), "fmi2SetInteger");
            check(setup(c, fmi2False, 0.0, 0.0, fmi2True, horizon), "fmi2SetupExperiment");
            check(enter_init(c), "fmi2EnterInitializationMode");
            check(exit_init(c), "fmi2ExitInitializationMode");
            if (!model_exchange) {
                fmi2DoStepTYPE *do_step = need(lib, "fmi2DoStep");
                check(do_step(c, 0.0, horizon, fmi2True), "fmi2DoStep");
            } else {
                fmi2NewDiscreteStatesTYPE *new_states = need(lib, "fmi2NewDiscreteStates");
                fmi2EnterContinuousTimeModeTYPE *continuous = need(lib, "fmi2EnterContinuousTimeMode");
                fmi2EnterEventModeTYPE *event_mode = need(lib, "fmi2EnterEventMode");
                fmi2GetContinuousStatesTYPE *get_states = need(lib, "fmi2GetContinuousStates");
                fmi2SetContinuousStatesTYPE *set_states = need(lib, "fmi2SetContinuousStates");
                fmi2GetDerivativesTYPE *derivatives = need(lib, "fmi2GetDerivatives");
                fmi2GetEventIndicatorsTYPE *get_indicators = need(lib, "fmi2GetEventIndicators");
                fmi2SetTimeTYPE *set_time = need(lib, "fmi2SetTime");
                fmi2CompletedIntegratorStepTYPE *completed = need(lib, "fmi2CompletedIntegratorStep");
                fmi2EventInfo info;
                double h = horizon / (double)me_steps;
                memset(&info, 0, sizeof info);
                info.newDiscreteStatesNeeded = fmi2True;
                while (info.newDiscreteStatesNeeded && !info.terminateSimulation)
                    check(new_states(c, &info), "fmi2NewDiscreteStates");
                check(continuous(c), "fmi2EnterContinuousTimeMode");
                check(get_states(c, x, states), "fmi2GetContinuousStates");
                for (step = 1; step <= me_steps; step++) {
                    fmi2Boolean enter_event = fmi2False, terminate = fmi2False;
                    check(derivatives(c, dx, states), "fmi2GetDerivatives");
                    for (k = 0; k < states; k++) x[k] += h * dx[k]; /* explicit Euler: the path, not the physics */
                    check(set_time(c, h * (double)step), "fmi2SetTime");
                    check(set_states(c, x, states), "fmi2SetContinuousStates");
                    if (indicators) check(get_indicators(c, z, indicators), "fmi2GetEventIndicators");
                    check(completed(c, fmi2True, &enter_event, &terminate), "fmi2CompletedIntegratorStep");
                    if (enter_event) {
                        check(event_mode(c), "fmi2EnterEventMode");
                        info.newDiscreteStatesNeeded = fmi2True;
                        while (info.newDiscreteStatesNeeded && !info.terminateSimulation)
                            check(new_states(c, &info), "fmi2NewDiscreteStates");
                        check(continuous(c), "fmi2EnterContinuousTimeMode");
                    }
                }
            }
            check(get_real(c, output_vrs, n_outputs, outputs), "fmi2GetReal");
            next_order(order, n_materials);
        }
        free_instance(c);
    } else {
        fmi3ResetTYPE *reset = need(lib, "fmi3Reset");
        fmi3FreeInstanceTYPE *free_instance = need(lib, "fmi3FreeInstance");
        fmi3SetInt32TYPE *set_int32 = need(lib, "fmi3SetInt32");
        fmi3EnterInitializationModeTYPE *enter_init = need(lib, "fmi3EnterInitializationMode");
        fmi3ExitInitializationModeTYPE *exit_init = need(lib, "fmi3ExitInitializationMode");
        fmi3GetFloat64TYPE *get_float64 = need(lib, "fmi3GetFloat64");
        fmi3Instance c;
        if (model_exchange) {
            fmi3InstantiateModelExchangeTYPE *instantiate = need(lib, "fmi3InstantiateModelExchange");
            c = instantiate("soak", token, resources, fmi3False, fmi3False, NULL, log_fmi3);
        } else {
            fmi3InstantiateCoSimulationTYPE *instantiate = need(lib, "fmi3InstantiateCoSimulation");
            c = instantiate("soak", token, resources, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                            log_fmi3, NULL);
        }
        if (!c) { fprintf(stderr, "fmi3Instantiate failed\n"); return 4; }
        for (cycle = 0; cycle < cycles; cycle++) {
            if (cycle % sample_every == 0) printf("rss %ld %llu\n", cycle, resident_bytes());
            if (cycle > 0) check(reset(c), "fmi3Reset");
            check(set_int32(c, material_vrs, n_material_vrs, order, n_materials), "fmi3SetInt32");
            check(enter_init(c, fmi3False, 0.0, 0.0, fmi3True, horizon), "fmi3EnterInitializationMode");
            check(exit_init(c), "fmi3ExitInitializationMode");
            if (!model_exchange) {
                fmi3DoStepTYPE *do_step = need(lib, "fmi3DoStep");
                fmi3Boolean event_needed, terminate, early;
                fmi3Float64 last;
                check(do_step(c, 0.0, horizon, fmi3True, &event_needed, &terminate, &early, &last), "fmi3DoStep");
            } else {
                fmi3UpdateDiscreteStatesTYPE *update = need(lib, "fmi3UpdateDiscreteStates");
                fmi3EnterContinuousTimeModeTYPE *continuous = need(lib, "fmi3EnterContinuousTimeMode");
                fmi3EnterEventModeTYPE *event_mode = need(lib, "fmi3EnterEventMode");
                fmi3GetContinuousStatesTYPE *get_states = need(lib, "fmi3GetContinuousStates");
                fmi3SetContinuousStatesTYPE *set_states = need(lib, "fmi3SetContinuousStates");
                fmi3GetContinuousStateDerivativesTYPE *derivatives = need(lib, "fmi3GetContinuousStateDerivatives");
                fmi3GetEventIndicatorsTYPE *get_indicators = need(lib, "fmi3GetEventIndicators");
                fmi3SetTimeTYPE *set_time = need(lib, "fmi3SetTime");
                fmi3CompletedIntegratorStepTYPE *completed = need(lib, "fmi3CompletedIntegratorStep");
                fmi3Boolean needs_update = fmi3True, terminate = fmi3False, nominals, values, time_defined;
                fmi3Float64 next_time;
                double h = horizon / (double)me_steps;
                while (needs_update && !terminate)
                    check(update(c, &needs_update, &terminate, &nominals, &values, &time_defined, &next_time),
                          "fmi3UpdateDiscreteStates");
                check(continuous(c), "fmi3EnterContinuousTimeMode");
                check(get_states(c, x, states), "fmi3GetContinuousStates");
                for (step = 1; step <= me_steps; step++) {
                    fmi3Boolean enter_event = fmi3False;
                    check(derivatives(c, dx, states), "fmi3GetContinuousStateDerivatives");
                    for (k = 0; k < states; k++) x[k] += h * dx[k]; /* explicit Euler: the path, not the physics */
                    check(set_time(c, h * (double)step), "fmi3SetTime");
                    check(set_states(c, x, states), "fmi3SetContinuousStates");
                    if (indicators) check(get_indicators(c, z, indicators), "fmi3GetEventIndicators");
                    check(completed(c, fmi3True, &enter_event, &terminate), "fmi3CompletedIntegratorStep");
                    if (enter_event) {
                        check(event_mode(c), "fmi3EnterEventMode");
                        needs_update = fmi3True;
                        while (needs_update && !terminate)
                            check(update(c, &needs_update, &terminate, &nominals, &values, &time_defined,
                                         &next_time), "fmi3UpdateDiscreteStates");
                        check(continuous(c), "fmi3EnterContinuousTimeMode");
                    }
                }
            }
            check(get_float64(c, output_vrs, n_outputs, outputs, n_outputs), "fmi3GetFloat64");
            next_order(order, n_materials);
        }
        free_instance(c);
    }
    printf("rss %ld %llu\n", cycles, resident_bytes());
    printf("done %ld %ld\n", cycles, failed_calls);
    free(order); free(x); free(dx); free(z); free(outputs);
    return failed_calls ? 1 : 0;
}
