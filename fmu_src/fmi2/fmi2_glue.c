/* FMI 2.0 glue, Co-Simulation and Model Exchange: the FMI state machine, logging and FMU states over the
 * model API.
 *
 * It knows nothing of springs: every model question goes through the model folder's model.h, found on the
 * include path (builder/sources.py), as the Reference FMUs keep one shared FMI glue beside each model's own
 * folder. Model Exchange hands the importer the model's
 * continuous-time contract (states, derivatives, event indicators, event update); Co-Simulation lets the
 * model integrate that same contract itself.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "instance.h" /* and through it the model folder's model.h */
#include "refused_calls.h"
#include "state_masks.h"

#define MESSAGE_SIZE 1024
#define STATE_MAGIC 0x4d534c32u /* "MSL2": marks a serialised state of this FMU */

typedef struct {
    InstanceCommon common; /* model, FMI state, experiment: kept alike by both FMI versions */
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment environment;
    int logging_on;
} Instance;

static void log_message(const Instance *instance, fmi2Status status, const char *category, const char *format,
                        ...) {
    char message[MESSAGE_SIZE];
    va_list args;
    if (!instance || !instance->logger) return;
    if (status == fmi2OK && !instance->logging_on) return;
    va_start(args, format);
    vsnprintf(message, sizeof(message), format, args);
    va_end(args);
    /* the logger formats like printf: hand it the message as an argument so a '%' in it is safe */
    instance->logger(instance->environment, instance->common.instance_name, status, category, "%s", message);
}

static fmi2Status error(Instance *instance, const char *function, const char *message) {
    log_message(instance, fmi2Error, "logStatusError", "%s: %s", function, message);
    return fmi2Error;
}

/* Refuses calls the FMI 2.0 state machine does not allow in the current state, naming that state. */
static int allowed(Instance *instance, const char *function, unsigned int states) {
    static const char *names[] = {"instantiated", "initialization mode", "step complete", "terminated", "error",
                                  "step failed", "event mode", "continuous-time mode"}; /* by InstanceState */
    char message[MESSAGE_SIZE];
    if (!instance) return 0;
    if (states & (1u << instance->common.state)) return 1;
    if (instance->common.state == STATE_ERROR) {
        error(instance, function, "the instance is in the error state: only fmi2Reset and fmi2FreeInstance are allowed");
        return 0;
    }
    snprintf(message, sizeof(message), "not allowed in the current state of the instance (%s, %s)",
             instance->common.model_exchange ? "Model Exchange" : "Co-Simulation", names[instance->common.state]);
    error(instance, function, message);
    return 0;
}

/* 1 when `function` may be called in the instance's state (its MASK_ in state_masks.h), else 0, logged. */
#define CHECK_STATE(function) allowed(instance, #function, MASK_##function)


