/* The model API: the functions the FMI glue (common/, fmi2/, fmi3/) calls, and every model folder implements.
 *
 * This is the seam between the glue and a model, as the Reference FMUs' model.h is: a handful of functions, no
 * FMI types. A model folder's own model.h includes this header (the glue finds it through the include path);
 * fmu_src/lattice/ is one model, fmu_src/projectile/ and fmu_src/hull/ the others. Every function that can fail
 * returns 0 on success and -1 with a human-readable reason in `message`.
 */
#ifndef FMU_MODEL_API_H
#define FMU_MODEL_API_H

#include <stddef.h>

typedef struct Model Model;

typedef enum { MODEL_TYPE_REAL = 0, MODEL_TYPE_INTEGER = 1 } ModelVariableType;

const char *model_guid(void);
size_t model_size(void); /* bytes: a Model is flat, so memcpy copies and serialises it */

Model *model_new(void);
void model_free(Model *m);

/* Back to the start values, uninitialised (fmi2Instantiate, fmi2Reset). */
void model_reset(Model *m);

/* Setters refuse outputs, unknown references, out-of-range values, and parameters after initialisation; inputs
 * may be set at any time. */
int model_set_real(Model *m, unsigned int vr, double value, char *message, size_t message_size);
int model_set_integer(Model *m, unsigned int vr, int value, char *message, size_t message_size);
/* Getters: Model Exchange's outputs and every variable's derivatives are computed here when first asked for. */
int model_get_real(Model *m, unsigned int vr, double *value, char *message, size_t message_size);
int model_get_integer(Model *m, unsigned int vr, int *value, char *message, size_t message_size);

/* Co-Simulation: the order-th time derivative (1 = first order) of the real input at vr at the start of the
 * next step (FMI 2's fmi2SetRealInputDerivatives); the model extrapolates that input over the step with it.
 * A model that cannot, or an order above the model's maximum, refuses with why. */
int model_set_input_derivative(Model *m, unsigned int vr, int order, double value, char *message, size_t message_size);
/* Co-Simulation: the order-th time derivative of the real output at vr at the model's time
 * (FMI 2's fmi2GetRealOutputDerivatives). */
int model_get_output_derivative(Model *m, unsigned int vr, int order, double *value, char *message, size_t message_size);

/* How many value references the model's variables take (0 .. count - 1); the type of the one at vr, or -1. */
unsigned int model_value_reference_count(void);
int model_variable_type(unsigned int vr);
/* 1 when the Integer variable at vr is declared as an FMI enumeration (FMI 3 moves it as Int64). */
int model_variable_is_enumeration(unsigned int vr);

/* Checks the parameters as a whole (the lattice: material is a permutation, ...) and sets up the state at
 * start_time.
 * With stop_time_defined, the solver never steps past stop_time. */
int model_initialize(Model *m, double start_time, int stop_time_defined, double stop_time, char *message,
                     size_t message_size);

/* Advances to t_target and updates the outputs. After a failure the model refuses to go on until reset.
 * Returns MODEL_LIMIT_REACHED (with why in message) when the model stopped the run early (the lattice: when
 * peak_backplate_force exceeded peak_force_limit): the run then stopped at model_time, its outputs are valid
 * there, and it goes no further. */
#define MODEL_LIMIT_REACHED 1
int model_advance(Model *m, double t_target, char *message, size_t message_size);

/* The Co-Simulation driver's, called by the glue beside the model's own: sets up the solver at the model's
 * time in its start state, with the outputs of that state (after model_initialize); and 0 when
 * the driver's part of a model read from an FMU state could have been made by this build (its layout, solver
 * fields, times and flags), else -1 and why (after model_check; an uninitialised model has none). */
void model_driver_initialize(Model *m);
int model_driver_check(const Model *m, char *message, size_t message_size);

double model_time(const Model *m);

/* Whether a step failed (the model refuses to go on until reset); a refused argument is not a failure. */
int model_has_failed(const Model *m);

/* 0 when a model read from an FMU state could have been made by this build: every parameter in range, and
 * every field of the model's that sizes or indexes memory (the lattice: material order, size, modes) this build's;
 * else -1 and why (the driver's fields: model_driver_check). The model must be a properly aligned copy
 * (model_size() bytes). */
int model_check(const Model *m, char *message, size_t message_size);

/* The continuous-time contract, as the Reference FMUs' model.h has it (getContinuousStates,
 * getDerivatives, getEventIndicators, eventUpdate). Model Exchange hands it to the importer's solver; a
 * model's Co-Simulation driver integrates the same derivatives with its own solver (the lattice's locates the
 * same event indicators on its dense output), so the two interfaces cannot drift.
 * A model folder's model.h says what its states, discrete states and indicators are.
 *
 * Model Exchange runs between model_initialize and a reset; every call checks its sizes and says why it
 * refuses. */
int model_state_count(void);
int model_event_indicator_count(void);

/* From here on the importer integrates: the model holds the state it is given instead of advancing. */
int model_exchange_begin(Model *m, char *message, size_t message_size);
void model_set_time(Model *m, double time);
int model_get_states(const Model *m, double *x, size_t n, char *message, size_t message_size);
int model_set_states(Model *m, const double *x, size_t n, char *message, size_t message_size);
int model_get_derivatives(Model *m, double *dx, size_t n, char *message, size_t message_size);
int model_get_event_indicators(const Model *m, double *z, size_t n, char *message, size_t message_size);

/* Event mode at the current time and state: sets the discrete states to those of the time and the state;
 * says whether they changed and when the next time event is. */
void model_event_update(Model *m, int *changed, int *next_event_time_defined, double *next_event_time);

/* The importer completed a step or reached an event: the model's peaks over the points it shows the model
 * (the only ones the model sees). Returns 1 when a discrete state contradicts the continuous ones there (a
 * switch the importer did not handle as an event): the importer should enter event mode. */
int model_completed_point(Model *m);

/* Model Exchange's answer to an importer that goes on integrating after model_completed_point asked for an
 * event: the discrete states that still contradict the continuous ones are switched here, so the physics stays
 * right (to the accuracy lost at the switch); returns how many were switched (0 when none was pending), with
 * the warning's text in message. Called in continuous-time mode only. */
int model_switch_lost_events(Model *m, char *message, size_t message_size);

/* 1 once the model stopped the run early (model_advance's MODEL_LIMIT_REACHED; FMI's "terminated" status),
 * else 0. */
int model_terminated(const Model *m);

#endif
