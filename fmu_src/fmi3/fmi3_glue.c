/* FMI 3.0 glue, Co-Simulation and Model Exchange: the FMI 3 state machine, logging and FMU states over the model
 * API.
 *
 * Like fmi2/fmi2_glue.c it knows nothing of springs: every model question goes through the model folder's
 * model.h (Model Exchange hands the importer the model's continuous-time contract). What FMI 3 adds here:
 * - a parameter array (material, k, ..., mass) is one FMI 3 array: one value reference moves all its values, so
 *   nValues counts values, not value references. Every other variable is a scalar.
 * - a value reference is the variable's 1-based position in modelDescription.xml (builder/fmi3_description.py),
 *   where importers that read `derivative` as an index look for a state; the generated fmi3_variables.h says
 *   which of the model's value references each array moves (model_range).
 * - the independent variable `time` (FMI 3 requires one): the value reference after the model's variables.
 * - Real is Float64, Integer Int32 and an enumeration Int64; every other FMI 3 type is refused (the FMU has
 *   none).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmi3_variables.h" /* generated: the FMI 3 arrays */
#include "instance.h" /* and through it the model folder's model.h */
#include "refused_calls.h"
#include "state_masks.h"

#define MESSAGE_SIZE 1024
#define STATE_MAGIC 0x4d534c33u /* "MSL3": marks a serialised state of this FMU */

typedef struct {
    InstanceCommon common; /* model, FMI state, experiment: kept alike by both FMI versions */
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment environment;
    int logging_on;
    int early_return_allowed; /* fmi3DoStep may stop before the step's end (the model's limit) */
} Instance;

static void log_message(const Instance *instance, fmi3Status status, const char *category, const char *format,
                        ...) {
    char message[MESSAGE_SIZE];
    va_list args;
    if (!instance || !instance->logger) return;
    if (status == fmi3OK && !instance->logging_on) return;
    va_start(args, format);
    vsnprintf(message, sizeof(message), format, args);
    va_end(args);
    instance->logger(instance->environment, status, category, message);
}

static fmi3Status error(Instance *instance, const char *function, const char *message) {
    log_message(instance, fmi3Error, "logStatusError", "%s: %s", function, message);
    return fmi3Error;
}


/* Refuses calls the FMI 3.0 state machine does not allow in the current state, naming that state. */
static int allowed(Instance *instance, const char *function, unsigned int states) {
    static const char *names[] = {"instantiated", "initialization mode", "step mode", "terminated", "error",
                                  "step mode, stopped", "event mode", "continuous-time mode"}; /* by InstanceState */
    char message[MESSAGE_SIZE];
    if (!instance) return 0;
    if (states & (1u << instance->common.state)) return 1;
    if (instance->common.state == STATE_ERROR) {
        error(instance, function, "the instance is in the error state: only fmi3Reset and fmi3FreeInstance are allowed");
        return 0;
    }
    snprintf(message, sizeof(message), "not allowed in the current state of the instance (%s, %s)",
             instance->common.model_exchange ? "Model Exchange" : "Co-Simulation", names[instance->common.state]);
    error(instance, function, message);
    return 0;
}

/* 1 when `function` may be called in the instance's state (its MASK_ in state_masks.h), else 0, logged. */
#define CHECK_STATE(function) allowed(instance, #function, MASK_##function)

#define VR_OFFSET 1u /* FMI 3 value reference = the 1-based position in modelDescription.xml */

/* The value reference of `time`: the one after the model's variables. */
static fmi3ValueReference time_reference(void) { return (fmi3ValueReference)FMI3_VARIABLE_COUNT + VR_OFFSET; }

/* The model's value references the FMI 3 value reference vr moves: *first and how many (an array's length, or 1
 * for a scalar); 0 for a value reference that is no model variable. A scalar is the model's value reference after
 * those of every array declared before it. */
