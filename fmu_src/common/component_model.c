/* The model API functions every component shares, and the checks its own start with; see component_model.h. */
#include "model.h" /* the component folder's, on the include path */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MODEL_VARIABLE_TABLES /* this file holds the variable table (model_variables.h) */
#include "component_model.h"

static ComponentCore *core_of(Model *m) { return (ComponentCore *)(void *)m; }
static const ComponentCore *const_core_of(const Model *m) { return (const ComponentCore *)(const void *)m; }

const char *model_guid(void) { return MODEL_GUID; }

Model *model_new(void) {
    Model *m = (Model *)calloc(1, model_size());
    if (m) model_reset(m);
    return m;
}

void model_free(Model *m) { free(m); }

void model_reset(Model *m) {
    unsigned int vr;
    memset(m, 0, model_size());
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) core_of(m)->value[vr] = VARIABLES[vr].start;
}

unsigned int model_value_reference_count(void) { return N_VALUE_REFERENCES; }
int model_variable_type(unsigned int vr) { return vr < N_VALUE_REFERENCES ? MODEL_TYPE_REAL : -1; }
int model_variable_is_enumeration(unsigned int vr) {
    (void)vr;
    return 0;
}

int component_check_reference(unsigned int vr, char *message, size_t message_size) {
    if (vr < N_VALUE_REFERENCES) return 0;
    snprintf(message, message_size, "value reference %u is unknown (allowed: 0..%d)", vr, N_VALUE_REFERENCES - 1);
    return -1;
}

static int check_range(unsigned int vr, double value, char *message, size_t message_size) {
    const VariableInfo *v = &VARIABLES[vr];
    const int below = v->minimum_exclusive ? value <= v->minimum : value < v->minimum;
    if (!isfinite(value) || below || value > v->maximum) {
        snprintf(message, message_size, "%s = %g is not allowed: allowed values are %s", v->name, value, v->allowed);
        return -1;
    }
    return 0;
}

static int check_parameters(const ComponentCore *core, char *message, size_t message_size) {
    unsigned int vr;
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) {
        if (VARIABLES[vr].causality == CAUSALITY_PARAMETER && check_range(vr, core->value[vr], message, message_size))
            return -1;
    }
    return 0;
}

int component_set_real(Model *m, unsigned int vr, double value, char *message, size_t message_size) {
    if (component_check_reference(vr, message, message_size)) return -1;
    if (VARIABLES[vr].causality != CAUSALITY_PARAMETER && VARIABLES[vr].causality != CAUSALITY_INPUT) {
        snprintf(message, message_size, "%s is %s and cannot be set%s", VARIABLES[vr].name,
                 VARIABLES[vr].causality == CAUSALITY_OUTPUT ? "an output" : "a local variable",
                 VARIABLES[vr].state >= 0 ? " (Model Exchange sets the continuous states as a whole)" : "");
        return -1;
    }
    if (VARIABLES[vr].causality == CAUSALITY_PARAMETER && core_of(m)->initialized) {
        snprintf(message, message_size,
                 "%s is a fixed parameter: it can be set only before initialisation (reset the FMU first)",
                 VARIABLES[vr].name);
        return -1;
    }
    if (check_range(vr, value, message, message_size)) return -1;
    core_of(m)->value[vr] = value;
    return 0;
}

int model_set_integer(Model *m, unsigned int vr, int value, char *message, size_t message_size) {
    (void)m;
    (void)value;
    snprintf(message, message_size, "value reference %u: this FMU has no Integer variables", vr);
    return -1;
}

int model_get_integer(Model *m, unsigned int vr, int *value, char *message, size_t message_size) {
    (void)m;
    (void)value;
    snprintf(message, message_size, "value reference %u: this FMU has no Integer variables", vr);
    return -1;
}

int component_get_output_derivative(Model *m, unsigned int vr, int order, double *value, char *message,
                                    size_t message_size) {
    unsigned int derivative;
    if (component_check_reference(vr, message, message_size)) return -1;
    if (order == 1 && VARIABLES[vr].causality == CAUSALITY_OUTPUT && VARIABLES[vr].state >= 0) {
        for (derivative = 0; derivative < N_VALUE_REFERENCES; derivative++) {
            if (VARIABLES[derivative].derivative == VARIABLES[vr].state)
                return model_get_real(m, derivative, value, message, message_size);
        }
    }
    snprintf(message, message_size, "derivative of %s of order %d: allowed order 1 of the outputs that are "
             "continuous states", VARIABLES[vr].name, order);
    return -1;
}

