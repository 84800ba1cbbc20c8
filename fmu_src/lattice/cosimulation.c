/* The Co-Simulation driver on the model's contract (cosimulation.h, contract.h). */
#include "cosimulation.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "contract.h"

/* Divergence: kinetic energy beyond this multiple of the energy put in ends the run with an error. */
#define ENERGY_LIMIT_FACTOR 10.0
/* ... and so does an energy balance off by more than this fraction of the energy put in, checked every
 * BALANCE_CHECK_STEPS accepted steps. */
#define BALANCE_LIMIT_FRACTION 0.5
#define BALANCE_CHECK_STEPS 16
/* The continuous peak inside a step: a free Hermite look at a few points first; only a step that may
 * come within PEAK_PREFILTER_MARGIN of the running peak pays for the dense output, a grid and Brent's
 * refinement to PEAK_TIME_TOLERANCE |t| + PEAK_TIME_ABSOLUTE (s) in the peak's time. */
#define PEAK_PREFILTER_POINTS 8
#define PEAK_PREFILTER_MARGIN 0.05
#define PEAK_GRID_POINTS 16
#define PEAK_REFINE_ITERATIONS 100
#define PEAK_TIME_TOLERANCE 1.5e-8 /* about the square root of the double's epsilon, as Brent advises */
#define PEAK_TIME_ABSOLUTE 1e-12
/* The shortest part of a step, as a fraction of it, that a located backplate switch may cut it back to. */
#define MIN_EVENT_FRACTION 1e-6
/* Backplate switches this close after the earliest in a step (a fraction of the step) count as one event. */
#define SIMULTANEOUS_EVENT_FRACTION 1e-9
/* This many steps in a row that do not move time forward mean the backplate switches chatter. */
#define MAX_STALLED_STEPS 1000
/* The work of one doStep is bounded, so that no setting makes a call run for ever: at most this many samples
 * of the peak (checked before the step: peak_sample_interval against the communication step) and this many
 * solver steps, accepted and rejected (checked before the step for the fixed-step solvers, and as they are
 * taken for all). */
#define MAX_SAMPLES_PER_DO_STEP 10000000.0
#define MAX_STEPS_PER_DO_STEP 200000L

/* The solver holds the part of a mirror-symmetric lattice (fewer rows or slices than the whole). */
static int solver_mirrored(const Model *m) {
    return m->cs.solver_rows != LATTICE_ROWS || m->cs.solver_slices != LATTICE_DEPTH;
}

void model_ports_at(Model *m, double t) {
    const double elapsed = t - m->port_time;
    const double velocity = m->port_back_velocity, acceleration = m->back_velocity_rate;
    const double rate = m->back_position_rate_given ? m->back_position_rate : velocity;
    m->params.front_force = m->port_front_force + m->front_force_rate * elapsed;
    m->params.back_velocity = velocity + acceleration * elapsed;
    m->params.back_position = m->port_back_position + rate * elapsed + 0.5 * acceleration * elapsed * elapsed;
}

/* The solver's layout (lattice.h): its masses, its positions (the lattice's), where its vx and its quadratures
 * begin (projectile mode: the body's position after the positions, its velocity after the velocities). */
static int solver_faces(const Model *m) { return m->cs.solver_rows * m->cs.solver_slices; }
static int solver_masses(const Model *m) { return solver_faces(m) * LATTICE_COLS; }
static int solver_positions(const Model *m) {
    return (m->cs.solver_along_x ? 1 : N_COMPONENTS) * solver_masses(m);
}
static int solver_vx_base(const Model *m) { return solver_positions(m) + m->cs.solver_projectile; }
static int solver_quadrature_base(const Model *m) { return 2 * solver_positions(m) + 2 * m->cs.solver_projectile; }

/* Projectile mode's right-hand side under params (the model's, or the sensitivity's moved ones): the lattice's
 * part of y in the lattice's own layout, its rate with the contact force on the face, and the body's. */
static void projectile_rhs(Model *m, LatticeParams *params, int phase, const double *y, double *dydt) {
    CoSimulation *cs = &m->cs;
    const int positions = solver_positions(m);
    const size_t block = (size_t)positions * sizeof(double);
    double *lattice = cs->lattice_state, *rate = cs->lattice_rate;
    double x_front, v_front, dissipation, force;
    memcpy(lattice, y, block);
    memcpy(lattice + positions, y + positions + 1, block);
    memcpy(lattice + 2 * positions, y + 2 * positions + 2, LATTICE_N_QUADRATURES * sizeof(double));
    if (cs->solver_along_x) {
        lattice_front_port_along_x(params, solver_mirrored(m), lattice, &x_front, &v_front);
    } else {
        lattice_front_port(params, lattice, &x_front, &v_front);
    }
    force = model_contact_force(m, m->contact_on, y[positions] - x_front, y[2 * positions + 1] - v_front,
                                &dissipation);
    params->front_force = force;
    if (cs->solver_along_x) {
        lattice_rhs_along_x(params, solver_mirrored(m), phase, m->wall_mode, lattice, rate);
    } else {
        lattice_rhs(params, phase, m->wall_mode, lattice, rate);
    }
    memcpy(dydt, rate, block);
    dydt[positions] = y[2 * positions + 1];
    memcpy(dydt + positions + 1, rate + positions, block);
    dydt[2 * positions + 1] = -force / PARAM_PROJECTILE_MASS(m);
    memcpy(dydt + 2 * positions + 2, rate + 2 * positions, LATTICE_N_QUADRATURES * sizeof(double));
    dydt[2 * positions + 2 + 1] += dissipation; /* D */
}

/* The contract's derivatives of the solver's layout (the whole lattice's, or its reduced one) under params and the
 * model's discrete states. */
static void layout_rhs(Model *m, LatticeParams *params, int phase, const double *y, double *dydt) {
    if (m->cs.solver_projectile) {
        projectile_rhs(m, params, phase, y, dydt);
    } else if (m->cs.solver_along_x) {
        lattice_rhs_along_x(params, solver_mirrored(m), phase, m->wall_mode, y, dydt);
    } else { /* the whole lattice's state, without the body's (at rest outside projectile mode) */
        lattice_rhs(params, phase, m->wall_mode, y, dydt);
    }
}

/* The sensitivity block's rate (cosimulation.h) from the state block y, its sensitivity s = y + block and the
 * state's rate: the positions' rates are the velocities' sensitivities themselves, the velocities' the forward
 * difference quotient (f(y + delta s, p + delta d) - f(y, p)) / delta under the same backplate modes; the energy
 * integrals carry no sensitivity.
 *
 * Why this way (CVODES's default without a sensitivity right-hand side, its sensitivities outside the error
 * control as CVodeSetSensErrCon has it by default): it needs nothing of the force law but the right-hand side, the
 * nominal state takes the very steps of a run without a seed (its outputs are that run's, bit for bit), and s is
 * integrated by the same method with the same steps: the derivative of the discrete run itself, to the quotient's
 * error. The step delta (sensitivity_delta) moves no parameter by more than SENSITIVITY_STEP of itself: small
 * against the force law's curvature, large against the rounding of f; the state moves by delta s alike. */
