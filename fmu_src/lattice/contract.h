/* The model as the Co-Simulation driver (cosimulation.c) sees it: the Model struct and the continuous-time
 * contract's calls (model.c). The FMI glue sees only model.h.
 *
 * The contract (model.h): continuous states in lattice.h's layout, their derivatives under the model's
 * discrete states (the load phase, each row's backplate mode), the event indicators and the event update.
 * Model Exchange hands it to the importer's solver; the driver integrates the same derivatives with its own
 * solver (or their reduced layout, lattice_rhs_along_x, the one hook beside the contract) and locates the same
 * indicators, so the two interfaces cannot drift. Both take their peaks through the one sampler and write
 * their outputs through the one updater below.
 */
#ifndef LATTICE_CONTRACT_H
#define LATTICE_CONTRACT_H

#include "cosimulation.h"
#include "lattice.h"
#include "model.h"
#include "model_variables.h"

/* Where the whole layout's vx and quadratures begin (lattice.h). */
#define VX_BASE (N_COMPONENTS * N_MASSES)
#define INDEX_EXTERNAL_WORK (2 * N_COMPONENTS * N_MASSES)
#define INDEX_DISSIPATED (2 * N_COMPONENTS * N_MASSES + 1)
#define INDEX_NONRECIPROCAL_WORK (2 * N_COMPONENTS * N_MASSES + 2)
/* projectile mode's body, after the lattice's state */
#define INDEX_PROJECTILE_POSITION N_LATTICE_STATE
#define INDEX_PROJECTILE_VELOCITY (N_LATTICE_STATE + 1)
/* The projectile's contact indicator is the last (an FMU without a backplate has no others). */
#define IMPACT_INDICATOR (N_EVENT_INDICATORS - 1)
#define FAILURE_SIZE 512
/* A time within this fraction of a sample interval of a sample belongs to it (rounding of t). */
#define SAMPLE_TIME_SLACK 1e-9

/* The contract's event indicators (model.h): each face mass's contact, then each one's damping, face mass
 * f = k*R + i as lattice.h numbers column C's masses. */
#define CONTACT_INDICATOR(face) (face)
#define DAMPING_INDICATOR(face) (N_FACE_MASSES + (face))
/* The column-1 and column-C mass of face mass f (k*rows + i) of a layout of rows x LATTICE_COLS x slices: the
 * whole lattice's, or the part of it a mirrored solver holds (its own rows). */
#define FIRST_COLUMN_MASS(face) ((face) * LATTICE_COLS)
#define LAST_COLUMN_MASS(face) ((face) * LATTICE_COLS + LATTICE_COLS - 1)

struct Model {
    double real[N_VALUE_REFERENCES];
    int integer[N_VALUE_REFERENCES];
    int initialized, failed;
    char failure[FAILURE_SIZE];
    int stop_time_defined;
    double stop_time, time;
    LatticeParams params;
    /* the discrete states */
    int load_on;
    signed char wall_mode[N_FACE_MASSES]; /* frozen between events (WallMode), f = k*R + i */
    int contact_on; /* projectile mode: the body touches the face (frozen between events) */
    /* the peaks and the last contact over the points each interface shows (the one sampler) */
    double peak_sampled, max_compression;
    double peak_sampled_derivative; /* Co-Simulation's sensitivity: d peak_sampled / d epsilon at its sample */
    double transmitted_impulse;            /* the trapezoidal integral of the sampled force so far */
    double last_sample_time, last_sample_force;
    int samples_taken;
    double peak_continuous, peak_continuous_time;
    double last_contact_time; /* latest time a column-C mass was in contact with the backplate */
    double initial_energy;    /* potential energy of the start state (a negative gap presses from t = 0) */
    double output_state[N_STATE]; /* the state at the model's time (Model Exchange: the importer's) */
    double derivative[N_STATE];   /* its derivatives, when derivative_valid */
    int derivative_valid;
    int exchange;      /* Model Exchange: the importer integrates output_state (model_exchange_begin) */
    int outputs_stale; /* Model Exchange: the outputs still describe an earlier state */
    long exchange_evaluations, exchange_points; /* derivative evaluations and completed points (ME) */
    int switch_pending; /* Model Exchange: a completed point found a mode that contradicts the state */
    /* Co-Simulation's ports over a step (docs/model.md section 11): the inputs' values at port_time (the last
     * communication point an input was set at), and the time derivatives the importer gave for them
     * (model_set_input_derivative; 0 until given, and again once the input itself is set). The backplate
     * moves from port_back_position with v_back (or with x_back's derivative where one is given). */
    double port_time, port_front_force, port_back_position, port_back_velocity;
    double front_force_rate, back_position_rate, back_velocity_rate;
    int back_position_rate_given;
    int ports_driven; /* an input was set after initialisation, or load_mode is input: steps end on the
                         communication points, where the inputs may change */
    CoSimulation cs;
};

