/* The instance bookkeeping both FMI versions share; see instance.h. */
#include "instance.h"

#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The importer's communication time may drift from ours by rounding; more than this is a real mismatch. */
#define TIME_MISMATCH_TOLERANCE 1e-9

/* The layout of a saved (and serialised) FMU state, in host byte order: this header, then the model's bytes.
 * The checksum is CRC-32 (zlib's) over every byte after it, so a state that was damaged in transit or on disk
 * is refused; the sizes and the build are checked before anything is read from the model's bytes, and
 * model_check and model_driver_check then check every field that sizes or indexes memory, so a crafted state
 * (a changed size with a recomputed checksum) is refused too. */
#define STATE_FORMAT 2u
typedef struct {
    uint32_t magic;      /* offset 0: the FMI version's magic number */
    uint32_t format;     /* 4: STATE_FORMAT */
    uint32_t checksum;   /* 8: CRC-32 of bytes [12, instance_saved_size()) */
    int32_t state;       /* 12: InstanceState */
    uint64_t saved_size; /* 16: instance_saved_size() */
    uint64_t model_size; /* 24: model_size() */
    uint64_t build;      /* 32: FNV-1a hash of the model GUID: a state of another build is foreign */
    double start_time, stop_time; /* 40, 48 */
    int32_t stop_time_defined;    /* 56 */
    int32_t reserved;             /* 60: 0 */
} SavedHeader;
#define CHECKSUM_START 12

/* CRC-32 as zlib computes it (reflected, polynomial 0xEDB88320), four bits at a time. */
static uint32_t crc32_of(const unsigned char *bytes, size_t size) {
    static const uint32_t nibble[16] = {0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
                                        0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
                                        0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    for (i = 0; i < size; i++) {
        crc ^= bytes[i];
        crc = (crc >> 4) ^ nibble[crc & 15u];
        crc = (crc >> 4) ^ nibble[crc & 15u];
    }
    return crc ^ 0xFFFFFFFFu;
}

static uint64_t build_hash(void) {
    const unsigned char *text = (const unsigned char *)model_guid();
    uint64_t hash = 14695981039346656037u;
    for (; *text; text++) hash = (hash ^ *text) * 1099511628211u;
    return hash;
}

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
    header.format = STATE_FORMAT;
    header.state = (int32_t)common->state;
    header.saved_size = instance_saved_size();
    header.model_size = model_size();
    header.build = build_hash();
    header.start_time = common->start_time;
    header.stop_time = common->stop_time;
    header.stop_time_defined = common->stop_time_defined;
    memcpy(bytes, &header, sizeof(header));
    memcpy(bytes + sizeof(header), common->model, model_size());
    header.checksum = crc32_of(bytes + CHECKSUM_START, instance_saved_size() - CHECKSUM_START);
    memcpy(bytes + offsetof(SavedHeader, checksum), &header.checksum, sizeof(header.checksum));
}

/* NULL when `size` bytes at `bytes` are an intact state of this build for this FMI version, else why not:
 * the sizes, version and build first, then the checksum; the fields of the model and of its driver last
 * (model_check, model_driver_check), read from an aligned copy in `scratch` (model_size() bytes). */
static const char *check_saved_state(unsigned int magic, const unsigned char *bytes, size_t size, Model *scratch,
                                     char *reason, size_t reason_size) {
    SavedHeader header;
    if (!bytes) return "no state given";
    if (size != instance_saved_size()) {
        snprintf(reason, reason_size, "the serialised state has %lu bytes, a state of this FMU has %lu",
                 (unsigned long)size, (unsigned long)instance_saved_size());
        return reason;
    }
    memcpy(&header, bytes, sizeof(header));
    if (header.magic != magic) return "not a state of this FMU and FMI version (wrong magic number)";
    if (header.format != STATE_FORMAT) return "a state of another format version of this FMU";
    if (header.saved_size != instance_saved_size() || header.model_size != model_size()) {
        snprintf(reason, reason_size, "the state's size fields (%lu, %lu bytes) are not this FMU's (%lu, %lu)",
                 (unsigned long)header.saved_size, (unsigned long)header.model_size,
                 (unsigned long)instance_saved_size(), (unsigned long)model_size());
        return reason;
    }
    if (header.build != build_hash()) return "a state of another build of this FMU (its GUID differs)";
    if (header.checksum != crc32_of(bytes + CHECKSUM_START, size - CHECKSUM_START)) {
        return "the state is corrupt: its checksum does not match its bytes";
    }
    if (header.state < STATE_INSTANTIATED || header.state > STATE_CONTINUOUS_TIME ||
        (header.stop_time_defined != 0 && header.stop_time_defined != 1) || header.reserved != 0) {
        return "the state is corrupt: its instance fields are out of range";
    }
    memcpy(scratch, bytes + sizeof(header), model_size());
    if (model_check(scratch, reason, reason_size) || model_driver_check(scratch, reason, reason_size)) return reason;
    return NULL;
}

/* Whether a saved state's place in the state machine belongs to the instance's interface (step mode is
 * Co-Simulation's, event and continuous-time mode Model Exchange's). */