static void sensitivity_rate(Model *m, int phase, const double *y, const double *rate, double *sensitivity_rate) {
    CoSimulation *cs = &m->cs;
    const int block = cs->solver.block, positions = solver_vx_base(m), quadratures = solver_quadrature_base(m);
    const double *s = y + block;
    double *moved = cs->sensitivity_state, *moved_rate = cs->sensitivity_rate;
    LatticeParams *params = &cs->sensitivity_params;
    const double delta = cs->sensitivity_delta;
    int i;
    for (i = 0; i < block; i++) moved[i] = y[i] + delta * s[i];
    params->front_force = m->params.front_force; /* the ports at this time (projectile mode: its contact's own) */
    params->back_position = m->params.back_position;
    params->back_velocity = m->params.back_velocity;
    layout_rhs(m, params, phase, moved, moved_rate);
    cs->sensitivity_evaluations++;
    for (i = 0; i < positions; i++) sensitivity_rate[i] = s[positions + i];
    for (i = positions; i < quadratures; i++) sensitivity_rate[i] = (moved_rate[i] - rate[i]) / delta;
    for (i = quadratures; i < block; i++) sensitivity_rate[i] = 0.0;
}

/* The solver's right-hand side at time t: the contract's derivatives of the whole lattice, or of its reduced
 * layout, with the ports' values at t (and the sensitivity block's, when seeded). */
static void solver_rhs(void *context, int phase, double t, const double *y, double *dydt) {
    Model *m = (Model *)context;
    model_ports_at(m, t);
    layout_rhs(m, &m->params, phase, y, dydt);
    if (m->cs.sensitivity_on) sensitivity_rate(m, phase, y, dydt, dydt + m->cs.solver.block);
}

/* The smallest state that carries this lattice's solution (use_symmetry; lattice.h): without the y and z
 * components when it is loaded along x, and then of the upper rows and the front slices only when it is also
 * mirror-symmetric about its middle row or slice (a mirror-symmetric lattice is always loaded along x:
 * lattice_mirror_rows, lattice_mirror_slices). */
static void solver_layout(const Model *m, int *rows, int *slices, int *along_x, int *projectile) {
    *projectile = m->params.load_mode == LOAD_MODE_PROJECTILE;
    *along_x = PARAM_USE_SYMMETRY(m) && lattice_along_x(&m->params);
    *rows = *along_x && lattice_mirror_rows(&m->params) ? lattice_mirror_rows(&m->params) : LATTICE_ROWS;
    *slices = *along_x && lattice_mirror_slices(&m->params) ? lattice_mirror_slices(&m->params) : LATTICE_DEPTH;
}

/* How often face mass f = k*rows + i of the solver's layout stands in the whole lattice: twice for a mirror
 * image in y (all rows but the part's last, the middle one), twice more for one in z. */
static double solver_face_count(const Model *m, int face) {
    const int rows = m->cs.solver_rows, slices = m->cs.solver_slices;
    const int i = face % rows, k = face / rows;
    return (rows != LATTICE_ROWS && i + 1 < rows ? 2.0 : 1.0) *
           (slices != LATTICE_DEPTH && k + 1 < slices ? 2.0 : 1.0);
}

/* Where component i of the whole lattice's state (lattice.h) is in the solver's: -1 for the y and z components
 * when the solver leaves them out (they are 0); a mass outside a mirrored part is its mirror image's in y and
 * in z (only a lattice along x is mirrored: solver_layout). */
static int solver_component_of(const Model *m, int i) {
    const int positions = solver_positions(m), projectile = m->cs.solver_projectile;
    int block, mass, face, row, slice, component;
    if (i >= INDEX_PROJECTILE_POSITION) {
        if (!projectile) return -1; /* the body rests outside projectile mode */
        return i == INDEX_PROJECTILE_POSITION ? positions : 2 * positions + 1;
    }
    if (i >= INDEX_EXTERNAL_WORK) return solver_quadrature_base(m) + (i - INDEX_EXTERNAL_WORK); /* the whole's */
    if (!m->cs.solver_along_x) return i < positions ? i : i + projectile;
    block = i / N_MASSES;
    if (block % N_COMPONENTS != 0) return -1;
    mass = i % N_MASSES;
    face = mass / LATTICE_COLS;
    row = face % LATTICE_ROWS;
    slice = face / LATTICE_ROWS;
    if (row >= m->cs.solver_rows) row = LATTICE_ROWS - 1 - row;
    if (slice >= m->cs.solver_slices) slice = LATTICE_DEPTH - 1 - slice;
    component = (block / N_COMPONENTS) * solver_masses(m) + (slice * m->cs.solver_rows + row) * LATTICE_COLS +
                mass % LATTICE_COLS; /* ux, vx */
    return component < positions ? component : component + projectile;
}

/* The solver's current state as the whole lattice's (itself when the solver integrates the whole). */
static const double *whole_solver_state(Model *m) {
    const double *y = solver_state(m->cs.work);
    int i;
    if (!m->cs.solver_along_x && !m->cs.solver_projectile) return y;
    for (i = 0; i < N_STATE; i++) {
        const int component = solver_component_of(m, i);
        m->cs.whole_state[i] = component < 0 ? 0.0 : y[component];
    }
    return m->cs.whole_state;
}

static int fail(Model *m, const char *reason, char *message, size_t message_size) {
    m->failed = 1;
    snprintf(m->failure, FAILURE_SIZE, "%s", reason);
    snprintf(message, message_size, "%s", reason);
    return -1;
}

int model_terminated(const Model *m) { return m->cs.terminated; }

/* State at time t of the last step (t_old <= t <= t_new); the dense output is paid for only off the ends. */
static double state_component(Model *m, int component, double t) {
    Solver *s = &m->cs.solver;
    if (t == s->t) return solver_state(m->cs.work)[component]; /* also before the first step */
    if (t == s->t_old && s->dense_power == 0) return solver_interpolate_hermite(s, m->cs.work, component, t);
    solver_prepare_dense(s, m->cs.work, solver_rhs, m);
    return solver_interpolate(s, m->cs.work, component, t);
}

/* Component i at time t of the last step: from the dense output, or (hermite) the free cubic Hermite first look. */
static double look(Model *m, int component, double t, int hermite) {
    if (hermite) return solver_interpolate_hermite(&m->cs.solver, m->cs.work, component, t);
    return state_component(m, component, t);
}

/* The backplate force at time t of the last step (its column-C masses). */
static double backplate_force_of(Model *m, double t, int hermite) {
    double ux[N_FACE_MASSES], vx[N_FACE_MASSES];
    const int vx_base = solver_vx_base(m);
    int f;
    for (f = 0; f < solver_faces(m); f++) {
        const int mass = LAST_COLUMN_MASS(f);
        ux[f] = look(m, mass, t, hermite);
        vx[f] = look(m, vx_base + mass, t, hermite);
    }
    /* the ports at t after the looks: preparing the dense output evaluates the right-hand side at its stages,
     * which sets the ports to theirs */
    model_ports_at(m, t);
    return model_backplate_force_of_column(m, ux, vx, m->cs.solver_rows, m->cs.solver_slices);
}

static double backplate_force_at(Model *m, double t) { return backplate_force_of(m, t, 0); }

/* d backplate force / d epsilon at time t of the last step: k_w dux + c_w dvx (the damper while approaching)
 * over the column-C masses in contact, each as often as it stands in the whole lattice. */