int model_initialize(Model *m, double start_time, int stop_time_defined, double stop_time, char *message,
                     size_t message_size) {
    (void)stop_time_defined; /* a step never goes past the communication point it is asked for */
    (void)stop_time;
    if (check_parameters(core_of(m), message, message_size)) return -1;
    component_start(m);
    core_of(m)->time = start_time;
    core_of(m)->initialized = 1;
    return 0;
}

double model_time(const Model *m) { return const_core_of(m)->time; }

int model_has_failed(const Model *m) {
    (void)m;
    return 0; /* a step cannot fail: the parameters were checked at initialisation */
}

int model_check(const Model *m, char *message, size_t message_size) {
    const ComponentCore *core = const_core_of(m);
    unsigned int vr;
    if ((core->initialized != 0 && core->initialized != 1) ||
        (core->model_exchange != 0 && core->model_exchange != 1) || !isfinite(core->time)) {
        snprintf(message, message_size, "the state is corrupt: its flags or its time are out of range");
        return -1;
    }
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) {
        if (!isfinite(core->value[vr])) {
            snprintf(message, message_size, "the state is corrupt: %s is not finite", VARIABLES[vr].name);
            return -1;
        }
    }
    return core->initialized ? check_parameters(core, message, message_size) : 0;
}

int model_state_count(void) { return N_CONTINUOUS_STATES; }
int model_event_indicator_count(void) { return N_EVENT_INDICATORS; }

int model_exchange_begin(Model *m, char *message, size_t message_size) {
    (void)message;
    (void)message_size;
    core_of(m)->model_exchange = 1;
    return 0;
}

void model_set_time(Model *m, double time) { core_of(m)->time = time; }

static int check_size(size_t n, size_t expected, const char *what, char *message, size_t message_size) {
    if (n == expected) return 0;
    snprintf(message, message_size, "%s: %lu values given, the model has %lu", what, (unsigned long)n,
             (unsigned long)expected);
    return -1;
}

/* The continuous states and their derivatives are variables of the table, at their state and derivative indices. */
int model_get_states(const Model *m, double *x, size_t n, char *message, size_t message_size) {
    unsigned int vr;
    if (check_size(n, N_CONTINUOUS_STATES, "continuous states", message, message_size)) return -1;
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) {
        if (VARIABLES[vr].state >= 0) x[VARIABLES[vr].state] = const_core_of(m)->value[vr];
    }
    return 0;
}

int model_set_states(Model *m, const double *x, size_t n, char *message, size_t message_size) {
    unsigned int vr;
    if (check_size(n, N_CONTINUOUS_STATES, "continuous states", message, message_size)) return -1;
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) {
        if (VARIABLES[vr].state >= 0) core_of(m)->value[vr] = x[VARIABLES[vr].state];
    }
    return 0;
}

int model_get_derivatives(Model *m, double *dx, size_t n, char *message, size_t message_size) {
    unsigned int vr;
    if (check_size(n, N_CONTINUOUS_STATES, "derivatives", message, message_size)) return -1;
    for (vr = 0; vr < N_VALUE_REFERENCES; vr++) {
        if (VARIABLES[vr].derivative >= 0 &&
            model_get_real(m, vr, &dx[VARIABLES[vr].derivative], message, message_size))
            return -1;
    }
    return 0;
}

int model_get_event_indicators(const Model *m, double *z, size_t n, char *message, size_t message_size) {
    (void)m;
    (void)z;
    return check_size(n, N_EVENT_INDICATORS, "event indicators", message, message_size);
}

void model_event_update(Model *m, int *changed, int *next_event_time_defined, double *next_event_time) {
    (void)m;
    *changed = 0;
    *next_event_time_defined = 0;
    *next_event_time = 0.0;
}

int model_completed_point(Model *m) {
    (void)m;
    return 0; /* no discrete state can contradict the continuous ones */
}

int model_switch_lost_events(Model *m, char *message, size_t message_size) {
    (void)m;
    (void)message;
    (void)message_size;
    return 0; /* no discrete states to switch */
}

int model_terminated(const Model *m) {
    (void)m;
    return 0; /* a component never stops a run early */
}