static unsigned int model_range(fmi3ValueReference vr, unsigned int *first) {
    unsigned int skipped = 0, i;
    if (vr < VR_OFFSET || vr >= time_reference()) return 0;
    for (i = 0; FMI3_ARRAYS[i].length != 0u && FMI3_ARRAYS[i].reference <= vr; i++) {
        if (FMI3_ARRAYS[i].reference == vr) {
            *first = FMI3_ARRAYS[i].first;
            return FMI3_ARRAYS[i].length;
        }
        skipped += FMI3_ARRAYS[i].length - 1u;
    }
    *first = vr - VR_OFFSET + skipped;
    return 1;
}

/* What a variable is moved as: Float64 (MODEL_TYPE_REAL), Int32 (MODEL_TYPE_INTEGER) or, for an Integer
 * declared as an enumeration, Int64 (FMI 3 moves enumerations with fmi3GetInt64 and fmi3SetInt64); -1 for a
 * value reference that is no model variable. */
#define KIND_ENUMERATION 2
static int kind_of(fmi3ValueReference vr) {
    unsigned int first = 0;
    if (model_range(vr, &first) == 0) return -1;
    return model_variable_is_enumeration(first) ? KIND_ENUMERATION : model_variable_type(first);
}

/* Checks a get or set call's value references (each a variable of the type, or `time` where allowed) and that
 * nValues is the number of values they move (an array's length for an array, 1 for a scalar). */
static int check_values(Instance *instance, const char *function, const fmi3ValueReference vr[], size_t nvr,
                        size_t nValues, int type, int time_allowed) {
    static const char *kinds[] = {"a Float64", "an Int32", "an Enumeration (Int64)"};
    char message[MESSAGE_SIZE];
    const fmi3ValueReference time_vr = time_reference();
    size_t i, values = 0;
    unsigned int first = 0;
    for (i = 0; i < nvr; i++) {
        const int kind = kind_of(vr[i]);
        if (vr[i] == time_vr && time_allowed) {
            values += 1;
            continue;
        }
        if (vr[i] == time_vr || kind < 0) {
            snprintf(message, sizeof(message), vr[i] == time_vr ? "value reference %u is time, not %s variable"
                                                                : "value reference %u is not %s variable of this FMU",
                     vr[i], kinds[type]);
            error(instance, function, message);
            return -1;
        }
        if (kind != type) {
            snprintf(message, sizeof(message), "value reference %u is not %s variable", vr[i], kinds[type]);
            error(instance, function, message);
            return -1;
        }
        values += model_range(vr[i], &first);
    }
    if (nValues != values) {
        snprintf(message, sizeof(message),
                 "nValues is %lu but the %lu value references move %lu values (an array all its elements)",
                 (unsigned long)nValues, (unsigned long)nvr, (unsigned long)values);
        error(instance, function, message);
        return -1;
    }
    return 0;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    Instance *instance = (Instance *)c;
    (void)nCategories;
    (void)categories;
    if (!instance) return fmi3Error;
    instance->logging_on = loggingOn;
    return fmi3OK;
}

