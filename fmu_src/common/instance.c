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

int instance_check_time(const InstanceCommon *common, double communication_point, char *message,
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
