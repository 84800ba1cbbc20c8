/* The physics of the mass-spring lattice (docs/model.md): the one place where the force law lives.
 *
 * Knows nothing of FMI and nothing of solvers: a parameter struct, a right-hand side over the augmented
 * state, the backplate force and the energies. General in rows x columns at run time (up to
 * LATTICE_MAX_COLS columns), so the same file serves the FMU (size fixed at build time) and the test
 * library that checks it against the numpy oracle.
 *
 * State layout (shared with reference/lattice.py): N = rows*cols, mass n = (i-1)*cols + (j-1) for row i,
 * column j (1-based);
 *   y[0..N)   ux      y[N..2N)  uy      y[2N..3N) vx      y[3N..4N) vy
 *   y[4N]     W_ext (external work)    y[4N+1] D (dissipated energy)    y[4N+2] W_nr (non-reciprocal work)
 * The last three are quadratures: integrating them with the state is what closes the energy balance.
 */
#ifndef LATTICE_H
#define LATTICE_H

#include "model_table.h" /* enum DiagonalRule, ColumnConstants ...: generated from the variable and material tables */

#define LATTICE_MAX_COLS 64
#define LATTICE_N_QUADRATURES 3
#define LATTICE_STATE_SIZE(rows, cols) (4 * (rows) * (cols) + LATTICE_N_QUADRATURES)

typedef enum { SPRING_EXPONENTIAL = 0, SPRING_LINEAR = 1 } SpringLaw;

/* Flat (no pointers), so a model holding it can be copied with memcpy for FMU states. */
typedef struct {
    int rows, cols;
    double mass;
    double k_horizontal, alpha_horizontal, c_horizontal; /* left/right neighbours: k0, alpha0, c0 */
    ColumnConstants column[LATTICE_MAX_COLS];
    int diagonal_rule; /* enum DiagonalRule */
    int spring_law;    /* SpringLaw */
    double load_total, load_angle_deg, load_duration; /* F_total, theta, t_active */
    int has_backplate;
    double k_wall, c_wall, backplate_gap;
} LatticeParams;

/* How a column-C mass meets the backplate: docs/model.md section 5 switches the wall force on with penetration
 * p > 0 and its damping with vx > 0. */
typedef enum { WALL_FREE = 0, WALL_RECEDING = 1, WALL_APPROACHING = 2 } WallMode;

/* The mode docs/model.md gives a column-C mass with displacement ux and velocity vx. */
int lattice_wall_mode(const LatticeParams *p, double ux, double vx);

/* dydt = f(y) over the augmented state. load_on says whether the column-1 load acts (decided by the
 * caller's phase, not by t, so a step that ends exactly on t_active integrates the right side).
 * wall_mode (one per row) freezes the backplate's switches for a solver step, so the right-hand side is
 * smooth inside the step and the switches are located as events; NULL takes them from the state. */
void lattice_rhs(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y,
                 double *dydt);

/* A lattice with an odd number of rows R >= 3, loaded along its rows (load_angle 0, or no load), is
 * mirror-symmetric about its middle row for all time (the materials vary by column only, the start state is
 * zero): row R-1-i moves as row i, and the middle row stays on the line. Its upper half, rows 0 .. (R-1)/2
 * (the middle row last), carries the whole solution at about half the cost (lattice_rhs_along_x with
 * mirrored 1). Returns the rows of that half, or 0 when the lattice is not symmetric. */
int lattice_mirror_rows(const LatticeParams *p);

/* A lattice loaded along x (load_angle 0, or no load) moves along x alone for all time: r = u_b - u_a
 * (docs/model.md section 2) of two masses that have not moved in y has no y part, so no spring, damper or load pushes
 * in y. Its state without uy and vy, [ux (N), vx (N), W_ext, D, W_nr], carries the whole solution. 1 if so. */
int lattice_along_x(const LatticeParams *p);

/* The right-hand side over that layout (wall_mode one per row it holds), of all rows (mirrored 0) or of the
 * upper half of a mirror-symmetric lattice (mirrored 1, lattice_mirror_rows rows). Equal, to rounding, to the
 * x components of lattice_rhs on the same state (the whole one, mirrored) with uy = vy = 0. */
void lattice_rhs_along_x(const LatticeParams *p, int mirrored, int load_on, const signed char *wall_mode,
                         const double *y, double *dydt);

/* Sum over column-C masses in contact of k_w p + c_w max(vx, 0) (docs/model.md section 5). */
double lattice_backplate_force(const LatticeParams *p, const double *y);

/* Backplate force from column C's ux and vx alone, element i at [i * stride] (the interpolated peak
 * search evaluates it on those 2 * rows components only). */
double lattice_backplate_force_from_column(const LatticeParams *p, const double *ux_last_column,
                                           const double *vx_last_column, int stride);

/* The same over the rows of the upper half of a mirror-symmetric lattice (each but the middle row twice). */
double lattice_backplate_force_mirrored(const LatticeParams *p, const double *ux_last_column,
                                        const double *vx_last_column, int stride);

/* Kinetic and potential energy (docs/model.md section 7; a non-reciprocal pair counts the mean of its ends). */
void lattice_energies(const LatticeParams *p, const double *y, double *kinetic, double *potential);

/* The potential of the force law for one end with constants (k, alpha). */
double lattice_spring_potential(int spring_law, double k, double alpha, double distance);

#endif
