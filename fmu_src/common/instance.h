/* What the FMI 2 and FMI 3 glue keep alike for an instance: its model, its place in the FMI state machine,
 * its experiment, and FMU states as flat copies of those. Each glue adds its own logger and API on top. */
#ifndef FMU_INSTANCE_H
#define FMU_INSTANCE_H

#include <stddef.h>

#include "../lattice/model.h"

/* STATE_STEP is FMI 2's step-complete state and FMI 3's step mode. */
typedef enum { STATE_INSTANTIATED, STATE_INITIALIZATION_MODE, STATE_STEP, STATE_TERMINATED, STATE_ERROR } InstanceState;

#define IN(state) (1u << (state))
#define ANY_STATE (IN(STATE_INSTANTIATED) | IN(STATE_INITIALIZATION_MODE) | IN(STATE_STEP) | IN(STATE_TERMINATED))

typedef struct {
    Model *model;
    InstanceState state;
    double start_time, stop_time;
    int stop_time_defined;
} InstanceCommon;

/* Back to a fresh instance (fmi2Reset, fmi3Reset). */
void instance_reset(InstanceCommon *common);

/* An FMU state: the common fields and the model's bytes behind a magic number naming the FMI version. */
size_t instance_saved_size(void);
void instance_save(const InstanceCommon *common, unsigned int magic, unsigned char *bytes);
int instance_restore(InstanceCommon *common, unsigned int magic, const unsigned char *bytes);
int instance_is_saved_state(unsigned int magic, const unsigned char *bytes, size_t size);

/* The FMU-state calls of both versions (fmi2GetFMUstate, fmi3GetFMUState, ...), behind their FMI types: each
 * returns NULL on success, or why it failed. *state is the importer's FMU state: reused when not NULL. */
const char *instance_get_state(const InstanceCommon *common, unsigned int magic, void **state);
const char *instance_set_state(InstanceCommon *common, unsigned int magic, const void *state);
void instance_free_state(void **state);
const char *instance_serialize_state(const void *state, unsigned char *buffer, size_t size);
const char *instance_deserialize_state(unsigned int magic, const unsigned char *buffer, size_t size, void **state);

/* 0 when the importer's communication point is the FMU's time (up to rounding), else -1 and why. */
int instance_check_time(const InstanceCommon *common, double communication_point, char *message,
                        size_t message_size);

#endif