const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    Instance *instance = (Instance *)c;
    (void)nCategories;
    (void)categories;
    if (!instance) return fmi2Error;
    instance->logging_on = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance probe, *instance;
    char message[MESSAGE_SIZE];
    (void)fmuResourceLocation;
    (void)visible;
    memset(&probe, 0, sizeof(probe));
    probe.logger = functions ? functions->logger : NULL;
    probe.environment = functions ? functions->componentEnvironment : NULL;
    probe.common.instance_name = (char *)(instanceName ? instanceName : "");
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        error(&probe, "fmi2Instantiate", "fmuType must be fmi2ModelExchange or fmi2CoSimulation");
        return NULL;
    }
    if (instance_check_token(fmuGUID, "GUID", message, sizeof(message))) {
        error(&probe, "fmi2Instantiate", message);
        return NULL;
    }
    instance = (Instance *)calloc(1, sizeof(Instance));
    if (!instance) return NULL;
    if (instance_open(&instance->common, probe.common.instance_name)) {
        free(instance);
        return NULL;
    }
    instance->common.model_exchange = fmuType == fmi2ModelExchange;
    instance->logger = probe.logger;
    instance->environment = probe.environment;
    instance->logging_on = loggingOn;
    return instance;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!instance) return;
    instance_close(&instance->common);
    free(instance);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *instance = (Instance *)c;
    (void)toleranceDefined; /* the solver's tolerances are the parameters rtol and atol */
    (void)tolerance;
    if (!CHECK_STATE(fmi2SetupExperiment)) return fmi2Error;
    instance->common.start_time = startTime;
    instance->common.stop_time_defined = stopTimeDefined;
    instance->common.stop_time = stopTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2EnterInitializationMode)) return fmi2Error;
    instance->common.state = STATE_INITIALIZATION_MODE;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2ExitInitializationMode)) return fmi2Error;
    if (instance_initialize(&instance->common, message, sizeof(message))) {
        return error(instance, "fmi2ExitInitializationMode", message);
    }
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2Terminate)) {
        return fmi2Error;
    }
    instance->common.state = STATE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi2Error;
    instance_reset(&instance->common);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2GetReal)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_get_real(instance->common.model, vr[i], &value[i], message, sizeof(message))) {
            return error(instance, "fmi2GetReal", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2GetInteger)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_get_integer(instance->common.model, vr[i], &value[i], message, sizeof(message))) {
            return error(instance, "fmi2GetInteger", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Instance *instance = (Instance *)c;
    (void)vr;
    (void)value;
    if (!CHECK_STATE(fmi2GetBoolean)) return fmi2Error;
    return nvr == 0 ? fmi2OK : error(instance, "fmi2GetBoolean", "this FMU has no Boolean variables");
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    Instance *instance = (Instance *)c;
    (void)vr;
    (void)value;
    if (!CHECK_STATE(fmi2GetString)) return fmi2Error;
    return nvr == 0 ? fmi2OK : error(instance, "fmi2GetString", "this FMU has no String variables");
}

/* Setting: parameters before initialisation only (the model says why it refuses). */
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2SetReal)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_set_real(instance->common.model, vr[i], value[i], message, sizeof(message))) {
            return error(instance, "fmi2SetReal", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2SetInteger)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_set_integer(instance->common.model, vr[i], value[i], message, sizeof(message))) {
            return error(instance, "fmi2SetInteger", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    Instance *instance = (Instance *)c;
    (void)vr;
    (void)value;
    if (!CHECK_STATE(fmi2SetBoolean)) return fmi2Error;
    return nvr == 0 ? fmi2OK : error(instance, "fmi2SetBoolean", "this FMU has no Boolean variables");
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    Instance *instance = (Instance *)c;
    (void)vr;
    (void)value;
    if (!CHECK_STATE(fmi2SetString)) return fmi2Error;
    return nvr == 0 ? fmi2OK : error(instance, "fmi2SetString", "this FMU has no String variables");
}

/* FMU states: a flat copy of the common fields and the model (the model holds no pointers); common/instance.c
 * does the work. */
static fmi2Status outcome(Instance *instance, const char *function, const char *failure) {
    return failure ? error(instance, function, failure) : fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2GetFMUstate)) return fmi2Error;
    return outcome(instance, "fmi2GetFMUstate", instance_get_state(&instance->common, STATE_MAGIC, FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2SetFMUstate)) return fmi2Error;
    return outcome(instance, "fmi2SetFMUstate", instance_set_state(&instance->common, STATE_MAGIC, FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)c;
    instance_free_state(FMUstate);
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)c;
    (void)FMUstate;
    *size = instance_saved_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi2Error;
    return outcome(instance, "fmi2SerializeFMUstate",
                   instance_serialize_state(FMUstate, (unsigned char *)serializedState, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi2Error;
    return outcome(instance, "fmi2DeSerializeFMUstate",
                   instance_deserialize_state(&instance->common, STATE_MAGIC,
                                              (const unsigned char *)serializedState, size, FMUstate));
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2SetRealInputDerivatives)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_set_input_derivative(instance->common.model, vr[i], order[i], value[i], message, sizeof(message))) {
            return error(instance, "fmi2SetRealInputDerivatives", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2GetRealOutputDerivatives)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (model_get_output_derivative(instance->common.model, vr[i], order[i], &value[i], message,
                                        sizeof(message))) {
            return error(instance, "fmi2GetRealOutputDerivatives", message);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    int status;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!CHECK_STATE(fmi2DoStep)) return fmi2Error;
    status = instance_do_step(&instance->common, currentCommunicationPoint, communicationStepSize, message,
                              sizeof(message));
    if (status == MODEL_LIMIT_REACHED) {
        /* FMI 2.0 section 4.2.3: the step was computed only up to fmi2LastSuccessfulTime, and fmi2Terminated */
        log_message(instance, fmi2Discard, "logStatusDiscard", "fmi2DoStep: %s", message);
        return fmi2Discard;
    }
    if (status) return error(instance, "fmi2DoStep", message);
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi2Error;
    if (s == fmi2LastSuccessfulTime) {
        *value = model_time(instance->common.model);
        return fmi2OK;
    }
    return error(instance, "fmi2GetRealStatus", "only fmi2LastSuccessfulTime is provided");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    Instance *instance = (Instance *)c;
    if (!instance) return fmi2Error;
    if (s == fmi2Terminated) {
        *value = model_terminated(instance->common.model) ? fmi2True : fmi2False; /* the model stopped the run early */
        return fmi2OK;
    }
    return error(instance, "fmi2GetBooleanStatus", "only fmi2Terminated is provided");
}

/* The calls this FMU refuses (common/refused_calls.h), each written by this macro. `ignored` takes a refused
 * call's parameters, so that none of them is unused. */
