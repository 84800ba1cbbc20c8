/* The physics of SPEC.md: springs, damping, load, backplate. See lattice.h for the state layout. */
#include "lattice.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Below this separation a spring exerts no force (SPEC section 2: the direction is undefined). */
#define SPRING_MIN_DISTANCE 1e-12

/* The force law, f(r; k, alpha) = k * stretch * r/|r| (SPEC section 2): exponential k (exp(alpha |r|) - 1)
 * as SPEC writes it (exp rather than expm1: the cheaper call, and the one the study's numbers came from),
 * or linear k |r| for the two-mass scene. */
static inline double spring_stretch(int linear, double alpha, double distance) {
    return linear ? distance : exp(alpha * distance) - 1.0;
}

double lattice_spring_force_magnitude(int spring_law, double k, double alpha, double distance) {
    return k * spring_stretch(spring_law == SPRING_LINEAR, alpha, distance);
}

/* The potential whose derivative is the force law. */
double lattice_spring_potential(int spring_law, double k, double alpha, double distance) {
    if (spring_law == SPRING_LINEAR) return 0.5 * k * distance * distance;
    return (k / alpha) * (expm1(alpha * distance) - alpha * distance);
}

/* The constants each end of a spring uses: its own column's (receiver rule) or the mean of both. */
typedef struct {
    double k_a, alpha_a, k_b, alpha_b;
} SpringEnds;

static SpringEnds spring_ends(int diagonal_rule, double k_a, double alpha_a, double k_b, double alpha_b) {
    SpringEnds ends;
    if (diagonal_rule == DIAGONAL_MEAN) {
        ends.k_a = ends.k_b = 0.5 * (k_a + k_b);
        ends.alpha_a = ends.alpha_b = 0.5 * (alpha_a + alpha_b);
    } else {
        ends.k_a = k_a;
        ends.alpha_a = alpha_a;
        ends.k_b = k_b;
        ends.alpha_b = alpha_b;
    }
    return ends;
}

/* Weight of row i (0-based) in the load: 1/2 for the first and last rows, 1 for the others, normalised. */
static double row_load_fraction(int rows, int i) {
    if (rows == 1) return 1.0;
    return ((i == 0 || i == rows - 1) ? 0.5 : 1.0) / (double)(rows - 1); /* the weights sum to rows - 1 */
}

/* One spring between masses a and b (r = u_b - u_a), written for speed: this is the hot loop of every
 * simulation. a is pushed by force_per_length_a * r, b by -force_per_length_b * r; the two differ only
 * for a non-reciprocal pair. Returns that pair's power g.(v_a + v_b), g = (f_a - f_b)/2 (0 otherwise). */
static inline double add_spring(const double *ux, const double *uy, const double *vx, const double *vy,
                                double *fx, double *fy, int a, int b, int linear, SpringEnds ends) {
    const double rx = ux[b] - ux[a], ry = uy[b] - uy[a];
    const double distance_squared = rx * rx + ry * ry;
    double distance, stretch_a, stretch_b, per_length_a, per_length_b;
    if (distance_squared < SPRING_MIN_DISTANCE * SPRING_MIN_DISTANCE) return 0.0;
    distance = sqrt(distance_squared);
    stretch_a = spring_stretch(linear, ends.alpha_a, distance);
    stretch_b = ends.alpha_b == ends.alpha_a ? stretch_a : spring_stretch(linear, ends.alpha_b, distance);
    {
        const double inverse_distance = 1.0 / distance;
        per_length_a = ends.k_a * stretch_a * inverse_distance;
        per_length_b = ends.k_b * stretch_b * inverse_distance;
    }
    fx[a] += per_length_a * rx;
    fy[a] += per_length_a * ry;
    fx[b] -= per_length_b * rx;
    fy[b] -= per_length_b * ry;
    if (per_length_a == per_length_b) return 0.0;
    return 0.5 * (per_length_a - per_length_b) * (rx * (vx[a] + vx[b]) + ry * (vy[a] + vy[b]));
}