/* Co-Simulation: the ports' values at time t (inputs extrapolated from port_time) into the model's params,
 * where the physics reads them. */
void model_ports_at(Model *m, double t);

/* Co-Simulation: the importer set input vr to value at the model's time (after initialisation): the driver
 * goes on from there with it. 0, or -1 and why. */
int model_driver_set_input(Model *m, unsigned int vr, double value, char *message, size_t message_size);

/* The derivatives of state y (lattice.h's whole layout) under the backplate modes, with the load on or off
 * (projectile mode: the body under the contact's mode; the contact force goes into the params' front force). */
void model_derivatives(Model *m, int load_on, const double *y, double *dydt);

/* Projectile mode: the contact force (N) of overlap delta and its rate (docs/model.md section 11), with the
 * contact on (frozen between events: continued smoothly past delta = 0 so a step that overshoots the opening
 * stays smooth until the event cuts it back) or off, and the power it dissipates. */
double model_contact_force(const Model *m, int contact_on, double delta, double rate, double *dissipation);

/* Projectile mode: whether the body touches the face at overlap delta closing at rate (at delta = 0: when
 * it closes). */
int model_contact_of(double delta, double rate);

/* The energies of whole state y: the lattice's, with the body's kinetic energy and the contact's potential in
 * projectile mode. */
void model_energies(const Model *m, const double *y, double *kinetic, double *potential);

/* Event indicator k (of the whole face: f = k*R + i) is state component *component minus *threshold, in a
 * layout of `rows` rows per slice whose vx begin at vx_base (LATTICE_ROWS and VX_BASE: the contract's whole
 * layout; the driver's reduced one has its own, and asks only of the face masses it holds). */
void model_indicator_definition(const Model *m, int k, int rows, int vx_base, int *component, double *threshold);

/* The backplate modes docs/model.md section 5 gives the column-C masses of state y, whose layout holds `rows`
 * rows of `slices` slices (the whole lattice's, or the part of a mirror-symmetric one, whose mirror images in y
 * and z take the same modes): what an event switches to, one per face mass of the whole lattice, f = k*R + i. */
void model_wall_modes(const Model *m, const double *y, int rows, int slices, int vx_base, signed char *modes);

/* The contract's time event (the load switches off at t_active): 1 and its time while one is ahead. */
int model_next_time_event(const Model *m, double *time);
int model_load_switches_off(const Model *m, double time);

/* W_ext + W_nr - KE - PE - D + the start state's energy, of whole state y: 0 when the balance closes. */
double model_energy_balance(const Model *m, const double *y, double *kinetic, double *potential);

/* The one sampler: a sample (at a time of the peak_sample_interval grid) takes the backplate force into the sampled
 * peak and the compression into max_compression; every point the force into the continuous peak. */
void model_take_sample(Model *m, double time, double force, double compression);
void model_take_force(Model *m, double time, double force);

/* The compression of the lattice along the load from the ux of its first and last columns' masses, f = k*rows + i
 * over `rows` rows of `slices` slices (all of them, or the part of a mirror-symmetric lattice, each mass counted
 * as often as it stands in the whole): the mean of column 1 minus the mean of column C over its R x D masses. */
double model_compression_of_columns(const Model *m, const double *ux_first, const double *ux_last, int rows,
                                    int slices);

/* The backplate force from the column-C masses' ux and vx, f = k*rows + i over `rows` rows of `slices` slices:
 * all of them, or the part of a mirror-symmetric lattice (lattice_backplate_force_mirrored's counts). */
double model_backplate_force_of_column(const Model *m, const double *ux, const double *vx, int rows, int slices);

/* The forward sensitivity's seeds (d_k[m], ...: the direction d every material property p moves along, p + epsilon
 * d). model_sensitivity_seed: 1 and the first seed that is not 0, named as FMI 2 names it (d_k[2]) with its value,
 * or 0 when every seed is 0 (no sensitivity). model_sensitivity_delta: the step delta of the difference quotient,
 * such that delta |d| is at most SENSITIVITY_STEP times |p| (times 1 where p is 0) for
 * every seeded property of every material. model_sensitivity_params: the params with each column's properties
 * at p + delta d. */
#define SENSITIVITY_STEP 1e-6 /* the quotient's largest move of a parameter, relative to it */
int model_sensitivity_seed(const Model *m, char *name, size_t size, double *value);
double model_sensitivity_delta(const Model *m);
void model_sensitivity_params(const Model *m, double delta, LatticeParams *out);

/* The one output updater: every output from output_state, the continuous peak and its time, the last contact
 * and the counters given by the interface. */
void model_update_outputs(Model *m, double peak_continuous, double peak_time, double last_contact_time,
                          long rhs_evaluations, long steps_accepted, long steps_rejected);

#endif
