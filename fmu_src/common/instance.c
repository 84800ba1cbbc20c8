/* The instance bookkeeping both FMI versions share; see instance.h. */
#include "instance.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The importer's communication time may drift from ours by rounding; more than this is a real mismatch. */
#define TIME_MISMATCH_TOLERANCE 1e-9

typedef struct {
    unsigned int magic;
    InstanceState state;
    double start_time, stop_time;
    int stop_time_defined;
} SavedHeader;

int instance_check_token(const char *token, const char *kind, char *message, size_t message_size) {
    if (token && strcmp(token, model_guid()) == 0) return 0;
    snprintf(message, message_size, "%s %s does not match this binary's %s (modelDescription.xml and binary come "
             "from different builds)", kind, token ? token : "(null)", model_guid());
    return -1;
}

int instance_open(InstanceCommon *common, const char *instance_name) {
    memset(common, 0, sizeof(*common));
    common->model = model_new();
    common->instance_name = (char *)malloc(strlen(instance_name) + 1);
    if (!common->model || !common->instance_name) {
        instance_close(common);
        return -1;
    }
    strcpy(common->instance_name, instance_name);
    common->state = STATE_INSTANTIATED;
    return 0;
}

void instance_close(InstanceCommon *common) {
    model_free(common->model);
    free(common->instance_name);
    common->model = NULL;
    common->instance_name = NULL;
}

void instance_reset(InstanceCommon *common) {
    model_reset(common->model);
    common->state = STATE_INSTANTIATED;
    common->start_time = 0.0;
    common->stop_time_defined = 0;
    common->stop_time = 0.0;
}

size_t instance_saved_size(void) { return sizeof(SavedHeader) + model_size(); }

void instance_save(const InstanceCommon *common, unsigned int magic, unsigned char *bytes) {
    SavedHeader header;
    memset(&header, 0, sizeof(header));
    header.magic = magic;
    header.state = common->state;
    header.start_time = common->start_time;
    header.stop_time = common->stop_time;
    header.stop_time_defined = common->stop_time_defined;
    memcpy(bytes, &header, sizeof(header));
    memcpy(bytes + sizeof(header), common->model, model_size());
}

int instance_is_saved_state(unsigned int magic, const unsigned char *bytes, size_t size) {
    SavedHeader header;
    if (!bytes || size != instance_saved_size()) return 0;
    memcpy(&header, bytes, sizeof(header));
    return header.magic == magic;
}

int instance_restore(InstanceCommon *common, unsigned int magic, const unsigned char *bytes) {
    SavedHeader header;
    if (!instance_is_saved_state(magic, bytes, instance_saved_size())) return -1;
    memcpy(&header, bytes, sizeof(header));
    common->state = header.state;
    common->start_time = header.start_time;
    common->stop_time = header.stop_time;
    common->stop_time_defined = header.stop_time_defined;
    memcpy(common->model, bytes + sizeof(header), model_size());
    return 0;
}

const char *instance_get_state(const InstanceCommon *common, unsigned int magic, void **state) {
    unsigned char *bytes = (unsigned char *)(*state ? *state : malloc(instance_saved_size()));
    if (!bytes) return "out of memory";
    instance_save(common, magic, bytes);
    *state = bytes;
    return NULL;
}

const char *instance_set_state(InstanceCommon *common, unsigned int magic, const void *state) {
    if (!state || instance_restore(common, magic, (const unsigned char *)state)) return "not a state of this FMU";
    return NULL;
}

void instance_free_state(void **state) {
    if (state) {
        free(*state);
        *state = NULL;
    }
}

const char *instance_serialize_state(const void *state, unsigned char *buffer, size_t size) {
    if (size < instance_saved_size()) return "the buffer is too small";
    memcpy(buffer, state, instance_saved_size());
    return NULL;
}

const char *instance_deserialize_state(unsigned int magic, const unsigned char *buffer, size_t size, void **state) {
    void *bytes;
    if (size != instance_saved_size()) return "the serialised state has the wrong size for this FMU";
    if (!instance_is_saved_state(magic, buffer, size)) return "not a state of this FMU";
    bytes = *state ? *state : malloc(size);
    if (!bytes) return "out of memory";
    memcpy(bytes, buffer, size);
    *state = bytes;
    return NULL;
}

int instance_initialize(InstanceCommon *common, char *message, size_t message_size) {
    if (model_initialize(common->model, common->start_time, common->stop_time_defined, common->stop_time, message,
                         message_size)) {
        common->state = STATE_ERROR;
        return -1;
    }
    common->state = STATE_STEP;
    return 0;
}

/* 0 when the importer's communication point is the FMU's time (up to rounding), else -1 and why. */
static int check_time(const InstanceCommon *common, double communication_point, char *message,
                      size_t message_size) {
    const double now = model_time(common->model);
    if (communication_point - now > TIME_MISMATCH_TOLERANCE * (1.0 + now) ||
        now - communication_point > TIME_MISMATCH_TOLERANCE * (1.0 + now)) {
        snprintf(message, message_size, "currentCommunicationPoint %.17g does not match the FMU's time %.17g",
                 communication_point, now);
        return -1;
    }
    return 0;
}

int instance_do_step(InstanceCommon *common, double communication_point, double step_size, char *message,
                     size_t message_size) {
    if (step_size < 0.0) {
        snprintf(message, message_size, "communicationStepSize must be >= 0");
        return -1;
    }
    if (check_time(common, communication_point, message, message_size)) return -1;
    if (model_advance(common->model, communication_point + step_size, message, message_size)) {
        common->state = STATE_ERROR;
        return -1;
    }
    return 0;
}