static int fits_interface(const InstanceCommon *common, const unsigned char *bytes) {
    SavedHeader header;
    memcpy(&header, bytes, sizeof(header));
    if (header.state == STATE_STEP || header.state == STATE_STEP_STOPPED) return !common->model_exchange;
    if (header.state == STATE_EVENT_MODE || header.state == STATE_CONTINUOUS_TIME) return common->model_exchange;
    return 1;
}

/* Copies a checked state into the instance (the model's bytes from `model`, already checked). */
static void restore(InstanceCommon *common, const unsigned char *bytes, const Model *model) {
    SavedHeader header;
    memcpy(&header, bytes, sizeof(header));
    common->state = (InstanceState)header.state;
    common->start_time = header.start_time;
    common->stop_time = header.stop_time;
    common->stop_time_defined = header.stop_time_defined;
    memcpy(common->model, model, model_size());
}

const char *instance_get_state(const InstanceCommon *common, unsigned int magic, void **state) {
    unsigned char *bytes = (unsigned char *)(*state ? *state : malloc(instance_saved_size()));
    if (!bytes) return "out of memory";
    instance_save(common, magic, bytes);
    *state = bytes;
    return NULL;
}

const char *instance_set_state(InstanceCommon *common, unsigned int magic, const void *state) {
    Model *scratch = (Model *)malloc(model_size());
    const char *failure;
    if (!scratch) return "out of memory";
    failure = check_saved_state(magic, (const unsigned char *)state, instance_saved_size(), scratch, common->reason,
                                sizeof(common->reason));
    if (!failure && !fits_interface(common, (const unsigned char *)state)) {
        failure = common->model_exchange ? "a Co-Simulation state cannot be set into a Model Exchange instance"
                                         : "a Model Exchange state cannot be set into a Co-Simulation instance";
    }
    if (!failure) restore(common, (const unsigned char *)state, scratch);
    free(scratch);
    return failure;
}

void instance_free_state(void **state) {
    if (state) {
        free(*state);
        *state = NULL;
    }
}

const char *instance_serialize_state(const void *state, unsigned char *buffer, size_t size) {
    if (!state || !buffer) return "no state or no buffer given";
    if (size < instance_saved_size()) return "the buffer is too small";
    memcpy(buffer, state, instance_saved_size());
    return NULL;
}

const char *instance_deserialize_state(InstanceCommon *common, unsigned int magic, const unsigned char *buffer,
                                       size_t size, void **state) {
    Model *scratch = (Model *)malloc(model_size());
    const char *failure;
    void *bytes;
    if (!scratch) return "out of memory";
    failure = check_saved_state(magic, buffer, size, scratch, common->reason, sizeof(common->reason));
    free(scratch);
    if (failure) return failure;
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
    model_driver_initialize(common->model);
    if (common->model_exchange && model_exchange_begin(common->model, message, message_size)) {
        common->state = STATE_ERROR;
        return -1;
    }
    common->state = common->model_exchange ? STATE_EVENT_MODE : STATE_STEP;
    return 0;
}

/* 0 when the importer's communication point is the FMU's time (up to rounding), else -1 and why. */
static int check_time(const InstanceCommon *common, double communication_point, char *message,
                      size_t message_size) {
    const double now = model_time(common->model);
    if (!(communication_point - now <= TIME_MISMATCH_TOLERANCE * (1.0 + now) &&
          now - communication_point <= TIME_MISMATCH_TOLERANCE * (1.0 + now))) {
        snprintf(message, message_size, "currentCommunicationPoint %.17g does not match the FMU's time %.17g",
                 communication_point, now);
        return -1;
    }
    return 0;
}

int instance_switch_lost_events(InstanceCommon *common, char *message, size_t message_size) {
    if (common->state != STATE_CONTINUOUS_TIME) return 0;
    return model_switch_lost_events(common->model, message, message_size);
}

int instance_set_time(InstanceCommon *common, double time, char *message, size_t message_size) {
    if (!(time >= common->start_time)) {
        snprintf(message, message_size, "time %.17g is before the start time %.17g", time, common->start_time);
        return -1;
    }
    model_set_time(common->model, time);
    return 0;
}

int instance_do_step(InstanceCommon *common, double communication_point, double step_size, char *message,
                     size_t message_size) {
    if (common->state == STATE_STEP_STOPPED) {
        snprintf(message, message_size,
                 "the run stopped at t = %.17g s (the model's limit): only terminate, reset or free the instance now",
                 model_time(common->model));
        return -1;
    }
    if (!(step_size >= 0.0 && step_size <= DBL_MAX)) {
        snprintf(message, message_size, "communicationStepSize = %g is not allowed: it must be finite and >= 0",
                 step_size);
        return -1;
    }
    if (check_time(common, communication_point, message, message_size)) return -1;
    {
        const int status = model_advance(common->model, communication_point + step_size, message, message_size);
        if (status == MODEL_LIMIT_REACHED) {
            common->state = STATE_STEP_STOPPED;
            return MODEL_LIMIT_REACHED;
        }
        if (status) {
            if (model_has_failed(common->model)) common->state = STATE_ERROR; /* not for a refused argument */
            return -1;
        }
    }
    return 0;
}