/* A new instance after the token check, or NULL (the reason logged through the importer's logger). */
static Instance *instantiate(const char *function, fmi3String instanceName, fmi3String instantiationToken,
                             fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                             fmi3LogMessageCallback logMessage, int model_exchange) {
    Instance probe, *instance;
    char message[MESSAGE_SIZE];
    memset(&probe, 0, sizeof(probe));
    probe.logger = logMessage;
    probe.environment = instanceEnvironment;
    probe.common.instance_name = (char *)(instanceName ? instanceName : "");
    if (instance_check_token(instantiationToken, "instantiation token", message, sizeof(message))) {
        error(&probe, function, message);
        return NULL;
    }
    instance = (Instance *)calloc(1, sizeof(Instance));
    if (!instance) return NULL;
    if (instance_open(&instance->common, probe.common.instance_name)) {
        free(instance);
        return NULL;
    }
    instance->common.model_exchange = model_exchange;
    instance->logger = probe.logger;
    instance->environment = probe.environment;
    instance->logging_on = loggingOn;
    return instance;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath;
    (void)visible;
    return instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, loggingOn,
                       instanceEnvironment, logMessage, 1);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    Instance *instance;
    if (eventModeUsed) {
        Instance probe;
        memset(&probe, 0, sizeof(probe));
        probe.logger = logMessage;
        probe.environment = instanceEnvironment;
        probe.common.instance_name = (char *)(instanceName ? instanceName : "");
        error(&probe, "fmi3InstantiateCoSimulation", "this FMU has no event mode (hasEventMode=\"false\")");
        return NULL;
    }
    instance = instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, loggingOn,
                           instanceEnvironment, logMessage, 0);
    if (instance) instance->early_return_allowed = earlyReturnAllowed;
    return instance;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    Instance probe;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    memset(&probe, 0, sizeof(probe));
    probe.logger = logMessage;
    probe.environment = instanceEnvironment;
    probe.common.instance_name = (char *)(instanceName ? instanceName : "");
    error(&probe, "fmi3InstantiateScheduledExecution", "this FMU supports Model Exchange and Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    if (!instance) return;
    instance_close(&instance->common);
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Instance *instance = (Instance *)c;
    (void)toleranceDefined; /* the solver's tolerances are the parameters rtol and atol */
    (void)tolerance;
    if (!CHECK_STATE(fmi3EnterInitializationMode)) return fmi3Error;
    instance->common.start_time = startTime;
    instance->common.stop_time_defined = stopTimeDefined;
    instance->common.stop_time = stopTime;
    instance->common.state = STATE_INITIALIZATION_MODE;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3ExitInitializationMode)) return fmi3Error;
    if (instance_initialize(&instance->common, message, sizeof(message))) {
        return error(instance, "fmi3ExitInitializationMode", message);
    }
    return fmi3OK;
}

/* Event mode is Model Exchange's only (the co-simulation interface has hasEventMode="false"). */

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi3EnterEventMode)) return fmi3Error;
    instance->common.state = STATE_EVENT_MODE;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi3Terminate)) return fmi3Error;
    instance->common.state = STATE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi3Error;
    instance_reset(&instance->common);
    return fmi3OK;
}

/* Float64, Int32 and Int64: the model's Real and Integer variables (and its enumerations as Int64); each value
 * reference moves its values (model_range) in order into values[], which check_values has sized. */
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    const fmi3ValueReference time_vr = time_reference();
    size_t i, at = 0;
    unsigned int first = 0, length, e;
    if (!CHECK_STATE(fmi3GetFloat64)) return fmi3Error;
    if (check_values(instance, "fmi3GetFloat64", vr, nvr, nValues, MODEL_TYPE_REAL, 1)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == time_vr) {
            values[at++] = model_time(instance->common.model);
            continue;
        }
        length = model_range(vr[i], &first);
        for (e = 0; e < length; e++) {
            if (model_get_real(instance->common.model, first + e, &values[at++], message, sizeof(message))) {
                return error(instance, "fmi3GetFloat64", message);
            }
        }
    }
    return fmi3OK;
}

/* The model's integer (or enumeration) at the e-th value reference vr moves, read into value; 0, or -1 when the
 * model refused (the reason logged). */
static int get_integer(Instance *instance, const char *function, fmi3ValueReference vr, unsigned int e, int *value) {
    char message[MESSAGE_SIZE];
    unsigned int first = 0;
    model_range(vr, &first);
    if (model_get_integer(instance->common.model, first + e, value, message, sizeof(message))) {
        error(instance, function, message);
        return -1;
    }
    return 0;
}

