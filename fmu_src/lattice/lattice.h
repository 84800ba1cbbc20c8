/* The physics of the mass-spring lattice (docs/model.md): the one place where the force law lives.
 *
 * Knows nothing of FMI and nothing of solvers: a parameter struct, a right-hand side over the augmented
 * state, the backplate force and the energies. General in rows x columns x depth at run time (up to
 * LATTICE_MAX_COLS columns), so the same file serves the FMU (size fixed at build time) and the test
 * library that checks it against the numpy oracle.
 *
 * The plate of docs/model.md section 10 is this lattice with a depth, not a second model: every spring of
 * it, in the plane or between slices, goes through the one force law (spring_stretch in lattice.c) and the
 * same ends rule, so a change to the physics is made once and depth 1 is the two-dimensional lattice of
 * sections 1 to 7 with the same numbers, bit for bit (the slices' extra springs and components are simply
 * absent there, not added as zeros).
 *
 * State layout (reference/lattice.py shares it at depth 1): R rows i (y), C columns j (x), D slices k along z (depth), all
 * 0-based here; N = R*C*D masses, mass n = (k*R + i)*C + j, so a slice is the two-dimensional lattice's
 * R*C block and depth 1 is its layout unchanged. The components of the state (LATTICE_COMPONENTS):
 *   depth 1:  y[0..N) ux  y[N..2N) uy  y[2N..3N) vx  y[3N..4N) vy                           (2 components)
 *   depth > 1: y[0..N) ux  y[N..2N) uy  y[2N..3N) uz  y[3N..4N) vx  y[4N..5N) vy  y[5N..6N) vz  (3 components)
 * then y[2cN] W_ext (external work), y[2cN+1] D (dissipated energy), y[2cN+2] W_nr (non-reciprocal work),
 * c the components: quadratures, integrating them with the state is what closes the energy balance.
 * The face masses (column 1's for the load, column C's for the backplate) are numbered f = k*R + i.
 * Words (docs/model.md's glossary): a slice is the R x C masses at one depth k; a layer is one material's column
 * j, its R x D masses.
 */
#ifndef LATTICE_H
#define LATTICE_H

#include "model_table.h" /* enum DiagonalRule, ColumnConstants ...: generated from the variable and material tables */

#define LATTICE_MAX_COLS 64
#define LATTICE_N_QUADRATURES 3
/* Components of a displacement (and of a velocity): x and y in one slice, x, y and z in more. */
#define LATTICE_COMPONENTS(depth) ((depth) > 1 ? 3 : 2)
#define LATTICE_STATE_SIZE_OF_PLATE(rows, cols, depth) \
    (2 * LATTICE_COMPONENTS(depth) * (rows) * (cols) * (depth) + LATTICE_N_QUADRATURES)
#define LATTICE_STATE_SIZE(rows, cols) LATTICE_STATE_SIZE_OF_PLATE(rows, cols, 1)
/* Masses of a face (column 1's, column C's): what a wall_mode array holds, f = k*R + i. */
#define LATTICE_FACE_MASSES(rows, depth) ((rows) * (depth))
/* load_patch of a load spread over the whole face (docs/model.md sections 4 and 10). */
#define LATTICE_WHOLE_FACE 0

typedef enum { SPRING_EXPONENTIAL = 0, SPRING_LINEAR = 1 } SpringLaw;

/* Flat (no pointers), so a model holding it can be copied with memcpy for FMU states. */
typedef struct {
    int rows, cols;
    double k_horizontal, alpha_horizontal, c_horizontal; /* left/right neighbours: k0, alpha0, c0 */
    ColumnConstants column[LATTICE_MAX_COLS]; /* its material's row: springs, dampers, mass (section 12) */
    int diagonal_rule; /* enum DiagonalRule */
    int spring_law;    /* SpringLaw */
    double load_total, load_angle_deg, load_duration; /* F_total, theta, t_active */
    int has_backplate;
    double k_wall, c_wall, backplate_gap;
    int depth;      /* slices D >= 1 (docs/model.md section 10); 1 is the two-dimensional lattice */
    int load_patch; /* LATTICE_WHOLE_FACE, or the odd side P of the centred P x P patch column 1 is pushed on */
    /* the ports (docs/model.md section 11): what pushes column 1 (enum LoadMode: the pulse above, or
     * front_force spread with the pulse's weights), and the backplate's displacement and velocity along +x, as
     * they are at the time the right-hand side is asked for (0, 0: the rigid wall of section 5) */
    int load_mode;
    double front_force, back_position, back_velocity;
} LatticeParams;

/* NULL when the core computes the lattice p describes, else message (of size bytes) filled with one line
 * naming the parameter and its allowed values. */
const char *lattice_params_error(const LatticeParams *p, char *message, int size);

/* How a column-C mass meets the backplate: docs/model.md section 5 switches the wall force on with penetration
 * p = ux - gap - x_back > 0 and its damping with vx - v_back > 0 (section 11: a moving backplate). */
typedef enum { WALL_FREE = 0, WALL_RECEDING = 1, WALL_APPROACHING = 2 } WallMode;

/* The mode docs/model.md gives a column-C mass with displacement ux and velocity vx. */
int lattice_wall_mode(const LatticeParams *p, double ux, double vx);

