/* One-step ODE solvers with dense output, kept apart from the physics and from FMI.
 *
 * DOP853 (adaptive, 8th order, 7th-order dense output, SciPy's step-size control) is the default; Tsitouras'
 * 5(4) pair (adaptive, 7 stages with the last reused as the next step's first, and its free 4th-order dense
 * output from the step's own stages) needs fewer right-hand sides at loose tolerances, and so does Dormand and
 * Prince's 5(4) pair (SciPy's RK45, built the same way), there for comparison; Fine's general
 * Runge-Kutta-Nystrom 5(4) pair (adaptive, for x'' = f(x, x') over a state [x, x', integrals], 6 right-hand
 * sides a step, free quintic Hermite dense output) needs the fewest at the searches' accuracy; fixed-step classical
 * RK4 and semi-implicit (symplectic) Euler are there for the stability and work-precision studies, with
 * cubic Hermite dense output. The solver advances in accepted steps that never cross a
 * caller's limit (the load switch-off, the stop time); the caller reads any time inside the last step
 * through the dense output, so where an importer puts its communication points never changes the steps.
 *
 * The Solver struct holds no pointers: its workspace is passed in, so a model can copy itself (FMU
 * states) with memcpy.
 */
#ifndef SOLVER_H
#define SOLVER_H

#include <stddef.h>

#include "model_table.h" /* enum Solver, SOLVER_DOP853 ...: generated from the variable table */

/* 1 for the methods with error control (their steps adapt, an event may cut one back to any length). */
int solver_is_adaptive(int method);

/* dydt = f(t, y) in the given phase (the model uses it for load on/off); time enters only through the inputs a
 * model extrapolates over a step (the lattice's ports), never the physics itself. */
typedef void (*OdeFunction)(void *context, int phase, double t, const double *y, double *dydt);

#define DENSE_FROM_STAGES (-1)
#define DENSE_NYSTROM (-2) /* the Nystrom pair's Hermite dense output (solver.c) */
#define SOLVER_STAGE_ROWS 16 /* DOP853's 12 stages, f(y_new), and 3 stages for the dense output */
#define SOLVER_DENSE_ROWS 7
#define SOLVER_WORKSPACE_ROWS (4 + SOLVER_STAGE_ROWS + SOLVER_DENSE_ROWS) /* y, y_old, scratch, K, dense, weights */
#define SOLVER_WORKSPACE_SIZE(n) (SOLVER_WORKSPACE_ROWS * (size_t)(n))

typedef struct {
    int method;         /* enum Solver */
    int n;              /* state size */
    int n_second_order; /* y[0..m) are positions whose rates are y[m..2m) (semi-implicit Euler needs it) */
    int block; /* n, or n / 2 for a state of two blocks laid out alike (a forward sensitivity after its state):
                  the positions and their rates above are those of each block */
    double rtol, atol, fixed_step;
    int phase;
    double t;            /* time of the current state */
    double t_old, h_last; /* the last accepted step covers [t_old, t_old + h_last] */
    double h_next;       /* proposed size of the next adaptive step; 0 before the first step */
    int end_derivative_valid; /* the stage row 12 holds f(y) in the current phase */
    int dense_power;          /* dense output ready for the last step: 0 (none), 3 or 7 (rows of coefficients),
                                 or DENSE_FROM_STAGES (Tsit5, DOPRI5: read from the step's stage rows) */
    long rhs_evaluations, steps_accepted, steps_rejected;
    int weighted;     /* the error norms weight the components (solver_set_norm_weights) */
    double norm_size; /* the count of components the error norms' mean is taken over (n unless weighted) */
    double dense_x, dense_weights[8]; /* Tsit5, DOPRI5: the dense output's stage weights at x = dense_x (a cache) */
} Solver;

/* The state at s->t (the first row of the workspace). */
const double *solver_state(const double *work);

/* blocks: 1, or 2 for a state of two blocks of n / 2 each, [positions, rates, rest] both (the Nystrom pair and
 * semi-implicit Euler take each block as the second-order system it is; the others see n components). */
void solver_init(Solver *s, double *work, int method, int n, int n_second_order, int blocks, double rtol,
                 double atol, double fixed_step, int phase, const double *y0);
/* y0 is the first block's start; a second block starts at 0. */

/* Weights of the components in the error norms, a root mean square over norm_size components: how a reduced
 * state (the upper half of a mirror-symmetric lattice, a lattice without its y components) keeps the step-size
 * control of the whole one, each of its components standing for weight[i] of the whole state's and the
 * components it leaves out (known to be 0, so without error) still counted in norm_size. weight holds the first
 * block's; a second block weighs 0 (outside the error control: it takes the first block's steps). Before the
 * first step. */
void solver_set_norm_weights(Solver *s, double *work, const double *weight, double norm_size);

/* The derivative f(y) at the current state that the next step will take as its first stage, or NULL when it
 * will evaluate it afresh: a caller that changed a part of the state (the sensitivity block at an event)
 * corrects that part of it. */
double *solver_end_derivative(Solver *s, double *work);

/* Changes the phase at the current time (the right-hand side changes there). */
void solver_set_phase(Solver *s, int phase);

/* Takes one accepted step that ends at or before t_limit. Returns 0, or -1 with a reason in message
 * (step size collapsed, state not finite). */
int solver_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                size_t message_size);

/* Makes the dense output of the last step available (DOP853 spends 3 evaluations on it, once a step). */
void solver_prepare_dense(Solver *s, double *work, OdeFunction f, void *context);

/* Component i at time t inside the last step from the cubic Hermite through both ends (free: no
 * evaluations); a cheap first look before the accurate dense output is paid for. */
double solver_interpolate_hermite(const Solver *s, const double *work, int component, double t);

/* Ends the last step early at t_end (t_old < t_end <= t), on its dense output: how a step that crossed
 * an event is cut back to the event. The dense output stays valid on [t_old, t_end]. */
void solver_truncate(Solver *s, double *work, OdeFunction f, void *context, double t_end);

/* Component i of the solution at time t inside the last step (after solver_prepare_dense). */
double solver_interpolate(const Solver *s, const double *work, int component, double t);

#endif