static void ignored(fmi2Component c, ...) { (void)c; }

#define REFUSED(function, parameters, names, reason)    \
    fmi2Status function parameters {                    \
        ignored names;                                  \
        return error((Instance *)c, #function, reason); \
    }

FMI2_REFUSED_CALLS

/* Model Exchange: the importer integrates the model's contract (model.h). */

/* A model call that may refuse: its reason is logged and the call returns fmi2Error. */
static fmi2Status model_outcome(Instance *instance, const char *function, int failed, const char *message) {
    return failed ? error(instance, function, message) : fmi2OK;
}

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2EnterEventMode)) return fmi2Error;
    instance->common.state = STATE_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    Instance *instance = (Instance *)c;
    int changed, next_defined = 0;
    double next_time = 0.0;
    if (!CHECK_STATE(fmi2NewDiscreteStates)) return fmi2Error;
    if (!eventInfo) return error(instance, "fmi2NewDiscreteStates", "eventInfo is NULL");
    model_event_update(instance->common.model, &changed, &next_defined, &next_time);
    /* one update reaches the new modes (they follow from the state, the load from the time): no iteration */
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    /* The states never jump, but where a mode switched the forces do: saying so makes every importer restart
     * its integrator here, as it must across a jump of the right-hand side (fmusim restarts CVODE only when an
     * FMU says its states or nominals changed, and otherwise fails its error test at tight tolerances). */
    eventInfo->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = next_defined ? fmi2True : fmi2False;
    eventInfo->nextEventTime = next_time;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    Instance *instance = (Instance *)c;
    if (!CHECK_STATE(fmi2EnterContinuousTimeMode)) return fmi2Error;
    instance->common.state = STATE_CONTINUOUS_TIME;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    Instance *instance = (Instance *)c;
    int event;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!CHECK_STATE(fmi2CompletedIntegratorStep)) return fmi2Error;
    /* a discrete state contradicting the continuous ones: a switch the importer did not handle, ask for an event */
    event = model_completed_point(instance->common.model);
    if (enterEventMode) *enterEventMode = event ? fmi2True : fmi2False;
    if (terminateSimulation) *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2SetTime)) return fmi2Error;
    return model_outcome(instance, "fmi2SetTime",
                         instance_set_time(&instance->common, time, message, sizeof(message)), message);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2SetContinuousStates)) return fmi2Error;
    if (!x) return error(instance, "fmi2SetContinuousStates", "x is NULL");
    return model_outcome(instance, "fmi2SetContinuousStates",
                         model_set_states(instance->common.model, x, nx, message, sizeof(message)), message);
}

/* An importer that goes on in continuous-time mode after fmi2CompletedIntegratorStep asked for event mode: the
 * model switches the contradicting discrete states itself and says so (fmi2Warning). 1 when it did. */
static int lost_events_switched(Instance *instance) {
    char message[MESSAGE_SIZE];
    if (!instance_switch_lost_events(&instance->common, message, sizeof(message))) return 0;
    log_message(instance, fmi2Warning, "logStatusWarning", "fmi2GetDerivatives: %s", message);
    return 1;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2GetDerivatives)) return fmi2Error;
    if (!derivatives) return error(instance, "fmi2GetDerivatives", "derivatives is NULL");
    if (model_get_derivatives(instance->common.model, derivatives, nx, message, sizeof(message))) {
        return error(instance, "fmi2GetDerivatives", message);
    }
    return lost_events_switched(instance) ? fmi2Warning : fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2GetEventIndicators)) return fmi2Error;
    if (!eventIndicators && ni > 0) return error(instance, "fmi2GetEventIndicators", "eventIndicators is NULL");
    return model_outcome(instance, "fmi2GetEventIndicators",
                         model_get_event_indicators(instance->common.model, eventIndicators, ni, message,
                                                    sizeof(message)),
                         message);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    if (!CHECK_STATE(fmi2GetContinuousStates)) return fmi2Error;
    if (!x) return error(instance, "fmi2GetContinuousStates", "x is NULL");
    return model_outcome(instance, "fmi2GetContinuousStates",
                         model_get_states(instance->common.model, x, nx, message, sizeof(message)), message);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    Instance *instance = (Instance *)c;
    char message[MESSAGE_SIZE];
    size_t i;
    if (!CHECK_STATE(fmi2GetNominalsOfContinuousStates)) return fmi2Error;
    if (!x_nominal) return error(instance, "fmi2GetNominalsOfContinuousStates", "x_nominal is NULL");
    if (nx != (size_t)model_state_count()) {
        snprintf(message, sizeof(message), "%lu nominals asked for, but this FMU has %d continuous states",
                 (unsigned long)nx, model_state_count());
        return error(instance, "fmi2GetNominalsOfContinuousStates", message);
    }
    for (i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}