/* The model's integer at the e-th value reference vr moves set to value; 0, or -1 when the model refused. */
static int set_integer(Instance *instance, const char *function, fmi3ValueReference vr, unsigned int e, int value) {
    char message[MESSAGE_SIZE];
    unsigned int first = 0;
    model_range(vr, &first);
    if (model_set_integer(instance->common.model, first + e, value, message, sizeof(message))) {
        error(instance, function, message);
        return -1;
    }
    return 0;
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
    Instance *instance = (Instance *)c;
    size_t i, at = 0;
    unsigned int first = 0, length, e;
    int value;
    if (!CHECK_STATE(fmi3GetInt32)) return fmi3Error;
    if (check_values(instance, "fmi3GetInt32", vr, nvr, nValues, MODEL_TYPE_INTEGER, 0)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        length = model_range(vr[i], &first);
        for (e = 0; e < length; e++) {
            if (get_integer(instance, "fmi3GetInt32", vr[i], e, &value)) return fmi3Error;
            values[at++] = (fmi3Int32)value;
        }
    }
    return fmi3OK;
}

/* Setting: parameters before or during initialisation only (the model says why it refuses). */
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    const fmi3ValueReference time_vr = time_reference();
    size_t i, at = 0;
    unsigned int first = 0, length, e;
    if (!CHECK_STATE(fmi3SetFloat64)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == time_vr) {
            return error(instance, "fmi3SetFloat64", "time is the independent variable: it cannot be set");
        }
    }
    if (check_values(instance, "fmi3SetFloat64", vr, nvr, nValues, MODEL_TYPE_REAL, 0)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        length = model_range(vr[i], &first);
        for (e = 0; e < length; e++) {
            if (model_set_real(instance->common.model, first + e, values[at++], message, sizeof(message))) {
                return error(instance, "fmi3SetFloat64", message);
            }
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
    Instance *instance = (Instance *)c;
    size_t i, at = 0;
    unsigned int first = 0, length, e;
    if (!CHECK_STATE(fmi3SetInt32)) return fmi3Error;
    if (check_values(instance, "fmi3SetInt32", vr, nvr, nValues, MODEL_TYPE_INTEGER, 0)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        length = model_range(vr[i], &first);
        for (e = 0; e < length; e++) {
            if (set_integer(instance, "fmi3SetInt32", vr[i], e, (int)values[at++])) return fmi3Error;
        }
    }
    return fmi3OK;
}

/* Int64: the enumerations (diagonal_rule, solver), kept by the model as Integers (scalars, never arrays). */
fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int64 values[],
                        size_t nValues) {
    Instance *instance = (Instance *)c;
    size_t i;
    int value;
    if (!CHECK_STATE(fmi3GetInt64)) return fmi3Error;
    if (check_values(instance, "fmi3GetInt64", vr, nvr, nValues, KIND_ENUMERATION, 0)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        if (get_integer(instance, "fmi3GetInt64", vr[i], 0, &value)) return fmi3Error;
        values[i] = (fmi3Int64)value;
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int64 values[],
                        size_t nValues) {
    Instance *instance = (Instance *)c;
    size_t i;
    if (!CHECK_STATE(fmi3SetInt64)) return fmi3Error;
    if (check_values(instance, "fmi3SetInt64", vr, nvr, nValues, KIND_ENUMERATION, 0)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        /* a value beyond Int32 is beyond every enumeration's items: the model refuses it with their names */
        const int value = values[i] > 1000000 ? 1000000 : values[i] < -1000000 ? -1000000 : (int)values[i];
        if (set_integer(instance, "fmi3SetInt64", vr[i], 0, value)) return fmi3Error;
    }
    return fmi3OK;
}

/* The calls this FMU refuses (common/refused_calls.h), each written by one of these three macros. `ignored`
 * takes a refused call's parameters, so that none of them is unused. */
static void ignored(fmi3Instance c, ...) { (void)c; }

#define REFUSED(function, parameters, names, reason)    \
    fmi3Status function parameters {                    \
        ignored names;                                  \
        return error((Instance *)c, #function, reason); \
    }

#define REFUSED_UNLESS_EMPTY(function, parameters, names, reason)           \
    fmi3Status function parameters {                                        \
        ignored names;                                                      \
        return nvr == 0 ? fmi3OK : error((Instance *)c, #function, reason); \
    }

#define NO_VARIABLES_OF_TYPE(function, parameters, names, type_name)                                      \
    fmi3Status function parameters {                                                                      \
        Instance *instance = (Instance *)c;                                                               \
        ignored names;                                                                                    \
        if (!CHECK_STATE(function)) return fmi3Error;                                                     \
        return nvr == 0 ? fmi3OK : error(instance, #function, "this FMU has no " type_name " variables"); \
    }

FMI3_REFUSED_CALLS

/* FMU states: a flat copy of the common fields and the model (the model holds no pointers); common/instance.c
 * does the work. */
static fmi3Status outcome(Instance *instance, const char *function, const char *failure) {
    return failure ? error(instance, function, failure) : fmi3OK;
}

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi3GetFMUState)) return fmi3Error;
    return outcome(instance, "fmi3GetFMUState", instance_get_state(&instance->common, STATE_MAGIC, FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi3SetFMUState)) return fmi3Error;
    return outcome(instance, "fmi3SetFMUState", instance_set_state(&instance->common, STATE_MAGIC, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    (void)c;
    instance_free_state(FMUState);
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t *size) {
    (void)c;
    (void)FMUState;
    *size = instance_saved_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi3Error;
    return outcome(instance, "fmi3SerializeFMUState",
                   instance_serialize_state(FMUState, (unsigned char *)serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi3Error;
    return outcome(instance, "fmi3DeserializeFMUState",
                   instance_deserialize_state(&instance->common, STATE_MAGIC,
                                              (const unsigned char *)serializedState, size, FMUState));
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    Instance *instance = (Instance *)c;
    int changed, next_defined = 0;
    double next_time = 0.0;
    if (!CHECK_STATE(fmi3UpdateDiscreteStates)) return fmi3Error;
    model_event_update(instance->common.model, &changed, &next_defined, &next_time);
    /* one update reaches the new modes (they follow from the state, the load from the time): no iteration.
     * The states never jump, but where a mode switched the forces do: valuesOfContinuousStatesChanged makes
     * every importer restart its integrator here (fmi2_glue.c says why). */
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = changed ? fmi3True : fmi3False;
    if (nextEventTimeDefined) *nextEventTimeDefined = next_defined ? fmi3True : fmi3False;
    if (nextEventTime) *nextEventTime = next_time;
    return fmi3OK;
}

/* Model Exchange: the importer integrates the model's contract (model.h). */
static fmi3Status model_outcome(Instance *instance, const char *function, int failed, const char *message) {
    return failed ? error(instance, function, message) : fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi3EnterContinuousTimeMode)) return fmi3Error;
    instance->common.state = STATE_CONTINUOUS_TIME;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    Instance *instance = (Instance *)c;
    int event;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!CHECK_STATE(fmi3CompletedIntegratorStep)) return fmi3Error;
    /* a discrete state contradicting the continuous ones: a switch the importer did not handle, ask for an event */
    event = model_completed_point(instance->common.model);
    if (enterEventMode) *enterEventMode = event ? fmi3True : fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3SetTime)) return fmi3Error;
    return model_outcome(instance, "fmi3SetTime",
                         instance_set_time(&instance->common, time, message, sizeof(message)), message);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 continuousStates[], size_t nContinuousStates) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3SetContinuousStates)) return fmi3Error;
    if (!continuousStates) return error(instance, "fmi3SetContinuousStates", "continuousStates is NULL");
    return model_outcome(instance, "fmi3SetContinuousStates",
                         model_set_states(instance->common.model, continuousStates, nContinuousStates, message,
                                          sizeof(message)),
                         message);
}

