/* The lattice as a simulation model: variables by value reference, initialisation, advancing in time.
 *
 * This is the seam the FMI glue calls (fmi2/, fmi3/): a handful of functions, no FMI types. Every function
 * that can fail returns 0 on success and -1 with a human-readable reason in `message`.
 */
#ifndef LATTICE_MODEL_H
#define LATTICE_MODEL_H

#include <stddef.h>

typedef struct Model Model;

typedef enum { MODEL_TYPE_REAL = 0, MODEL_TYPE_INTEGER = 1 } ModelVariableType;

const char *model_guid(void);
size_t model_size(void); /* bytes: a Model is flat, so memcpy copies and serialises it */

Model *model_new(void);
void model_free(Model *m);

/* Back to the start values, uninitialised (fmi2Instantiate, fmi2Reset). */
void model_reset(Model *m);

/* Setters refuse outputs, unknown references, out-of-range values, and parameters after initialisation. */
int model_set_real(Model *m, unsigned int vr, double value, char *message, size_t message_size);
int model_set_integer(Model *m, unsigned int vr, int value, char *message, size_t message_size);
int model_get_real(const Model *m, unsigned int vr, double *value, char *message, size_t message_size);
int model_get_integer(const Model *m, unsigned int vr, int *value, char *message, size_t message_size);

/* Number of elements of the variable at vr (FMI 3 arrays), or 0 when vr is unknown. */
int model_variable_count(unsigned int vr);
int model_variable_type(unsigned int vr);

/* Checks the parameters as a whole (material is a permutation, ...) and sets up the state at start_time.
 * With stop_time_defined, the solver never steps past stop_time. */
int model_initialize(Model *m, double start_time, int stop_time_defined, double stop_time, char *message,
                     size_t message_size);

/* Advances to t_target and updates the outputs. After a failure the model refuses to go on until reset.
 * Returns MODEL_LIMIT_REACHED (with why in message) when peak_backplate_force exceeded peak_force_limit: the
 * run then stopped at that sample's time (model_time), its outputs are valid there, and it goes no further. */
#define MODEL_LIMIT_REACHED 1
int model_advance(Model *m, double t_target, char *message, size_t message_size);

double model_time(const Model *m);

/* Whether a step failed (the model refuses to go on until reset); a refused argument is not a failure. */
int model_has_failed(const Model *m);

/* 0 when a model read from an FMU state could have been made by this build: every parameter in range, and
 * every field that sizes or indexes memory (state size, lattice size, solver, modes) this build's; else -1 and
 * why. The model must be a properly aligned copy (model_size() bytes). */
int model_check(const Model *m, char *message, size_t message_size);

/* 1 once the run stopped at peak_force_limit (FMI's "terminated" status), else 0. */
int model_terminated(const Model *m);

#endif