static double backplate_force_derivative_at(Model *m, double t) {
    /* zeroed: the compiler cannot see that the second loop reads only what the first wrote */
    double ux[N_FACE_MASSES] = {0.0}, vx[N_FACE_MASSES] = {0.0};
    double dux[N_FACE_MASSES] = {0.0}, dvx[N_FACE_MASSES] = {0.0}, sum = 0.0;
    const int vx_base = solver_vx_base(m), block = m->cs.solver.block;
    int f;
    if (!m->params.has_backplate) return 0.0;
    for (f = 0; f < solver_faces(m); f++) {
        const int mass = LAST_COLUMN_MASS(f);
        ux[f] = state_component(m, mass, t);
        vx[f] = state_component(m, vx_base + mass, t);
        dux[f] = state_component(m, block + mass, t);
        dvx[f] = state_component(m, block + vx_base + mass, t);
    }
    model_ports_at(m, t); /* after the looks, as backplate_force_of */
    for (f = 0; f < solver_faces(m); f++) {
        const double penetration = ux[f] - m->params.backplate_gap - m->params.back_position;
        if (penetration > 0.0) {
            const double approach = vx[f] - m->params.back_velocity;
            const double rate = m->params.k_wall * dux[f] + (approach > 0.0 ? m->params.c_wall * dvx[f] : 0.0);
            sum += solver_face_count(m, f) * rate;
        }
    }
    return sum;
}

/* The compression of the lattice at time t of the last step (its first and last columns). */
static double compression_at(Model *m, double t, int hermite) {
    double first[N_FACE_MASSES], last[N_FACE_MASSES];
    int f;
    for (f = 0; f < solver_faces(m); f++) {
        first[f] = look(m, FIRST_COLUMN_MASS(f), t, hermite);
        last[f] = look(m, LAST_COLUMN_MASS(f), t, hermite);
    }
    return model_compression_of_columns(m, first, last, m->cs.solver_rows, m->cs.solver_slices);
}

/* The compression a sample takes: a step without contact pays for the dense output only when the free first
 * look comes within PEAK_PREFILTER_MARGIN of the largest so far (else the sample cannot raise it). */
static double sample_compression(Model *m, double t) {
    if (m->cs.step_contact_free && m->max_compression > 0.0) {
        const double cheap = compression_at(m, t, 1);
        if (cheap < (1.0 - PEAK_PREFILTER_MARGIN) * m->max_compression) return cheap;
    }
    return compression_at(m, t, 0);
}

/* Brent's minimiser without derivatives (R. P. Brent, Algorithms for Minimization without Derivatives,
 * 1973, ch. 5: parabolic interpolation, golden section where the parabola is not trusted) on -F over
 * [low, high], from x with F(x) = fx, the best point of the grid. It stops once x is within
 * PEAK_TIME_TOLERANCE * |x| + PEAK_TIME_ABSOLUTE of the maximum: near a maximum F is flat to second order,
 * so the peak's value is then exact to rounding. */
