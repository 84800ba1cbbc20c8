/* What the FMI 2 and FMI 3 glue keep alike for an instance: its model, its place in the FMI state machine,
 * its experiment, and FMU states as flat copies of those. Each glue adds its own logger and API on top. */
#ifndef FMU_INSTANCE_H
#define FMU_INSTANCE_H

#include <stddef.h>

#include "model.h" /* the model folder's, on the include path */

/* STATE_STEP is FMI 2's step-complete state and FMI 3's step mode; STATE_STEP_STOPPED is FMI 2's step-failed
 * state after the model stopped the run early (the lattice: at peak_force_limit; outputs valid, only
 * terminate, reset or free next) (Co-Simulation); STATE_EVENT_MODE and STATE_CONTINUOUS_TIME are Model Exchange's. */
typedef enum {
    STATE_INSTANTIATED,
    STATE_INITIALIZATION_MODE,
    STATE_STEP,
    STATE_TERMINATED,
    STATE_ERROR,
    STATE_STEP_STOPPED,
    STATE_EVENT_MODE,
    STATE_CONTINUOUS_TIME /* the last: instance.c's state check takes it as the upper bound */
} InstanceState;

#define IN(state) (1u << (state))
#define ANY_STATE                                                                                       \
    (IN(STATE_INSTANTIATED) | IN(STATE_INITIALIZATION_MODE) | IN(STATE_STEP) | IN(STATE_TERMINATED) | \
     IN(STATE_STEP_STOPPED) | IN(STATE_EVENT_MODE) | IN(STATE_CONTINUOUS_TIME))

#define INSTANCE_REASON_SIZE 512

typedef struct {
    Model *model;
    char *instance_name; /* the importer's name for the instance, in every log message */
    InstanceState state;
    double start_time, stop_time;
    int stop_time_defined;
    char reason[INSTANCE_REASON_SIZE]; /* why the last FMU-state call failed, when the reason is not a constant */
    int model_exchange; /* instantiated for Model Exchange (the model's contract, model.h), else Co-Simulation */
} InstanceCommon;

/* Instantiation (fmi2Instantiate, fmi3InstantiateCoSimulation): 0 when the importer's token is this binary's,
 * else -1 and why; `kind` names the token ("GUID", "instantiation token"). */
int instance_check_token(const char *token, const char *kind, char *message, size_t message_size);

/* A new model and a copy of the name, in the instantiated state; -1 (nothing left allocated) when out of
 * memory. instance_close frees what instance_open allocated. */
int instance_open(InstanceCommon *common, const char *instance_name);
void instance_close(InstanceCommon *common);

/* Back to a fresh instance (fmi2Reset, fmi3Reset). */
void instance_reset(InstanceCommon *common);

/* An FMU state: a 64-byte header (a magic number naming the FMI version, a format version, a CRC-32 of all
 * that follows it, the sizes, a hash of the build's GUID, the common fields; the layout is in instance.c),
 * then the model's bytes. A serialised state is the same bytes. */
size_t instance_saved_size(void);
void instance_save(const InstanceCommon *common, unsigned int magic, unsigned char *bytes);

/* The FMU-state calls of both versions (fmi2GetFMUstate, fmi3GetFMUState, ...), behind their FMI types: each
 * returns NULL on success, or why it failed. *state is the importer's FMU state: reused when not NULL.
 * Setting and deserialising check a state whole (size, magic number, format, build, checksum, then every
 * field of the model that sizes or indexes memory) before anything is copied: a corrupt, truncated, crafted
 * or foreign state is refused and changes nothing. */
const char *instance_get_state(const InstanceCommon *common, unsigned int magic, void **state);
const char *instance_set_state(InstanceCommon *common, unsigned int magic, const void *state);
void instance_free_state(void **state);
const char *instance_serialize_state(const void *state, unsigned char *buffer, size_t size);
const char *instance_deserialize_state(InstanceCommon *common, unsigned int magic, const unsigned char *buffer,
                                       size_t size, void **state);

/* fmi2ExitInitializationMode, fmi3ExitInitializationMode: initialises the model and enters the step state
 * (FMI 3 co-simulation without event mode goes straight to step mode), or Model Exchange's event mode;
 * on failure -1 and why, and the instance is in the error state. */
int instance_initialize(InstanceCommon *common, char *message, size_t message_size);

/* fmi2DoStep, fmi3DoStep: checks the step against the FMU's time and advances the model; on failure -1 and
 * why. A step the model fails puts the instance in the error state (a refused argument does not). Returns
 * MODEL_LIMIT_REACHED (why in message) when the model stopped the run early: the instance is then in
 * STATE_STEP_STOPPED at model_time. */
int instance_do_step(InstanceCommon *common, double communication_point, double step_size, char *message,
                     size_t message_size);

/* Model Exchange in continuous-time mode, when the importer asks for derivatives: the discrete-state switches
 * the model had to make itself because the importer went on without the event a completed step asked for
 * (model_switch_lost_events). Returns how many it switched, with the warning's text in message. */
int instance_switch_lost_events(InstanceCommon *common, char *message, size_t message_size);

/* Model Exchange's fmi2SetTime / fmi3SetTime: -1 and why for a time before the start time. */
int instance_set_time(InstanceCommon *common, double time, char *message, size_t message_size);

#endif