/* An importer that goes on in continuous-time mode after fmi3CompletedIntegratorStep asked for event mode: the
 * model switches the contradicting discrete states itself and says so (fmi3Warning). 1 when it did. */
static int lost_events_switched(Instance *instance) {
    char message[MESSAGE_SIZE];
    if (!instance_switch_lost_events(&instance->common, message, sizeof(message))) return 0;
    log_message(instance, fmi3Warning, "logStatusWarning", "fmi3GetContinuousStateDerivatives: %s", message);
    return 1;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t nContinuousStates) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3GetContinuousStateDerivatives)) return fmi3Error;
    if (!derivatives) return error(instance, "fmi3GetContinuousStateDerivatives", "derivatives is NULL");
    if (model_get_derivatives(instance->common.model, derivatives, nContinuousStates, message, sizeof(message))) {
        return error(instance, "fmi3GetContinuousStateDerivatives", message);
    }
    return lost_events_switched(instance) ? fmi3Warning : fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3GetEventIndicators)) return fmi3Error;
    if (!eventIndicators && nEventIndicators > 0) {
        return error(instance, "fmi3GetEventIndicators", "eventIndicators is NULL");
    }
    return model_outcome(instance, "fmi3GetEventIndicators",
                         model_get_event_indicators(instance->common.model, eventIndicators, nEventIndicators,
                                                    message, sizeof(message)),
                         message);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi3GetContinuousStates)) return fmi3Error;
    if (!continuousStates) return error(instance, "fmi3GetContinuousStates", "continuousStates is NULL");
    return model_outcome(instance, "fmi3GetContinuousStates",
                         model_get_states(instance->common.model, continuousStates, nContinuousStates, message,
                                          sizeof(message)),
                         message);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nContinuousStates) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi3GetNominalsOfContinuousStates)) return fmi3Error;
    if (!nominals) return error(instance, "fmi3GetNominalsOfContinuousStates", "nominals is NULL");
    if (nContinuousStates != (size_t)model_state_count()) {
        snprintf(message, sizeof(message), "%lu nominals asked for, but this FMU has %d continuous states",
                 (unsigned long)nContinuousStates, model_state_count());
        return error(instance, "fmi3GetNominalsOfContinuousStates", message);
    }
    for (i = 0; i < nContinuousStates; i++) nominals[i] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *nEventIndicators) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi3Error;
    *nEventIndicators = (size_t)model_event_indicator_count();
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *nContinuousStates) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi3Error;
    *nContinuousStates = (size_t)model_state_count();
    return fmi3OK;
}