static void brent_maximum(Model *m, double low, double high, double *x_best, double *f_best) {
    const double c = 0.5 * (3.0 - sqrt(5.0));
    double x = *x_best, fx = -*f_best, w = x, fw = fx, v = x, fv = fx, d = 0.0, e = 0.0;
    int i;
    for (i = 0; i < PEAK_REFINE_ITERATIONS; i++) {
        const double middle = 0.5 * (low + high), tol = PEAK_TIME_TOLERANCE * fabs(x) + PEAK_TIME_ABSOLUTE;
        const double tol2 = 2.0 * tol;
        double p = 0.0, q = 0.0, r = 0.0, u, fu;
        if (fabs(x - middle) <= tol2 - 0.5 * (high - low)) break;
        if (fabs(e) > tol) { /* a parabola through x, w, v */
            r = (x - w) * (fx - fv);
            q = (x - v) * (fx - fw);
            p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if (q > 0.0) {
                p = -p;
            } else {
                q = -q;
            }
            r = e;
            e = d;
        }
        if (fabs(p) < fabs(0.5 * q * r) && p > q * (low - x) && p < q * (high - x)) {
            d = p / q;
            u = x + d;
            if (u - low < tol2 || high - u < tol2) d = x < middle ? tol : -tol;
        } else {
            e = (x < middle ? high : low) - x;
            d = c * e;
        }
        u = x + (fabs(d) >= tol ? d : (d > 0.0 ? tol : -tol));
        fu = -backplate_force_at(m, u);
        if (fu <= fx) {
            if (u < x) {
                high = x;
            } else {
                low = x;
            }
            v = w;
            fv = fw;
            w = x;
            fw = fx;
            x = u;
            fx = fu;
        } else {
            if (u < x) {
                low = u;
            } else {
                high = u;
            }
            if (fu <= fw || w == x) {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if (fu <= fv || v == x || v == w) {
                v = u;
                fv = fu;
            }
        }
    }
    *x_best = x;
    *f_best = -fx;
}

/* Largest backplate force on [a, b] inside the last step: grid, then Brent's method around the best. */
static void maximum_in_step(Model *m, double a, double b, double *value, double *time) {
    double best = backplate_force_at(m, a), best_time = a, cheap_best;
    int i, best_index = 0;
    {
        const double at_b = backplate_force_at(m, b);
        if (at_b > best) {
            best = at_b;
            best_time = b;
            best_index = PEAK_GRID_POINTS;
        }
    }
    cheap_best = best;
    for (i = 1; i < PEAK_PREFILTER_POINTS; i++) {
        cheap_best = fmax(cheap_best, backplate_force_of(m, a + (b - a) * i / PEAK_PREFILTER_POINTS, 1));
    }
    if (cheap_best <= 0.0 || cheap_best < (1.0 - PEAK_PREFILTER_MARGIN) * m->peak_continuous) {
        *value = best;
        *time = best_time;
        return;
    }
    for (i = 1; i < PEAK_GRID_POINTS; i++) {
        const double t = a + (b - a) * i / PEAK_GRID_POINTS, force = backplate_force_at(m, t);
        if (force > best) {
            best = force;
            best_time = t;
            best_index = i;
        }
    }
    brent_maximum(m, a + (b - a) * (best_index > 0 ? best_index - 1 : 0) / PEAK_GRID_POINTS,
                  a + (b - a) * (best_index < PEAK_GRID_POINTS ? best_index + 1 : PEAK_GRID_POINTS) / PEAK_GRID_POINTS,
                  &best_time, &best);
    *value = best;
    *time = best_time;
}

/* Samples and the continuous peak of the last step, for the part of it up to t_target; a sample above
 * peak_force_limit ends the run at its time (limit_exceeded, limit_time), and the step counts up to there. */
static void process_step(Model *m, double t_target) {
    CoSimulation *cs = &m->cs;
    const Solver *s = &cs->solver;
    const double interval = PARAM_PEAK_SAMPLE_INTERVAL(m), limit = PARAM_PEAK_FORCE_LIMIT(m);
    const double sample_limit = fmin(s->t, t_target + SAMPLE_TIME_SLACK * interval);
    for (;;) {
        const double sample_time = (double)cs->next_sample * interval;
        double force;
        if (sample_time > sample_limit || cs->limit_exceeded) break;
        /* a step without contact has no backplate force: 0 throughout */
        force = cs->step_contact_free ? 0.0 : backplate_force_at(m, sample_time);
        if (cs->sensitivity_on && force > m->peak_sampled) { /* the sample that will hold the peak */
            m->peak_sampled_derivative = cs->step_contact_free ? 0.0 : backplate_force_derivative_at(m, sample_time);
        }
        model_take_sample(m, sample_time, force, sample_compression(m, sample_time));
        cs->next_sample++;
        if (limit > 0.0 && m->peak_sampled > limit) {
            cs->limit_exceeded = 1;
            cs->limit_time = sample_time;
            t_target = fmin(t_target, sample_time);
        }
    }
    if (s->steps_accepted == 0 || cs->step_peak_committed) return;
    if (!cs->step_peak_known) {
        if (cs->step_contact_free) {
            cs->step_peak = 0.0;
            cs->step_peak_time = s->t_old;
        } else {
            maximum_in_step(m, s->t_old, s->t, &cs->step_peak, &cs->step_peak_time);
        }
        cs->step_peak_known = 1;
    }
    if (s->t <= t_target) {
        model_take_force(m, cs->step_peak_time, cs->step_peak);
        cs->step_peak_committed = 1;
    }
}

/* The outputs at t_target inside the last step: the whole lattice's state there, and the continuous peak
 * with the part of the last step up to t_target (the step may reach past it). */
static void update_outputs(Model *m, double t_target) {
    CoSimulation *cs = &m->cs;
    const Solver *s = &cs->solver;
    double peak = m->peak_continuous, peak_time = m->peak_continuous_time;
    int i;
    for (i = 0; i < N_STATE; i++) {
        const int component = solver_component_of(m, i);
        m->output_state[i] = component < 0 ? 0.0 : state_component(m, component, t_target);
    }
    if (s->steps_accepted > 0 && cs->step_peak_known && !cs->step_peak_committed) {
        /* the last step reaches past t_target: only the part up to t_target counts (not committed) */
        double partial = cs->step_peak, partial_time = cs->step_peak_time;
        if (partial_time > t_target) maximum_in_step(m, s->t_old, t_target, &partial, &partial_time);
        if (partial > peak) {
            peak = partial;
            peak_time = partial_time;
        }
    }
    model_ports_at(m, t_target);
    model_update_outputs(m, peak, peak_time, fmin(m->last_contact_time, t_target),
                         s->rhs_evaluations + cs->sensitivity_evaluations, s->steps_accepted, s->steps_rejected);
    m->real[VR_BACKPLATE_FORCE_DERIVATIVE] = cs->sensitivity_on ? backplate_force_derivative_at(m, t_target) : 0.0;
}

/* No column-C mass in contact with the backplate (always so without one). */
static int wall_free(const Model *m) {
    int f;
    for (f = 0; f < N_FACE_MASSES; f++) {
        if (m->wall_mode[f] != WALL_FREE) return 0;
    }
    return 1;
}

/* The modes docs/model.md gives the column-C masses in the state at the end of the last step. */
static void wall_modes_of_state(Model *m, signed char *modes) {
    model_ports_at(m, m->cs.solver.t);
    model_wall_modes(m, solver_state(m->cs.work), m->cs.solver_rows, m->cs.solver_slices, solver_vx_base(m), modes);
}

/* Where inside the last step event indicator k (the contract's, under the step's frozen modes) takes the
 * sign it has at the step's end: the end of a bracket [low, high] that already has it, narrowed to rounding
 * on the dense output of its component by the Illinois variant of regula falsi (M. Dowell and P. Jarratt,
 * BIT 11 (1971) 168-174), with a bisection whenever the bracket has not halved over two evaluations, which
 * keeps the worst case within a few times bisection's. Where the indicator already has the end's sign at the
 * step's start, no crossing is inside and the bracket closes on the start by bisection. */
/* Projectile mode: the front port at time t of the last step, from the face masses the solver holds. */
static void front_port_at(Model *m, double t, double *x_front, double *v_front) {
    const int vx_base = solver_vx_base(m);
    double x = 0.0, v = 0.0;
    int f;
    for (f = 0; f < solver_faces(m); f++) {
        const double weight = solver_face_count(m, f) *
                              lattice_load_weight(&m->params, f % m->cs.solver_rows, f / m->cs.solver_rows);
        if (weight == 0.0) continue;
        x += weight * state_component(m, FIRST_COLUMN_MASS(f), t);
        v += weight * state_component(m, vx_base + FIRST_COLUMN_MASS(f), t);
    }
    *x_front = x;
    *v_front = v;
}

/* Projectile mode: the contact's mode of the solver's state at time t of the last step. */
static int contact_at(Model *m, double t) {
    const int positions = solver_positions(m);
    double x_front, v_front;
    front_port_at(m, t, &x_front, &v_front);
    return model_contact_of(state_component(m, positions, t) - x_front,
                            state_component(m, 2 * positions + 1, t) - v_front);
}

static double indicator_at(Model *m, int k, double t) {
    int component;
    double offset;
    if (k == IMPACT_INDICATOR) { /* the body's overlap with the face */
        double x_front, v_front;
        front_port_at(m, t, &x_front, &v_front);
        return state_component(m, solver_positions(m), t) - x_front;
    }
    model_ports_at(m, t); /* a moving backplate moves the threshold */
    model_indicator_definition(m, k, m->cs.solver_rows, solver_vx_base(m), &component, &offset);
    return state_component(m, component, t) - offset;
}

static double locate_switch(Model *m, int k) {
    const Solver *s = &m->cs.solver;
    const double g_end = indicator_at(m, k, s->t);
    const int positive_at_end = g_end > 0.0;
    double low = s->t_old, high = s->t, g_low = indicator_at(m, k, low);
    double g_high = g_end, width_1 = INFINITY, width_2 = INFINITY;
    int i, side = 0;
    if ((g_low > 0.0) == positive_at_end) g_low = g_high = 0.0; /* no sign change: bisection alone */
    for (i = 0; i < 400 && high - low > 4.0 * DBL_EPSILON * fmax(fabs(high), 1.0); i++) {
        const double width = high - low, nudge = 2.0 * DBL_EPSILON * fmax(fabs(high), 1.0);
        double x = 0.5 * (low + high), g;
        if (g_high != g_low && width <= 0.5 * width_2) { /* halved over the last two: secant again */
            /* kept a rounding step inside the bracket: a secant on an end (an end's indicator exactly 0)
             * would make no progress, a step beyond it usually closes the bracket */
            x = fmin(fmax(high - g_high * width / (g_high - g_low), low + nudge), high - nudge);
        }
        width_2 = width_1;
        width_1 = width;
        g = indicator_at(m, k, x);
        if ((g > 0.0) == positive_at_end) {
            high = x;
            g_high = g;
            if (side == 1) g_low *= 0.5; /* Illinois: the stale end's value halved */
            side = 1;
        } else {
            low = x;
            g_low = g;
            if (side == -1) g_high *= 0.5;
            side = -1;
        }
    }
    return high;
}

/* The sensitivity's jump where backplate modes switched at the current time (before: the modes until then). A
 * switch at the time tau where indicator g crosses 0 moves with epsilon by dtau = -(dg . s) / (dg/dt), and the
 * rate that changes there moves with it: s gains (f_before - f_after) dtau. Each mass's wall force is its own, so
 * each switching mass's jump is that of its own velocity, and at the switch it is known in closed form: the
 * wall's spring force k_w p is 0 there (p = 0 is the contact's switch), and so is the damper's c_w (vx - v_back)
 * at the damper's switch; only a contact that begins or ends approaching changes the force, by the damper's
 * c_w (vx - v_back), where g = ux - gap - x_back has dg/dt = vx - v_back too: the jump is -+ c_w s_ux / m, the
 * two vanishing factors cancelled rather than divided (a grazing contact, vx - v_back near 0, would otherwise
 * divide rounding by it). The solver's derivative at the state, which its next step starts from, is corrected
 * for the new s. */
static void sensitivity_jump(Model *m, const signed char *before) {
    CoSimulation *cs = &m->cs;
    Solver *s = &cs->solver;
    const int block = s->block, vx_base = solver_vx_base(m);
    const double damper = m->params.c_wall / m->params.column[LATTICE_COLS - 1].mass;
    double *y = cs->work; /* the solver's state, its first row (solver_state) */
    double *sensitivity = y + block, *end_derivative;
    int i, jumped = 0;
    for (i = 0; i < solver_faces(m); i++) {
        const int f = (i / cs->solver_rows) * LATTICE_ROWS + i % cs->solver_rows, mass = LAST_COLUMN_MASS(i);
        const int contact_switched = (before[f] != WALL_FREE) != (m->wall_mode[f] != WALL_FREE);
        if (!contact_switched) continue; /* the damper's switch, or none: no force changes */
        if (m->wall_mode[f] == WALL_APPROACHING) {
            sensitivity[vx_base + mass] -= damper * sensitivity[mass];
            jumped = 1;
        } else if (before[f] == WALL_APPROACHING) {
            sensitivity[vx_base + mass] += damper * sensitivity[mass];
            jumped = 1;
        }
    }
    end_derivative = solver_end_derivative(s, cs->work);
    if (jumped && end_derivative) { /* its state part stays the solver's own (the nominal run's steps) */
        double *rate = cs->whole_state; /* scratch */
        model_ports_at(m, s->t);
        layout_rhs(m, &m->params, s->phase, y, rate); /* the rate under the modes now */
        cs->sensitivity_evaluations++;
        sensitivity_rate(m, s->phase, y, rate, end_derivative + block);
    }
}

/* The backplate's switches (contact on/off, damping on/off) and the projectile's contact inside the last step:
 * the step is cut back to the earliest one and the modes are switched there, so no step integrates across a
 * discontinuity. */
static int handle_events(Model *m) {
    Solver *s = &m->cs.solver;
    signed char at_end[N_FACE_MASSES];
    double located[2 * N_FACE_MASSES + 1], earliest = s->t, cut_time;
    int i, changed = 0, cut = 0, count = 0;
    const int contact_at_end = m->cs.solver_projectile ? contact_at(m, s->t) : m->contact_on;
    wall_modes_of_state(m, at_end);
    changed = contact_at_end != m->contact_on;
    /* the face masses the solver holds (f = k*R + i of the whole face); the others are their mirror images */
    for (i = 0; i < solver_faces(m); i++) {
        const int f = (i / m->cs.solver_rows) * LATTICE_ROWS + i % m->cs.solver_rows;
        changed = changed || at_end[f] != m->wall_mode[f];
    }
    if (!changed) return 0;
    solver_prepare_dense(s, m->cs.work, solver_rhs, m); /* in the step's own modes, before they change */
    for (i = 0; i < solver_faces(m); i++) {
        const int f = (i / m->cs.solver_rows) * LATTICE_ROWS + i % m->cs.solver_rows;
        const int contact_before = m->wall_mode[f] != WALL_FREE, contact_after = at_end[f] != WALL_FREE;
        if (at_end[f] == m->wall_mode[f]) continue;
        if (contact_before != contact_after) located[count++] = locate_switch(m, CONTACT_INDICATOR(f));
        if (contact_before && (m->wall_mode[f] == WALL_APPROACHING) != (at_end[f] == WALL_APPROACHING)) {
            located[count++] = locate_switch(m, DAMPING_INDICATOR(f));
        }
    }
    if (contact_at_end != m->contact_on) located[count++] = locate_switch(m, IMPACT_INDICATOR);
    for (i = 0; i < count; i++) earliest = fmin(earliest, located[i]);
    /* Switches within SIMULTANEOUS_EVENT_FRACTION of a step after the earliest are one event, cut at the
     * last of them: mirror-image masses (the armour scene is symmetric about its middle row) cross within
     * rounding of each other, and cutting at the first alone would leave the other to cut the next step back
     * to a sliver of itself, a whole step's right-hand sides for nothing. */
    cut_time = earliest;
    for (i = 0; i < count; i++) {
        if (located[i] <= earliest + SIMULTANEOUS_EVENT_FRACTION * s->h_last) cut_time = fmax(cut_time, located[i]);
    }
    /* A fixed-step solver takes a switch within MIN_EVENT_FRACTION of its step's start at the step's end
     * instead: its cubic dense output is too rough to place a switch that close, and cutting back there can
     * make no progress (near its stability limit it chatters on one switch). The adaptive solver always
     * cuts back: its error control keeps the steps after an event honest. */
    const double shortest = solver_is_adaptive(s->method) ? 0.0 : MIN_EVENT_FRACTION * s->h_last;
    if (earliest > s->t_old + shortest && cut_time < s->t) {
        solver_truncate(s, m->cs.work, solver_rhs, m, cut_time);
        cut = 1;
    }
    {
        signed char before[N_FACE_MASSES];
        memcpy(before, m->wall_mode, sizeof(before));
        wall_modes_of_state(m, m->wall_mode);
        if (m->cs.sensitivity_on) sensitivity_jump(m, before);
    }
    if (m->cs.solver_projectile && contact_at(m, s->t) != m->contact_on) {
        m->contact_on = !m->contact_on;
        s->end_derivative_valid = 0; /* the contact force changes there */
    }
    return cut;
}

void model_driver_initialize(Model *m) {
    CoSimulation *cs = &m->cs;
    double *start = cs->lattice_state; /* scratch: the start state in the solver's layout */
    int i;
    char seed[64];
    double seed_value;
    solver_layout(m, &cs->solver_rows, &cs->solver_slices, &cs->solver_along_x, &cs->solver_projectile);
    memset(start, 0, sizeof(cs->lattice_state));
    for (i = 0; i < N_STATE; i++) {
        const int component = solver_component_of(m, i);
        if (component >= 0) start[component] = m->output_state[i];
    }
    cs->sensitivity_on = model_sensitivity_seed(m, seed, sizeof(seed), &seed_value);
    cs->sensitivity_evaluations = 0;
    if (cs->sensitivity_on) {
        cs->sensitivity_delta = model_sensitivity_delta(m);
        model_sensitivity_params(m, cs->sensitivity_delta, &cs->sensitivity_params);
    }
    {
        const int block = solver_quadrature_base(m) + LATTICE_N_QUADRATURES, blocks = cs->sensitivity_on ? 2 : 1;
        solver_init(&cs->solver, cs->work, PARAM_SOLVER(m), blocks * block, solver_vx_base(m), blocks, PARAM_RTOL(m),
                    PARAM_ATOL(m), PARAM_FIXED_STEP(m), m->load_on, start);
    }
    if (solver_mirrored(m) || cs->solver_along_x || cs->sensitivity_on) {
        /* each mass of a mirrored part stands for itself and its mirror images (1, 2 or 4 of them: in y, in z):
         * the error norms weight it so, and take their mean over the whole state (the y and z components, left
         * out, are 0 and err by 0), so the steps are the whole lattice's; the sensitivity block weighs 0 */
        double *weight = cs->whole_state; /* scratch until the first step */
        const int masses = solver_masses(m);
        int component;
        const int positions = solver_positions(m), projectile = cs->solver_projectile;
        for (component = 0; component < cs->solver.block; component++) {
            /* the lattice's component: the velocities sit one further on behind the body's position */
            const int lattice = projectile && component > positions ? component - 1 : component;
            const int body = projectile && (component == positions || component == 2 * positions + 1);
            const int mechanical = !body && lattice < 2 * positions;
            weight[component] = mechanical ? solver_face_count(m, (lattice % masses) / LATTICE_COLS) : 1.0;
        }
        solver_set_norm_weights(&cs->solver, cs->work, weight,
                                (double)(N_STATE - (projectile ? 0 : N_PROJECTILE_STATES)));
    }
    cs->solver.t = m->time;
    wall_modes_of_state(m, m->wall_mode);
    cs->next_sample = (long)ceil(m->time / PARAM_PEAK_SAMPLE_INTERVAL(m) - SAMPLE_TIME_SLACK);
    process_step(m, m->time);
    update_outputs(m, m->time);
}

/* Kinetic energy far beyond what the load and the diagonals put in means the solution diverged. */
static int check_divergence(Model *m, char *message, size_t message_size) {
    const Solver *s = &m->cs.solver;
    const double *y = solver_state(m->cs.work);
    const int masses = solver_masses(m), velocity_blocks = m->cs.solver_along_x ? 1 : N_COMPONENTS;
    const double *velocity = y + solver_vx_base(m), *quadrature = y + solver_quadrature_base(m);
    const double injected = m->initial_energy + fabs(quadrature[0]) + fabs(quadrature[2]); /* W_ext, W_nr */
    const double impulse = m->params.load_total * fmax(m->params.load_duration, PARAM_PEAK_SAMPLE_INTERVAL(m));
    const double lightest = lattice_lightest_mass(&m->params); /* kinetic below: a lower bound */
    const double floor = 1e-9 + 1e-6 * impulse * impulse / lightest;
    double speed_squared = 0.0, kinetic;
    char reason[FAILURE_SIZE];
    int i;
    if (!solver_mirrored(m)) {
        for (i = 0; i < velocity_blocks * masses; i++) speed_squared += velocity[i] * velocity[i];
    } else { /* a mirrored part (vx only): each mass as often as it stands in the whole (its images move as it) */
        double once = 0.0, twice = 0.0, four_times = 0.0;
        for (i = 0; i < masses; i++) {
            const double count = solver_face_count(m, i / LATTICE_COLS), squared = velocity[i] * velocity[i];
            if (count == 1.0) {
                once += squared;
            } else if (count == 2.0) {
                twice += squared;
            } else {
                four_times += squared;
            }
        }
        speed_squared = 4.0 * four_times + 2.0 * twice + once;
    }
    kinetic = 0.5 * lightest * speed_squared;
    if (isfinite(kinetic) && isfinite(injected) && kinetic <= ENERGY_LIMIT_FACTOR * injected + floor) {
        /* every BALANCE_CHECK_STEPS steps (it costs about one right-hand side): the balance must roughly
         * close; a solution that makes energy out of nothing is diverging, even while it stays bounded */
        double potential, balance;
        if (s->steps_accepted % BALANCE_CHECK_STEPS != 0) return 0;
        model_ports_at(m, s->t);
        balance = model_energy_balance(m, whole_solver_state(m), &kinetic, &potential);
        if (isfinite(balance) && fabs(balance) <= BALANCE_LIMIT_FRACTION * injected + floor) return 0;
        snprintf(reason, sizeof(reason),
                 "the solution diverged at t = %.9g s: the energy balance is off by %g J of %g J put in (solver %d, "
                 "fixed_step = %g s, rtol = %g)",
                 s->t, balance, injected, s->method, s->fixed_step, s->rtol);
        return fail(m, reason, message, message_size);
    }
    if (solver_is_adaptive(s->method)) {
        snprintf(reason, sizeof(reason),
                 "the solution diverged at t = %.9g s: kinetic energy %g J against %g J of energy put in (rtol = %g)",
                 s->t, kinetic, injected, s->rtol);
    } else {
        snprintf(reason, sizeof(reason),
                 "the solution diverged at t = %.9g s: kinetic energy %g J against %g J of energy put in; "
                 "fixed_step = %g s is beyond the stability limit of solver %d",
                 s->t, kinetic, injected, s->fixed_step, s->method);
    }
    return fail(m, reason, message, message_size);
}

/* 0 when a doStep to t_target may start, else -1 and why (nothing changes). */
static int check_advance(const Model *m, double t_target, char *message, size_t message_size) {
    const Solver *s = &m->cs.solver;
    const double interval = PARAM_PEAK_SAMPLE_INTERVAL(m);
    if (!m->initialized) {
        snprintf(message, message_size, "the model is not initialised");
        return -1;
    }
    if (m->failed) {
        snprintf(message, message_size, "an earlier step failed (%s); reset the FMU to start again", m->failure);
        return -1;
    }
    if (m->cs.terminated) {
        snprintf(message, message_size,
                 "the run stopped at t = %.17g s, where peak_backplate_force exceeded peak_force_limit = %g N; reset "
                 "the FMU to start again",
                 m->time, PARAM_PEAK_FORCE_LIMIT(m));
        return -1;
    }
    if (!(t_target >= m->time)) {
        snprintf(message, message_size, "cannot step back from t = %.17g to t = %.17g", m->time, t_target);
        return -1;
    }
    if (m->stop_time_defined && t_target > m->stop_time) {
        snprintf(message, message_size, "t = %.17g is beyond the stop time %.17g given at setup", t_target,
                 m->stop_time);
        return -1;
    }
    if ((t_target - m->time) / interval > MAX_SAMPLES_PER_DO_STEP) {
        snprintf(message, message_size,
                 "a doStep over %g s takes %g samples of peak_sample_interval = %g s, more than the cap of %.0f "
                 "samples per doStep: take shorter communication steps or a longer peak_sample_interval",
                 t_target - m->time, (t_target - m->time) / interval, interval, MAX_SAMPLES_PER_DO_STEP);
        return -1;
    }
    if ((s->method == SOLVER_RK4 || s->method == SOLVER_SEMI_IMPLICIT_EULER) &&
        (t_target - m->time) / s->fixed_step > (double)MAX_STEPS_PER_DO_STEP) {
        snprintf(message, message_size,
                 "a doStep over %g s takes %g steps of fixed_step = %g s, more than the cap of %ld solver steps per "
                 "doStep: take shorter communication steps or a longer fixed_step",
                 t_target - m->time, (t_target - m->time) / s->fixed_step, s->fixed_step, MAX_STEPS_PER_DO_STEP);
        return -1;
    }
    return 0;
}

int model_advance(Model *m, double t_target, char *message, size_t message_size) {
    CoSimulation *cs = &m->cs;
    Solver *s = &cs->solver;
    char reason[FAILURE_SIZE];
    long steps_before;
    if (check_advance(m, t_target, message, message_size)) return -1;
    steps_before = s->steps_accepted + s->steps_rejected;
    process_step(m, t_target); /* what remains of the last step up to the new target */
    while (s->t < t_target && !cs->limit_exceeded) {
        const int free_before = wall_free(m);
        int cut_by_event;
        double t_limit = INFINITY;
        model_next_time_event(m, &t_limit);
        if (m->stop_time_defined) t_limit = fmin(t_limit, m->stop_time);
        if (m->ports_driven) t_limit = fmin(t_limit, t_target); /* the inputs may change there */
        if (s->steps_accepted + s->steps_rejected - steps_before >= MAX_STEPS_PER_DO_STEP) {
            snprintf(reason, sizeof(reason),
                     "this doStep reached the cap of %ld solver steps per doStep at t = %.9g s, short of %.9g s: "
                     "take shorter communication steps (solver %d, rtol = %g)",
                     MAX_STEPS_PER_DO_STEP, s->t, t_target, s->method, s->rtol);
            return fail(m, reason, message, message_size);
        }
        if (solver_step(s, cs->work, solver_rhs, m, t_limit, reason, sizeof(reason))) {
            return fail(m, reason, message, message_size);
        }
        cs->step_peak_known = 0;
        cs->step_peak_committed = 0;
        cut_by_event = m->params.has_backplate || cs->solver_projectile ? handle_events(m) : 0;
        /* in contact during the step (its frozen modes) or from its end on (the modes after its events) */
        cs->step_contact_free = free_before && wall_free(m);
        if (!cs->step_contact_free) m->last_contact_time = s->t;
        if (!cut_by_event || s->t - s->t_old > 1e-12 * (1.0 + fabs(s->t))) {
            cs->stalled_steps = 0;
        } else if (++cs->stalled_steps > MAX_STALLED_STEPS) {
            snprintf(reason, sizeof(reason),
                     "the backplate switches chatter at t = %.9g s: %d steps in a row made no progress (solver %d, "
                     "fixed_step = %g s, rtol = %g)",
                     s->t, MAX_STALLED_STEPS, s->method, s->fixed_step, s->rtol);
            return fail(m, reason, message, message_size);
        }
        if (check_divergence(m, message, message_size)) return -1;
        if (model_load_switches_off(m, s->t)) {
            /* the dense output of this step belongs to the loaded phase: take it before the switch */
            solver_prepare_dense(s, cs->work, solver_rhs, m);
            m->load_on = 0;
            solver_set_phase(s, 0);
        }
        process_step(m, t_target);
    }
    if (cs->limit_exceeded) {
        update_outputs(m, cs->limit_time);
        m->time = cs->limit_time;
        cs->terminated = 1;
        snprintf(message, message_size,
                 "peak_backplate_force = %.17g N exceeded peak_force_limit = %g N at t = %.17g s: the run stops there",
                 m->peak_sampled, PARAM_PEAK_FORCE_LIMIT(m), cs->limit_time);
        return MODEL_LIMIT_REACHED;
    }
    update_outputs(m, t_target);
    m->time = t_target;
    m->derivative_valid = 0;
    return 0;
}

int model_driver_check(const Model *m, char *message, size_t message_size) {
    const CoSimulation *cs = &m->cs;
    const Solver *s = &cs->solver;
    const double interval = PARAM_PEAK_SAMPLE_INTERVAL(m);
    int rows, slices, along_x, projectile;
    if (!m->initialized) return 0; /* the solver is set up at initialisation */
    solver_layout(m, &rows, &slices, &along_x, &projectile);
    {
        char seed[64];
        double seed_value;
        const int seeded = model_sensitivity_seed(m, seed, sizeof(seed), &seed_value);
        LatticeParams moved;
        if (cs->sensitivity_on != seeded) {
            snprintf(message, message_size, "the state is corrupt: its sensitivity flag %d is not its seeds' %d",
                     cs->sensitivity_on, seeded);
            return -1;
        }
        if (seeded) {
            const LatticeParams *held = &cs->sensitivity_params;
            model_sensitivity_params(m, cs->sensitivity_delta, &moved);
            if (cs->sensitivity_delta != model_sensitivity_delta(m) ||
                memcmp(moved.column, held->column, sizeof(moved.column)) != 0 || held->rows != moved.rows ||
                held->cols != moved.cols || held->depth != moved.depth || held->load_patch != moved.load_patch ||
                held->load_mode != moved.load_mode || held->spring_law != moved.spring_law ||
                held->diagonal_rule != moved.diagonal_rule || held->has_backplate != moved.has_backplate) {
                snprintf(message, message_size, "the state is corrupt: its sensitivity's parameters are not its seeds'");
                return -1;
            }
        }
    }
    {
        const int positions = (along_x ? 1 : N_COMPONENTS) * rows * LATTICE_COLS * slices + projectile;
        const int block = 2 * positions + LATTICE_N_QUADRATURES, size = (cs->sensitivity_on ? 2 : 1) * block;
        const int norm_size = N_STATE - (projectile ? 0 : N_PROJECTILE_STATES);
        const int reduced = rows != LATTICE_ROWS || slices != LATTICE_DEPTH || along_x || cs->sensitivity_on;
        if (cs->solver_rows != rows || cs->solver_slices != slices || cs->solver_along_x != along_x ||
            cs->solver_projectile != projectile || s->n != size || s->block != block ||
            s->n_second_order != positions ||
            m->params.rows != LATTICE_ROWS || m->params.cols != LATTICE_COLS || m->params.depth != LATTICE_DEPTH ||
            s->weighted != reduced || s->norm_size != (double)norm_size) {
            snprintf(message, message_size,
                     "the state is corrupt or foreign: its sizes (solver rows %d, slices %d, along x %d, state %d, "
                     "positions %d, lattice %d x %d x %d, norm over %g) are not this FMU's (%d, %d, %d, %d, %d, "
                     "%d x %d x %d, %d)",
                     cs->solver_rows, cs->solver_slices, cs->solver_along_x, s->n, s->n_second_order,
                     m->params.rows, m->params.cols, m->params.depth, s->norm_size, rows, slices, along_x, size,
                     positions, LATTICE_ROWS, LATTICE_COLS, LATTICE_DEPTH, norm_size);
            return -1;
        }
    }
    if (s->method != PARAM_SOLVER(m) ||
        (s->dense_power == DENSE_FROM_STAGES ? !(s->method == SOLVER_TSIT5 || s->method == SOLVER_DOPRI5)
         : s->dense_power == DENSE_NYSTROM   ? s->method != SOLVER_RKN5
                                             : s->dense_power < 0 || s->dense_power > SOLVER_DENSE_ROWS) ||
        (s->phase != 0 && s->phase != 1)) {
        snprintf(message, message_size, "the state is corrupt: its solver fields are out of range (solver %d of %d, "
                 "dense output %d, phase %d)", s->method, PARAM_SOLVER(m), s->dense_power, s->phase);
        return -1;
    }
    /* the solver is at or ahead of the communication time, and the next sample lies between them (samples
     * are bounded per doStep only from the communication time on); Model Exchange leaves the solver at the
     * start, the importer sets the time */
    if (!m->exchange &&
        (!(m->time >= 0.0 && m->time <= s->t && s->t <= DBL_MAX) ||
         !((double)cs->next_sample >= m->time / interval - 2.0 && (double)cs->next_sample <= s->t / interval + 2.0))) {
        snprintf(message, message_size, "the state is corrupt: its times are inconsistent (communication time %g s, "
                 "solver time %g s, next sample %ld)", m->time, s->t, cs->next_sample);
        return -1;
    }
    if ((cs->limit_exceeded != 0 && cs->limit_exceeded != 1) || (cs->terminated != 0 && cs->terminated != 1)) {
        snprintf(message, message_size, "the state is corrupt: its peak_force_limit flags are out of range");
        return -1;
    }
    return 0;
}

/* ---- The ports between communication points (docs/model.md section 11) ---- */

/* Before an input or its derivative changes at the communication point: a solver that went past it with the old
 * inputs goes back to it (its last step cut there on the dense output, that part's peak taken), and the ports
 * are anchored there with their present values. */
static void ports_to_communication_point(Model *m) {
    CoSimulation *cs = &m->cs;
    Solver *s = &cs->solver;
    if (s->t > m->time) {
        solver_truncate(s, cs->work, solver_rhs, m, m->time);
        cs->step_peak_known = 0;
        cs->step_peak_committed = 0;
        process_step(m, m->time);
    }
    model_ports_at(m, m->time);
    m->port_time = m->time;
    m->port_front_force = m->params.front_force;
    m->port_back_position = m->params.back_position;
    m->port_back_velocity = m->params.back_velocity;
}

/* After the change: the solver goes on from the communication point under the new inputs, and the outputs
 * (the backplate force, its modes) are those of the new inputs there. */
static void ports_changed(Model *m) {
    m->cs.solver.end_derivative_valid = 0;
    m->ports_driven = 1;
    wall_modes_of_state(m, m->wall_mode);
    m->derivative_valid = 0;
    update_outputs(m, m->time);
}

/* Whether value is what input vr already is at the communication point, held (a master that sets every input
 * at every step, changed or not, leaves the run as it was). */
static int input_unchanged(Model *m, unsigned int vr, double value) {
    model_ports_at(m, m->time);
    if (vr == VR_F_FRONT) return value == m->params.front_force && m->front_force_rate == 0.0;
    if (vr == VR_V_BACK) return value == m->params.back_velocity && m->back_velocity_rate == 0.0;
    return value == m->params.back_position && !m->back_position_rate_given;
}

int model_driver_set_input(Model *m, unsigned int vr, double value, char *message, size_t message_size) {
    (void)message;
    (void)message_size;
    m->real[vr] = value;
    if (m->failed || m->cs.terminated) return 0; /* the run goes no further: nothing to move */
    if (input_unchanged(m, vr, value)) return 0;
    ports_to_communication_point(m);
    if (vr == VR_F_FRONT) {
        m->port_front_force = value;
        m->front_force_rate = 0.0; /* held until a derivative is given */
    } else if (vr == VR_V_BACK) {
        m->port_back_velocity = value;
        m->back_velocity_rate = 0.0;
    } else if (vr == VR_X_BACK) {
        /* a backplate put somewhere else than where it moved to does work on the lattice in the jump: the
         * change of the backplate's potential goes into external_work, so the balance still closes */
        const double *y = whole_solver_state(m);
        const double before = lattice_backplate_potential(&m->params, y);
        m->port_back_position = value;
        m->back_position_rate_given = 0;
        model_ports_at(m, m->time);
        m->cs.work[solver_quadrature_base(m)] += lattice_backplate_potential(&m->params, y) - before;
    }
    ports_changed(m);
    return 0;
}

int model_set_input_derivative(Model *m, unsigned int vr, int order, double value, char *message,
                               size_t message_size) {
    const char *name = vr == VR_F_FRONT ? "F_front" : vr == VR_X_BACK ? "x_back" : "v_back";
    if (vr != VR_F_FRONT && vr != VR_X_BACK && vr != VR_V_BACK) {
        snprintf(message, message_size, "value reference %u is not an input (the inputs: F_front, x_back, v_back)",
                 vr);
        return -1;
    }
    if (order != 1) {
        snprintf(message, message_size,
                 "%s: derivative order %d is not allowed: this FMU extrapolates its inputs linearly (order 1 only)",
                 name, order);
        return -1;
    }
    if (!isfinite(value)) {
        snprintf(message, message_size, "%s: its derivative %g is not allowed: it must be finite", name, value);
        return -1;
    }
    if (m->exchange) {
        snprintf(message, message_size,
                 "%s: input derivatives are for Co-Simulation; under Model Exchange the importer sets the inputs "
                 "at every time it asks for derivatives",
                 name);
        return -1;
    }
    if (m->initialized && !m->failed && !m->cs.terminated) ports_to_communication_point(m);
    if (vr == VR_F_FRONT) {
        m->front_force_rate = value;
    } else if (vr == VR_V_BACK) {
        m->back_velocity_rate = value;
    } else {
        m->back_position_rate = value;
        m->back_position_rate_given = 1;
    }
    if (m->initialized && !m->failed && !m->cs.terminated) ports_changed(m);
    return 0;
}

int model_get_output_derivative(Model *m, unsigned int vr, int order, double *value, char *message,
                                size_t message_size) {
    const double *y = m->output_state;
    const char *name = vr == VR_X_FRONT ? "x_front" : vr == VR_V_FRONT ? "v_front" : "backplate_force";
    if (vr != VR_X_FRONT && vr != VR_V_FRONT && vr != VR_BACKPLATE_FORCE) {
        snprintf(message, message_size,
                 "value reference %u: output derivatives are given for x_front, v_front and backplate_force only", vr);
        return -1;
    }
    if (order != 1) {
        snprintf(message, message_size, "%s: derivative order %d is not allowed: allowed 1 (maxOutputDerivativeOrder)",
                 name, order);
        return -1;
    }
    if (!m->initialized || m->exchange) {
        snprintf(message, message_size, "%s: output derivatives are given in Co-Simulation after initialisation",
                 name);
        return -1;
    }
    if (vr == VR_X_FRONT) {
        *value = m->real[VR_V_FRONT];
        return 0;
    }
    model_ports_at(m, m->time);
    if (!m->derivative_valid) {
        model_derivatives(m, m->load_on, y, m->derivative);
        m->derivative_valid = 1;
    }
    if (vr == VR_V_FRONT) {
        double velocity;
        lattice_front_port(&m->params, m->derivative, &velocity, value); /* (ux', vx') = (vx, ax) */
        return 0;
    }
    {
        /* d/dt of k_w p + c_w (vx - v_back) over the masses in contact (the damper while approaching) */
        const double elapsed = m->time - m->port_time;
        const double back_rate = (m->back_position_rate_given ? m->back_position_rate : m->port_back_velocity) +
                                 m->back_velocity_rate * elapsed;
        double rate = 0.0;
        int f;
        for (f = 0; f < N_FACE_MASSES; f++) {
            const int mass = LAST_COLUMN_MASS(f);
            if (!m->params.has_backplate || m->wall_mode[f] == WALL_FREE) continue;
            rate += m->params.k_wall * (y[VX_BASE + mass] - back_rate);
            if (m->wall_mode[f] == WALL_APPROACHING) {
                rate += m->params.c_wall * (m->derivative[VX_BASE + mass] - m->back_velocity_rate);
            }
        }
        *value = rate;
    }
    return 0;
}
