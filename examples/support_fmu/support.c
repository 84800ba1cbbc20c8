/* BackplateSupport: a tiny FMI 2.0 co-simulation FMU, the body the backplate is mounted on.
 *
 * One mass on a spring and a damper to the ground, pushed by the force the lattice puts on its backplate:
 *
 *     m x'' = F - k x - c x'        F_support = k x + c x'  (the force passed on to what is behind)
 *
 * The input F is held over each communication step (what a co-simulation master gives it) and the step is
 * integrated with classic RK4 in substeps of at most `max_substep`. Value references:
 *   0 m, 1 k, 2 c, 3 max_substep (parameters), 4 F (input), 5 x, 6 v, 7 F_support (outputs).
 * Every FMI 2.0 function exists so that any importer can load it; the ones it has no use for refuse.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

enum { VR_M, VR_K, VR_C, VR_MAX_SUBSTEP, VR_F, VR_X, VR_V, VR_F_SUPPORT, N_VR };

typedef struct {
    double value[N_VR];
    double time;
    int initialized;
    fmi2CallbackFunctions callbacks;
    char name[64];
} Support;

#ifndef SUPPORT_GUID
#define SUPPORT_GUID "{b0d1e5a4-5c1b-4d7e-9f00-5a11e5ba0001}"
#endif

static const double START[N_VR] = {20.0, 2.0e4, 200.0, 1.0e-3, 0.0, 0.0, 0.0, 0.0};

static fmi2Status fail(Support *s, const char *message) {
    if (s && s->callbacks.logger) {
        s->callbacks.logger(s->callbacks.componentEnvironment, s->name, fmi2Error, "logStatusError", "%s", message);
    }
    return fmi2Error;
}

static void accelerations(const Support *s, double x, double v, double *dx, double *dv) {
    *dx = v;
    *dv = (s->value[VR_F] - s->value[VR_K] * x - s->value[VR_C] * v) / s->value[VR_M];
}

static void advance(Support *s, double h) {
    double x = s->value[VR_X], v = s->value[VR_V];
    double k1x, k1v, k2x, k2v, k3x, k3v, k4x, k4v;
    accelerations(s, x, v, &k1x, &k1v);
    accelerations(s, x + 0.5 * h * k1x, v + 0.5 * h * k1v, &k2x, &k2v);
    accelerations(s, x + 0.5 * h * k2x, v + 0.5 * h * k2v, &k3x, &k3v);
    accelerations(s, x + h * k3x, v + h * k3v, &k4x, &k4v);
    s->value[VR_X] = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    s->value[VR_V] = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
}

static void update_outputs(Support *s) {
    s->value[VR_F_SUPPORT] = s->value[VR_K] * s->value[VR_X] + s->value[VR_C] * s->value[VR_V];
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    (void)c;
    (void)on;
    (void)n;
    (void)categories;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *callbacks, fmi2Boolean visible, fmi2Boolean logging) {
    Support *s;
    (void)resources;
    (void)visible;
    (void)logging;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, SUPPORT_GUID) != 0) return NULL;
    s = (Support *)calloc(1, sizeof(Support));
    if (!s) return NULL;
    memcpy(s->value, START, sizeof(START));
    if (callbacks) s->callbacks = *callbacks;
    strncpy(s->name, name ? name : "", sizeof(s->name) - 1);
    return s;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDefined, fmi2Real stop) {
    (void)tolDefined;
    (void)tol;
    (void)stopDefined;
    (void)stop;
    ((Support *)c)->time = start;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Support *s = (Support *)c;
    if (!(s->value[VR_M] > 0.0) || s->value[VR_K] < 0.0 || s->value[VR_C] < 0.0 || !(s->value[VR_MAX_SUBSTEP] > 0.0)) {
        return fail(s, "m and max_substep must be > 0, k and c >= 0");
    }
    s->initialized = 1;
    update_outputs(s);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Support *s = (Support *)c;
    memcpy(s->value, START, sizeof(START));
    s->time = 0.0;
    s->initialized = 0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Support *s = (Support *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= N_VR) return fail(s, "unknown value reference");
        value[i] = s->value[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Support *s = (Support *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] > VR_F) return fail(s, "only m, k, c, max_substep and F can be set");
        if (vr[i] != VR_F && s->initialized) return fail(s, "parameters can be set only before initialisation");
        s->value[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Support *s = (Support *)c;
    int n, i;
    (void)noSetPrior;
    if (h < 0.0) return fail(s, "negative step");
    n = (int)ceil(h / s->value[VR_MAX_SUBSTEP] - 1e-9);
    if (n < 1) n = 1;
    for (i = 0; i < n; i++) advance(s, h / n);
    s->time = t + h;
    update_outputs(s);
    return fmi2OK;
}

/* Nothing else is provided: the functions exist so that importers find them. */
#define REFUSE(s) return fail((Support *)(s), "not provided by BackplateSupport")

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)vr;
    (void)v;
    if (n == 0) return fmi2OK;
    REFUSE(c);
}
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)state;
    REFUSE(c);
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    (void)state;
    REFUSE(c);
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)state;
    REFUSE(c);
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)state;
    (void)size;
    REFUSE(c);
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    (void)state;
    (void)bytes;
    (void)size;
    REFUSE(c);
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    (void)bytes;
    (void)size;
    (void)state;
    REFUSE(c);
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference k[], size_t nk, const fmi2Real dk[],
                                        fmi2Real du[]) {
    (void)u;
    (void)nu;
    (void)k;
    (void)nk;
    (void)dk;
    (void)du;
    REFUSE(c);
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[]) {
    (void)vr;
    (void)n;
    (void)order;
    (void)v;
    REFUSE(c);
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real v[]) {
    (void)vr;
    (void)n;
    (void)order;
    (void)v;
    REFUSE(c);
}
fmi2Status fmi2CancelStep(fmi2Component c) { REFUSE(c); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) {
    (void)k;
    (void)v;
    REFUSE(c);
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) {
    Support *s = (Support *)c;
    if (k == fmi2LastSuccessfulTime) {
        *v = s->time;
        return fmi2OK;
    }
    REFUSE(c);
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) {
    (void)k;
    (void)v;
    REFUSE(c);
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) {
    if (k == fmi2Terminated) {
        *v = fmi2False;
        return fmi2OK;
    }
    REFUSE(c);
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) {
    (void)k;
    (void)v;
    REFUSE(c);
}