/* Adds the dashpot F_a = -c (v_a - v_b) between a and b; returns the dissipated power c |v_a - v_b|^2. */
static inline double add_damper(const double *vx, const double *vy, double *fx, double *fy, int a, int b,
                                double c) {
    const double dvx = vx[b] - vx[a], dvy = vy[b] - vy[a];
    fx[a] += c * dvx;
    fy[a] += c * dvy;
    fx[b] -= c * dvx;
    fy[b] -= c * dvy;
    return c * (dvx * dvx + dvy * dvy);
}

/* The two diagonals between columns j and j+1 use these ends: the one in column j, the one in j+1. */
static SpringEnds diagonal_ends(const LatticeParams *p, int j) {
    const ColumnConstants *left = &p->column[j], *right = &p->column[j + 1];
    return spring_ends(p->diagonal_rule, left->k_diagonal, left->alpha_diagonal, right->k_diagonal,
                       right->alpha_diagonal);
}

static SpringEnds reversed(SpringEnds ends) {
    const SpringEnds swapped = {ends.k_b, ends.alpha_b, ends.k_a, ends.alpha_a};
    return swapped;
}

int lattice_wall_mode(const LatticeParams *p, double ux, double vx) {
    if (!p->has_backplate || ux - p->backplate_gap <= 0.0) return WALL_FREE;
    return vx > 0.0 ? WALL_APPROACHING : WALL_RECEDING;
}

void lattice_rhs(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y,
                 double *dydt) {
    const int rows = p->rows, cols = p->cols, n = rows * cols, linear = p->spring_law == SPRING_LINEAR;
    const double *ux = y, *uy = y + n, *vx = y + 2 * n, *vy = y + 3 * n;
    double *fx = dydt + 2 * n, *fy = dydt + 3 * n;
    double power_external = 0.0, power_dissipated = 0.0, power_nonreciprocal = 0.0;
    const SpringEnds horizontal = {p->k_horizontal, p->alpha_horizontal, p->k_horizontal, p->alpha_horizontal};
    int i, j;

    memcpy(dydt, vx, (size_t)n * sizeof(double));
    memcpy(dydt + n, vy, (size_t)n * sizeof(double));
    memset(fx, 0, 2 * (size_t)n * sizeof(double));

    /* left/right neighbours: k0, alpha0, c0 at both ends */
    for (i = 0; i < rows; i++) {
        for (j = 0; j + 1 < cols; j++) {
            const int a = i * cols + j;
            add_spring(ux, uy, vx, vy, fx, fy, a, a + 1, linear, horizontal);
            power_dissipated += add_damper(vx, vy, fx, fy, a, a + 1, p->c_horizontal);
        }
    }
    /* up/down neighbours: both ends in column j, so its material's constants at both ends */
    for (j = 0; j < cols; j++) {
        const ColumnConstants *column = &p->column[j];
        const SpringEnds vertical = {column->k_vertical, column->alpha_vertical, column->k_vertical,
                                     column->alpha_vertical};
        for (i = 0; i + 1 < rows; i++) {
            const int a = i * cols + j;
            add_spring(ux, uy, vx, vy, fx, fy, a, a + cols, linear, vertical);
            power_dissipated += add_damper(vx, vy, fx, fy, a, a + cols, column->c_vertical);
        }
    }
    /* diagonals between columns j and j+1: each end with its own column's constants (receiver rule) */
    for (j = 0; j + 1 < cols; j++) {
        const SpringEnds rising = diagonal_ends(p, j), falling = reversed(rising);
        for (i = 0; i + 1 < rows; i++) {
            const int a = i * cols + j;
            power_nonreciprocal += add_spring(ux, uy, vx, vy, fx, fy, a, a + cols + 1, linear, rising);
            power_nonreciprocal += add_spring(ux, uy, vx, vy, fx, fy, a + 1, a + cols, linear, falling);
        }
    }

    if (load_on) {
        const double angle = p->load_angle_deg * (M_PI / 180.0);
        const double cos_angle = cos(angle), sin_angle = sin(angle);
        for (i = 0; i < rows; i++) {
            const int a = i * cols;
            const double share = p->load_total * row_load_fraction(rows, i);
            fx[a] += share * cos_angle;
            fy[a] += share * sin_angle;
            power_external += share * (cos_angle * vx[a] + sin_angle * vy[a]);
        }
    }

    if (p->has_backplate) {
        for (i = 0; i < rows; i++) {
            const int a = i * cols + cols - 1;
            const double penetration = ux[a] - p->backplate_gap;
            const int mode = wall_mode ? wall_mode[i] : lattice_wall_mode(p, ux[a], vx[a]);
            if (mode != WALL_FREE) {
                const double damped_velocity = mode == WALL_APPROACHING ? vx[a] : 0.0;
                fx[a] -= p->k_wall * penetration + p->c_wall * damped_velocity;
                power_dissipated += p->c_wall * damped_velocity * vx[a];
            }
        }
    }

    {
        const double inverse_mass = 1.0 / p->mass;
        for (i = 0; i < 2 * n; i++) fx[i] *= inverse_mass; /* fx and fy are contiguous */
    }
    dydt[4 * n] = power_external;
    dydt[4 * n + 1] = power_dissipated;
    dydt[4 * n + 2] = power_nonreciprocal;
}