/* dydt = f(y) over the augmented state. load_on says whether the column-1 load acts (decided by the
 * caller's phase, not by t, so a step that ends exactly on t_active integrates the right side).
 * wall_mode (one per column-C mass, LATTICE_FACE_MASSES of them, f = k*R + i) freezes the backplate's
 * switches for a solver step, so the right-hand side is smooth inside the step and the switches are located
 * as events; NULL takes them from the state. */
void lattice_rhs(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y,
                 double *dydt);

/* A lattice loaded along x (load_angle 0, or no load) by a load centred on its face (the whole face, or a
 * centred patch) is mirror-symmetric about its middle row when it has an odd number of rows R >= 3, and
 * about its middle slice when it has an odd depth D >= 3, for all time (the materials vary by column only,
 * the start state is zero): row R-1-i moves as row i, slice D-1-k as slice k, and the middle row and slice
 * stay on their planes. The part of rows 0 .. (R-1)/2 and slices 0 .. (D-1)/2 (the middle ones last), a
 * half or a quarter, carries the whole solution (lattice_rhs_along_x with mirrored 1).
 * lattice_mirror_rows returns the rows of that part, or 0 when the lattice is not symmetric about a row;
 * lattice_mirror_slices its slices, or 0 when it is not symmetric about a slice. */
int lattice_mirror_rows(const LatticeParams *p);
int lattice_mirror_slices(const LatticeParams *p);

/* A lattice loaded along x (load_angle 0, no load, or the ports' load, which is along +x) moves along x alone for all time: r = u_b - u_a
 * (docs/model.md section 2) of two masses that have not moved in y or z has no y or z part, so no spring,
 * damper or load pushes in y or z. Its state without the y and z components, [ux (N), vx (N), W_ext, D,
 * W_nr], carries the whole solution. 1 if so. */
int lattice_along_x(const LatticeParams *p);

/* The right-hand side over that layout, of all masses (mirrored 0) or of the part of a mirror-symmetric
 * lattice that carries its solution (mirrored 1: the lattice_mirror_rows rows if that is not 0, else all R,
 * times the lattice_mirror_slices slices if that is not 0, else all D; at least one must not be 0), its
 * masses numbered as the whole lattice's with those rows and slices. wall_mode, when not NULL, holds one
 * mode per column-C mass of the whole lattice (f = k*R + i); the part reads its own. Equal, to rounding, to
 * the x components of lattice_rhs on the same state (the whole one, mirrored) with the y and z parts 0. */
void lattice_rhs_along_x(const LatticeParams *p, int mirrored, int load_on, const signed char *wall_mode,
                         const double *y, double *dydt);

/* The front port (docs/model.md section 11): x_front = sum of w_a ux_a and v_front = sum of w_a vx_a over the
 * loaded face masses with the load's weights w_a (summing to 1), of whole state y. */
void lattice_front_port(const LatticeParams *p, const double *y, double *x_front, double *v_front);
/* The same of a state in lattice_rhs_along_x's layout (mirrored: of the part it integrates, each face mass
 * counted as often as it stands in the whole). */
void lattice_front_port_along_x(const LatticeParams *p, int mirrored, const double *y, double *x_front,
                                double *v_front);
/* The load's weight w_a of face mass (i, k) of the whole lattice (0-based; the weights sum to 1). */
double lattice_load_weight(const LatticeParams *p, int i, int k);

/* Sum over column-C masses in contact of k_w p + c_w max(vx - v_back, 0), p = ux - gap - x_back (docs/model.md
 * sections 5 and 11). */
double lattice_backplate_force(const LatticeParams *p, const double *y);

/* Backplate force from column C's ux and vx alone, face mass f = k*R + i at [f * stride] (the interpolated
 * peak search evaluates it on those 2 * R * D components only). */
double lattice_backplate_force_from_column(const LatticeParams *p, const double *ux_last_column,
                                           const double *vx_last_column, int stride);

/* The same over the column-C masses of the part of a mirror-symmetric lattice that lattice_rhs_along_x
 * computes with mirrored 1 (f = k*rows + i over its rows and slices), each counted as often as it stands
 * in the whole: 4 times off both middle planes, twice on one, once on both. */
double lattice_backplate_force_mirrored(const LatticeParams *p, const double *ux_last_column,
                                        const double *vx_last_column, int stride);

/* The backplate's part of the potential energy, sum of k_w p^2 / 2 over the column-C masses in contact, of whole
 * state y. */
double lattice_backplate_potential(const LatticeParams *p, const double *y);

/* Kinetic and potential energy (docs/model.md section 7; a non-reciprocal pair counts the mean of its ends). */
void lattice_energies(const LatticeParams *p, const double *y, double *kinetic, double *potential);

/* The potential of the force law for one end with constants (k, alpha). */
double lattice_spring_potential(int spring_law, double k, double alpha, double distance);

/* The lattice's total mass, rows x depth x the sum of its columns' masses (docs/model.md section 12). */
double lattice_stack_mass(const LatticeParams *p);

/* The smallest mass of any column: a lower bound of the kinetic energy is half of it times sum |v|^2. */
double lattice_lightest_mass(const LatticeParams *p);

#endif