/* Co-simulation. */
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    Instance *instance = (Instance *)c;
    /* only reached from event mode, which this FMU does not have; step mode is already on after init */
    if (!CHECK_STATE(fmi3EnterStepMode)) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi3GetOutputDerivatives)) return fmi3Error;
    if (nValues != nvr) return error(instance, "fmi3GetOutputDerivatives", "nValues must equal nValueReferences");
    for (i = 0; i < nvr; i++) {
        unsigned int first = 0;
        const unsigned int length = model_range(vr[i], &first);
        if (length != 1 ||
            model_get_output_derivative(instance->common.model, first, orders[i], &values[i], message,
                                        sizeof(message))) {
            if (length != 1) snprintf(message, sizeof(message), "value reference %u is no scalar variable", vr[i]);
            return error(instance, "fmi3GetOutputDerivatives", message);
        }
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    int status;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (!CHECK_STATE(fmi3DoStep)) return fmi3Error;
    if (lastSuccessfulTime) *lastSuccessfulTime = model_time(instance->common.model);
    status = instance_do_step(&instance->common, currentCommunicationPoint, communicationStepSize, message,
                              sizeof(message));
    if (lastSuccessfulTime) *lastSuccessfulTime = model_time(instance->common.model);
    if (status == MODEL_LIMIT_REACHED) {
        /* the model asks to stop the run early: an early return when the importer allows one, else the
         * step counts as discarded after lastSuccessfulTime; either way terminateSimulation */
        if (terminateSimulation) *terminateSimulation = fmi3True;
        if (instance->early_return_allowed) {
            if (earlyReturn) *earlyReturn = fmi3True;
            log_message(instance, fmi3OK, "logStatusDiscard", "fmi3DoStep: %s", message);
            return fmi3OK;
        }
        log_message(instance, fmi3Discard, "logStatusDiscard", "fmi3DoStep: %s", message);
        return fmi3Discard;
    }
    if (status) return error(instance, "fmi3DoStep", message);
    return fmi3OK;
}