double lattice_backplate_force_from_column(const LatticeParams *p, const double *ux_last_column,
                                           const double *vx_last_column, int stride) {
    double force = 0.0;
    int i;
    if (!p->has_backplate) return 0.0;
    for (i = 0; i < p->rows; i++) {
        const double penetration = ux_last_column[i * stride] - p->backplate_gap;
        if (penetration > 0.0) {
            const double vx = vx_last_column[i * stride];
            force += p->k_wall * penetration + p->c_wall * (vx > 0.0 ? vx : 0.0);
        }
    }
    return force;
}

double lattice_backplate_force(const LatticeParams *p, const double *y) {
    const int n = p->rows * p->cols;
    return lattice_backplate_force_from_column(p, y + p->cols - 1, y + 2 * n + p->cols - 1, p->cols);
}

/* Potential of one spring: for a non-reciprocal pair, the mean of its two ends' potentials. */
static double spring_energy(const double *ux, const double *uy, int a, int b, int spring_law, SpringEnds ends) {
    const double rx = ux[b] - ux[a], ry = uy[b] - uy[a];
    const double distance = sqrt(rx * rx + ry * ry);
    return 0.5 * (lattice_spring_potential(spring_law, ends.k_a, ends.alpha_a, distance) +
                  lattice_spring_potential(spring_law, ends.k_b, ends.alpha_b, distance));
}

void lattice_energies(const LatticeParams *p, const double *y, double *kinetic, double *potential) {
    const int rows = p->rows, cols = p->cols, n = rows * cols, law = p->spring_law;
    const double *ux = y, *uy = y + n, *vx = y + 2 * n, *vy = y + 3 * n;
    const SpringEnds horizontal = {p->k_horizontal, p->alpha_horizontal, p->k_horizontal, p->alpha_horizontal};
    double speed_squared = 0.0, energy = 0.0;
    int i, j;
    for (i = 0; i < n; i++) speed_squared += vx[i] * vx[i] + vy[i] * vy[i];
    for (i = 0; i < rows; i++) {
        for (j = 0; j + 1 < cols; j++) energy += spring_energy(ux, uy, i * cols + j, i * cols + j + 1, law, horizontal);
    }
    for (j = 0; j < cols; j++) {
        const ColumnConstants *column = &p->column[j];
        const SpringEnds vertical = {column->k_vertical, column->alpha_vertical, column->k_vertical,
                                     column->alpha_vertical};
        for (i = 0; i + 1 < rows; i++) energy += spring_energy(ux, uy, i * cols + j, (i + 1) * cols + j, law, vertical);
    }
    for (j = 0; j + 1 < cols; j++) {
        const SpringEnds rising = diagonal_ends(p, j), falling = reversed(rising);
        for (i = 0; i + 1 < rows; i++) {
            const int a = i * cols + j;
            energy += spring_energy(ux, uy, a, a + cols + 1, law, rising);
            energy += spring_energy(ux, uy, a + 1, a + cols, law, falling);
        }
    }
    if (p->has_backplate) {
        for (i = 0; i < rows; i++) {
            const double penetration = ux[i * cols + cols - 1] - p->backplate_gap;
            if (penetration > 0.0) energy += 0.5 * p->k_wall * penetration * penetration;
        }
    }
    *kinetic = 0.5 * p->mass * speed_squared;
    *potential = energy;
}
