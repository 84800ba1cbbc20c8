/* The physics of docs/model.md: springs, damping, load, backplate. See lattice.h for the state layout. */
#include "lattice.h"

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>

#include "compiler.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Below this separation a spring exerts no force (docs/model.md section 2: the direction is undefined). */
#define SPRING_MIN_DISTANCE 1e-12

/* exp(x) to about 2 ulp, written out so that a loop of them vectorises: libm's exp is a call per spring, and
 * it was 40% of a simulation. x = k ln2 + r with |r| <= ln2/2, exp(r) by its Taylor polynomial of degree 13
 * (truncation below 1e-17) in Estrin's scheme (short dependency chains), times 2^k built in the exponent
 * bits. Nothing but IEEE adds, multiplies and selects, so the same bits scalar or vectorised as long as no
 * multiply and add are contracted into an FMA (GCC does not in ISO C mode, nor in VECTOR_CLONES, whatever
 * the mode: see compiler.h). Overflows to inf above 709 (exp(709) is 8e307: any spring stretched that far
 * has diverged long before), 0 below -708 (subnormal), NaN stays NaN. */
static inline double lattice_exp(double x) {
    const double shift = 0x1.8p52; /* t = x/ln2 + shift rounds x/ln2 to the integer k in t's low bits */
    const double clamped = x < -708.0 ? -708.0 : (x > 709.0 ? 709.0 : x);
    const double t = clamped * 1.4426950408889634 + shift, k = t - shift;
    const double r = (clamped - k * 0x1.62e42fefa3800p-1) - k * 0x1.ef35793c76730p-45; /* ln2 in two parts */
    const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
    const double p01 = 1.0 + r, p23 = 1.0 / 2.0 + r * (1.0 / 6.0), p45 = 1.0 / 24.0 + r * (1.0 / 120.0),
                 p67 = 1.0 / 720.0 + r * (1.0 / 5040.0), p89 = 1.0 / 40320.0 + r * (1.0 / 362880.0),
                 p1011 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0),
                 p1213 = 1.0 / 479001600.0 + r * (1.0 / 6227020800.0);
    const double polynomial = (p01 + r2 * p23 + r4 * (p45 + r2 * p67)) + r8 * (p89 + r2 * p1011 + r4 * p1213);
    uint64_t bits, shift_bits;
    double scale, result;
    memcpy(&bits, &t, sizeof bits);
    memcpy(&shift_bits, &shift, sizeof shift_bits);
    bits = (bits - shift_bits + 1023u) << 52; /* 2^k: k + 1023 in the exponent field */
    memcpy(&scale, &bits, sizeof scale);
    result = polynomial * scale;
    result = x > 709.0 ? HUGE_VAL : result;
    return x < -708.0 ? 0.0 : result;
}

/* The force law, f(r; k, alpha) = k * stretch * r/|r| (docs/model.md section 2): exponential
 * k (exp(alpha |r|) - 1) as that section writes it (exp rather than expm1: the one the study's numbers came from),
 * or linear k |r| for the two-mass scene. Branch-free, so that the loop over a row's springs vectorises. */
static inline double spring_stretch(int linear, double alpha, double distance) {
    const double exponential = lattice_exp(alpha * distance) - 1.0;
    return linear ? distance : exponential;
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
    if (diagonal_rule == DIAGONAL_RULE_MEAN) {
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

/* Weight of row i (0-based) in the load over the whole face: 1/2 for the first and last rows, 1 for the others,
 * normalised (docs/model.md section 4); a slice k of D has the same weight in z (section 10). */
static double row_load_fraction(int rows, int i) {
    if (rows == 1) return 1.0;
    return ((i == 0 || i == rows - 1) ? 0.5 : 1.0) / (double)(rows - 1); /* the weights sum to rows - 1 */
}

/* The two diagonals between columns j and j+1 use these ends: the one in column j, the one in j+1. */
static SpringEnds diagonal_ends(const LatticeParams *p, int j) {
    const ColumnConstants *left = &p->column[j], *right = &p->column[j + 1];
    return spring_ends(p->diagonal_rule, left->k_diag, left->alpha_diag, right->k_diag,
                       right->alpha_diag);
}

static SpringEnds reversed(SpringEnds ends) {
    const SpringEnds swapped = {ends.k_b, ends.alpha_b, ends.k_a, ends.alpha_a};
    return swapped;
}

/* docs/model.md section 12: a damper of constant c and exponent n pushes with c |dv|^(n-1) dv, a linear damper
 * of constant c |dv|^(n-1) at that relative speed; at dv = 0 its force is 0 for every n > 0 (and pow would
 * give an infinite constant for n < 1). */
static double nonlinear_damping(double c, double exponent, double speed) {
    return speed > 0.0 ? c * pow(speed, exponent - 1.0) : 0.0;
}

/* The columns whose dampers are not linear (exponent != 1), count returned: only they pay for pow, and a
 * lattice without any takes the linear dampers' code unchanged. */
static int nonlinear_columns(const LatticeParams *p, int *columns) {
    int count = 0, j;
    for (j = 0; j < p->cols; j++) {
        if (p->column[j].damping_exponent != 1.0) columns[count++] = j;
    }
    return count;
}

/* The constants c_effective[j] of the count non-linear dampers inside columns[] whose ends a and b have the
 * velocities given (vy and vz NULL along x: there |dv| is |dvx|, what sqrt(dvx^2) gives; vz NULL in a
 * lattice of one slice). The linear columns' entries are left as they are. */
static void nonlinear_dampers(const LatticeParams *p, int count, const int *columns, const double *vx_a,
                              const double *vy_a, const double *vz_a, const double *vx_b, const double *vy_b,
                              const double *vz_b, double *c_effective) {
    int q;
    for (q = 0; q < count; q++) {
        const int j = columns[q];
        const double dvx = vx_b[j] - vx_a[j];
        double speed = fabs(dvx);
        if (vy_a) {
            const double dvy = vy_b[j] - vy_a[j], dvz = vz_a ? vz_b[j] - vz_a[j] : 0.0;
            speed = sqrt(vz_a ? dvx * dvx + dvy * dvy + dvz * dvz : dvx * dvx + dvy * dvy);
        }
        c_effective[j] = nonlinear_damping(p->column[j].c, p->column[j].damping_exponent, speed);
    }
}

/* Whether every column's mass is 1 kg: then nothing is divided by a mass (multiplying by 1 changes nothing). */
static int unit_masses(const LatticeParams *p) {
    int j;
    for (j = 0; j < p->cols; j++) {
        if (p->column[j].mass != 1.0) return 0;
    }
    return 1;
}

double lattice_stack_mass(const LatticeParams *p) {
    double sum = 0.0;
    int j;
    for (j = 0; j < p->cols; j++) sum += p->column[j].mass;
    return (double)p->rows * (double)p->depth * sum;
}

double lattice_lightest_mass(const LatticeParams *p) {
    double lightest = p->column[0].mass;
    int j;
    for (j = 1; j < p->cols; j++) lightest = p->column[j].mass < lightest ? p->column[j].mass : lightest;
    return lightest;
}


/* always_inline where the compiler has it: rhs_of_slices is written once and compiled for the lattice and
 * for the plate, with_z folded in each (the plate's z parts cost the lattice nothing). */
#if defined(__GNUC__)
#define ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define ALWAYS_INLINE inline
#endif

/* The right-hand side is written for speed: it is most of the cost of a simulation (about 420 springs,
 * 6000 evaluations per 8 s run). It works one row of masses at a time, on the springs that start in that
 * row: horizontal (i, j) -> (i, j+1), and down to the next row rising (i, j) -> (i+1, j+1), falling
 * (i, j+1) -> (i+1, j) and vertical (i, j) -> (i+1, j). Each family's springs sit in local arrays indexed
 * by j (RowBuffers), and every stage is a plain loop over them:
 *   1. geometry: r = u_b - u_a and |r|^2;
 *   2. |r|, 1/|r| and the stretch (the exponential) of all the row's springs in one loop (row_stretches):
 *      their |r|^2 are packed one family after another (SLOT), so the loop is long enough to vectorise;
 *   3. the forces of the springs;
 *   4. each mass of the row gathers the forces of the springs at it (no scatter, so no conflicts); what
 *      the springs down to the next row do to it is carried over to that row.
 * No per-spring branches. The loops of stages 1, 3 and 4 run over an even count and then at most one
 * element more: at -O2 GCC vectorises a loop only when its trip count is known to be a multiple of the
 * vector length. They read the state and local arrays and write local arrays (or read local arrays and
 * write the derivative), so the compiler knows nothing overlaps. Vectorised or not, the results are the
 * same: nothing is reassociated (the powers are summed by column over the rows, then over the columns),
 * so a build at -O3 gives the same numbers as one at -O2.
 *
 * A plate (depth > 1) is swept slice by slice, each slice's springs in its plane as above (with their z
 * parts), and then slice to slice (between_slices): the springs from slice k to k+1 in the same four stages,
 * row by row, which add what they do to both slices' forces. */

/* j over [0, count): BODY(j) in a loop the compiler can vectorise, then the odd one out. even = EVEN(count)
 * is computed once, outside the loop over rows, and the loop ends on j != even: either way GCC (-O2) can
 * lose what it knows of the trip count once loops follow one another (it then wants to peel). */
#define OVER(count, even, BODY)         \
    {                                   \
        for (j = 0; j != (even); j++) { \
            BODY(j)                     \
        }                               \
        if (j < (count)) {              \
            BODY(j)                     \
        }                               \
    }

enum { HORIZONTAL = 0, RISING = 1, FALLING = 2, VERTICAL = 3, FAMILIES = 4 };

/* Where spring j of a family sits in the packed arrays of a row: horizontal, rising, falling (links each),
 * vertical (cols), then the right ends of the rising and falling diagonals (links each; used only when their
 * alphas differ from the left ends'). Needs links and cols in scope; family is a constant, so this folds. */
#define SLOT(family, j)                                                                                        \
    (((family) == HORIZONTAL ? 0 : (family) == RISING ? links : (family) == FALLING ? 2 * links : 3 * links) + \
     (j))
#define RIGHT_END_SLOT(diagonal, j) (3 * links + cols + (diagonal) * links + (j)) /* diagonal 0 rising, 1 falling */
#define PACKED_SPRINGS (6 * LATTICE_MAX_COLS)

/* A row's springs by family and column, the constants by column, and the forces by the springs of a row
 * (x, y, and z in a plate): one object, so the compiler addresses them all from one register. The forces are
 * all stored at [j] (stores at [j + 1] would keep GCC from vectorising); the gather reads some at [j - 1],
 * where a zero guard stands for the spring that does not exist left of column 0 (those arrays start two
 * elements into their storage, keeping the alignment), and others at [cols - 1], where a zero guard stands
 * for the one right of the last column. */
typedef struct {
    double rx[FAMILIES][LATTICE_MAX_COLS], ry[FAMILIES][LATTICE_MAX_COLS], rz[FAMILIES][LATTICE_MAX_COLS];
    /* packed by SLOT; a diagonal's left end is the one in column j, its right end the one in j+1 */
    double squared[PACKED_SPRINGS], alpha[PACKED_SPRINGS], stretch[PACKED_SPRINGS], inverse[PACKED_SPRINGS];
    double k_vertical[LATTICE_MAX_COLS], c_vertical[LATTICE_MAX_COLS], k_left[LATTICE_MAX_COLS],
        k_right[LATTICE_MAX_COLS];
    /* the vertical dampers' constants at this row's relative speeds (nonlinear_dampers; c_vertical in the
     * linear columns) and the columns that are not linear */
    double c_effective[LATTICE_MAX_COLS];
    int nonlinear[LATTICE_MAX_COLS], nonlinear_count;
    double dissipated[LATTICE_MAX_COLS], nonreciprocal[LATTICE_MAX_COLS]; /* powers, summed by column */
    double horizontal[3][LATTICE_MAX_COLS + 2], rising_bottom[3][LATTICE_MAX_COLS + 2],
        falling_top[3][LATTICE_MAX_COLS + 2];
    double vertical[3][LATTICE_MAX_COLS], rising_top[3][LATTICE_MAX_COLS], falling_bottom[3][LATTICE_MAX_COLS];
    /* what the springs from the row above do to a row, and what this row's do to the next */
    double carried[3][LATTICE_MAX_COLS], next[3][LATTICE_MAX_COLS];
} RowBuffers;

/* the force arrays by component c and spring j; those with a guard at [-1] start two elements in */
#define HORIZONTAL_FORCE(c, j) w.horizontal[c][(j) + 2]
#define RISING_BOTTOM_FORCE(c, j) w.rising_bottom[c][(j) + 2]
#define FALLING_TOP_FORCE(c, j) w.falling_top[c][(j) + 2]
#define VERTICAL_FORCE(c, j) w.vertical[c][j]
#define RISING_TOP_FORCE(c, j) w.rising_top[c][j]
#define FALLING_BOTTOM_FORCE(c, j) w.falling_bottom[c][j]

/* Stage 2 over count packed springs: the stretch (spring_stretch: the force law) and 1/|r|, which is 0 below
 * SPRING_MIN_DISTANCE: there a spring exerts no force (docs/model.md section 2). No branches (selects only), so GCC
 * vectorises it; it is most of the cost of the right-hand side. */
static NOINLINE VECTOR_CLONES void packed_stretches(int linear, const double *RESTRICT squared,
                                                   const double *RESTRICT alpha, int count,
                                                   double *RESTRICT stretch, double *RESTRICT inverse) {
    int k;
    for (k = 0; k < count; k++) {
        const double d = sqrt(squared[k]);
        const int too_close = squared[k] < SPRING_MIN_DISTANCE * SPRING_MIN_DISTANCE;
        const double inverse_distance = 1.0 / (too_close ? 1.0 : d);
        stretch[k] = spring_stretch(linear, alpha[k], d);
        inverse[k] = too_close ? 0.0 : inverse_distance;
    }
}

/* packed_stretches for springs along x (rhs_rows_along_x): given dx, |r| = |dx|, which is what sqrt(dx^2)
 * gives (exactly, wherever the spring exerts a force), without the square root. */
static NOINLINE VECTOR_CLONES void packed_stretches_x(int linear, const double *RESTRICT dx,
                                                     const double *RESTRICT alpha, int count,
                                                     double *RESTRICT stretch, double *RESTRICT inverse) {
    int k;
    for (k = 0; k < count; k++) {
        const double d = fabs(dx[k]);
        const int too_close = dx[k] * dx[k] < SPRING_MIN_DISTANCE * SPRING_MIN_DISTANCE;
        const double inverse_distance = 1.0 / (too_close ? 1.0 : d);
        stretch[k] = spring_stretch(linear, alpha[k], d);
        inverse[k] = too_close ? 0.0 : inverse_distance;
    }
}

/* Stage 2 over count packed springs from first on: |r|^2 in squared, or dx along x. */
static void stretches_of(int linear, int along_x, int count, const double *squared, const double *alpha,
                         double *stretch, double *inverse) {
    if (along_x) {
        packed_stretches_x(linear, squared, alpha, count, stretch, inverse);
    } else {
        packed_stretches(linear, squared, alpha, count, stretch, inverse);
    }
}

/* Stage 2 for the springs of a row: the horizontal ones, and with below the ones down to the next row (and
 * the diagonals' right ends when their alphas differ from the left ends': docs/model.md section 2, each end of a
 * diagonal uses its own alpha). w->squared holds |r|^2, or dx along x. */
static NOINLINE VECTOR_CLONES void row_stretches(int linear, int along_x, int below, int alphas_differ, int links,
                                                 int cols, RowBuffers *w) {
    int count = links, j;
    if (below) {
        count = 3 * links + cols;
        if (alphas_differ) {
            for (j = 0; j < links; j++) {
                w->squared[RIGHT_END_SLOT(0, j)] = w->squared[SLOT(RISING, j)];
                w->squared[RIGHT_END_SLOT(1, j)] = w->squared[SLOT(FALLING, j)];
            }
            count += 2 * links;
        }
    }
    stretches_of(linear, along_x, count, w->squared, w->alpha, w->stretch, w->inverse);
}

/* The buffers' per-lattice part (column constants, alphas and the zero guards) for rhs_of_slices and
 * rhs_rows_along_x; returns whether some diagonal's right end needs an exponential of its own. */
static int prepare_row_buffers(const LatticeParams *p, RowBuffers *w) {
    const int cols = p->cols, links = cols - 1;
    int alphas_differ = 0, j, c;
    for (j = 0; j < cols; j++) {
        const ColumnConstants *column = &p->column[j];
        w->k_vertical[j] = column->k;
        w->c_vertical[j] = w->c_effective[j] = column->c;
        w->alpha[SLOT(VERTICAL, j)] = column->alpha;
    }
    w->nonlinear_count = nonlinear_columns(p, w->nonlinear);
    for (j = 0; j < links; j++) {
        const SpringEnds ends = diagonal_ends(p, j);
        w->alpha[SLOT(HORIZONTAL, j)] = p->alpha_horizontal;
        w->alpha[SLOT(RISING, j)] = w->alpha[SLOT(FALLING, j)] = ends.alpha_a;
        w->alpha[RIGHT_END_SLOT(0, j)] = w->alpha[RIGHT_END_SLOT(1, j)] = ends.alpha_b;
        w->k_left[j] = ends.k_a;
        w->k_right[j] = ends.k_b;
        alphas_differ = alphas_differ || ends.alpha_a != ends.alpha_b;
    }
    for (c = 0; c < 3; c++) { /* the guards: the springs left of column 0 and right of the last */
        w->horizontal[c][1] = w->horizontal[c][links + 2] = 0.0;
        w->rising_top[c][links] = w->rising_bottom[c][1] = 0.0;
        w->falling_top[c][1] = w->falling_bottom[c][links] = 0.0;
    }
    return alphas_differ;
}

/* Before the first row of a slice: nothing carried from above, no power summed yet. */
static void start_slice(RowBuffers *w, int cols) {
    int j, c;
    for (j = 0; j < cols; j++) {
        for (c = 0; c < 3; c++) w->carried[c][j] = 0.0;
        w->dissipated[j] = w->nonreciprocal[j] = 0.0;
    }
}

/* Before the middle row of a mirrored half: every spring so far has a mirror image below the middle row, so
 * the powers summed so far count twice. */
static void count_mirror_images(double *dissipated, double *nonreciprocal, int cols) {
    int j;
    for (j = 0; j < cols; j++) {
        dissipated[j] *= 2.0;
        nonreciprocal[j] *= 2.0;
    }
}

/* The springs' powers: what every slice and every pair of slices dissipate and do by unequal forces. */
typedef struct {
    double dissipated, nonreciprocal;
} SpringPowers;

/* Adds the powers summed by column, counted times (2: they have a mirror image in z), to the total. */
static void add_spring_powers(const double *dissipated, const double *nonreciprocal, int cols, double counted,
                              SpringPowers *total) {
    double power_dissipated = 0.0, power_nonreciprocal = 0.0;
    int j;
    for (j = 0; j < cols; j++) {
        power_dissipated += dissipated[j];
        power_nonreciprocal += nonreciprocal[j];
    }
    total->dissipated += counted * power_dissipated;
    total->nonreciprocal += counted * power_nonreciprocal;
}

/* The load's share of face mass (i, k) of the whole lattice (docs/model.md sections 4 and 10): over the whole
 * face the product of the row weights in y and z, over a centred P x P patch 1/P^2 inside it, 0 outside. */
static double load_fraction(const LatticeParams *p, int i, int k) {
    const int patch = p->load_patch;
    if (patch == LATTICE_WHOLE_FACE) return row_load_fraction(p->rows, i) * row_load_fraction(p->depth, k);
    {
        const int first_row = (p->rows - patch) / 2, first_slice = (p->depth - patch) / 2;
        const int inside = i >= first_row && i < first_row + patch && k >= first_slice && k < first_slice + patch;
        return inside ? 1.0 / (double)(patch * patch) : 0.0;
    }
}

/* How often face mass (i, k) of a part that holds rows x slices stands in the whole lattice: twice for a
 * mirror image in y (all but the middle row, the part's last), twice more for one in z. */
static double mirror_count(int mirror_y, int mirror_z, int rows, int slices, int i, int k) {
    return (mirror_y && i + 1 < rows ? 2.0 : 1.0) * (mirror_z && k + 1 < slices ? 2.0 : 1.0);
}

/* What acts beyond the springs, after the rows: the springs' powers, the load on column 1, the backplate on
 * column C, the mass; the powers into powers[0..3) (W_ext, D, W_nr). Over the rows x slices the state holds
 * (a mirrored part's counted as often as they stand in the whole); forces holds force_blocks blocks of
 * rows * cols * slices (x, then y and z: the load pushes in the xy plane), vy NULL along x. */
static void external_forces(const LatticeParams *p, int mirror_y, int mirror_z, int rows, int slices, int load_on,
                            const signed char *wall_mode, const double *ux, const double *vx, const double *vy,
                            double *forces, int force_blocks, const SpringPowers *springs, double *powers) {
    const int cols = p->cols, n = rows * cols * slices;
    double *fx = forces, *fy = force_blocks > 1 ? forces + n : NULL;
    double power_external = 0.0, power_dissipated = springs->dissipated, power_nonreciprocal = springs->nonreciprocal;
    int i, k;

    if (p->load_mode != LOAD_MODE_PULSE) {
        /* the front port's force along +x, with the pulse's weights; its work is external in input mode, while
         * projectile mode's contact is inside the model (the body's energy and the contact's take it) */
        const int external = p->load_mode == LOAD_MODE_INPUT;
        for (k = 0; k < slices; k++) {
            for (i = 0; i < rows; i++) {
                const int a = (k * rows + i) * cols;
                const double share = p->front_force * load_fraction(p, i, k);
                if (share == 0.0) continue; /* outside the patch, or no force */
                fx[a] += share;
                if (external) power_external += mirror_count(mirror_y, mirror_z, rows, slices, i, k) * (share * vx[a]);
            }
        }
    } else if (load_on) {
        const double angle = p->load_angle_deg * (M_PI / 180.0);
        const double cos_angle = cos(angle), sin_angle = sin(angle);
        for (k = 0; k < slices; k++) {
            for (i = 0; i < rows; i++) {
                const int a = (k * rows + i) * cols;
                const double fraction = load_fraction(p, i, k);
                const double share = p->load_total * fraction;
                const double counted = mirror_count(mirror_y, mirror_z, rows, slices, i, k); /* and its images */
                if (fraction == 0.0) continue; /* outside the patch */
                fx[a] += share * cos_angle;
                if (fy) {
                    fy[a] += share * sin_angle;
                    power_external += counted * (share * (cos_angle * vx[a] + sin_angle * vy[a]));
                } else {
                    power_external += counted * (share * (cos_angle * vx[a]));
                }
            }
        }
    }

    if (p->has_backplate) {
        for (k = 0; k < slices; k++) {
            for (i = 0; i < rows; i++) {
                const int a = (k * rows + i) * cols + cols - 1;
                const double penetration = ux[a] - p->backplate_gap - p->back_position;
                const int mode = wall_mode ? wall_mode[k * p->rows + i] : lattice_wall_mode(p, ux[a], vx[a]);
                if (mode != WALL_FREE) {
                    /* the damper on the velocity relative to the backplate; the force on the mass does
                     * work on the backplate at v_back, which leaves the lattice (docs/model.md section 11) */
                    const double damped_velocity = mode == WALL_APPROACHING ? vx[a] - p->back_velocity : 0.0;
                    const double counted = mirror_count(mirror_y, mirror_z, rows, slices, i, k);
                    const double wall_force = p->k_wall * penetration + p->c_wall * damped_velocity;
                    fx[a] -= wall_force;
                    power_dissipated += counted * (p->c_wall * damped_velocity * damped_velocity);
                    power_external -= counted * (wall_force * p->back_velocity);
                }
            }
        }
    }

    if (!unit_masses(p)) { /* each mass weighs its column's material's mass (docs/model.md section 12) */
        double inverse_mass[LATTICE_MAX_COLS];
        int j;
        for (j = 0; j < cols; j++) inverse_mass[j] = 1.0 / p->column[j].mass;
        for (i = 0; i < force_blocks * n; i += cols) { /* the forces' rows, each over the columns */
            for (j = 0; j < cols; j++) forces[i + j] *= inverse_mass[j];
        }
    }
    powers[0] = power_external;
    powers[1] = power_dissipated;
    powers[2] = power_nonreciprocal;
}

int lattice_wall_mode(const LatticeParams *p, double ux, double vx) {
    if (!p->has_backplate || ux - p->backplate_gap - p->back_position <= 0.0) return WALL_FREE;
    return vx - p->back_velocity > 0.0 ? WALL_APPROACHING : WALL_RECEDING;
}

int lattice_along_x(const LatticeParams *p) {
    return p->load_mode != LOAD_MODE_PULSE || p->load_angle_deg == 0.0 || p->load_total == 0.0;
}

/* A load along x (or none) that is centred on the face: a patch is centred when its side leaves as many
 * rows (slices) on either side. */
static int centred_along_x(const LatticeParams *p, int extent) {
    return lattice_along_x(p) && (p->load_patch == LATTICE_WHOLE_FACE || (extent - p->load_patch) % 2 == 0);
}

int lattice_mirror_rows(const LatticeParams *p) {
    return (p->rows >= 3 && p->rows % 2 == 1 && centred_along_x(p, p->rows)) ? (p->rows + 1) / 2 : 0;
}

int lattice_mirror_slices(const LatticeParams *p) {
    return (p->depth >= 3 && p->depth % 2 == 1 && centred_along_x(p, p->depth)) ? (p->depth + 1) / 2 : 0;
}

/* The first column whose mass or damping exponent is not a finite number > 0 (docs/model.md section 12), or -1. */
static int column_out_of_range(const LatticeParams *p) {
    int j;
    for (j = 0; j < p->cols && j < LATTICE_MAX_COLS; j++) {
        const ColumnConstants *column = &p->column[j];
        if (!(isfinite(column->mass) && column->mass > 0.0) ||
            !(isfinite(column->damping_exponent) && column->damping_exponent > 0.0)) {
            return j;
        }
    }
    return -1;
}

const char *lattice_params_error(const LatticeParams *p, char *message, int size) {
    const int patch = p->load_patch, column = column_out_of_range(p);
    if (p->rows < 1) {
        snprintf(message, (size_t)size, "rows = %d: the lattice needs at least 1 row", p->rows);
    } else if (p->cols < 1 || p->cols > LATTICE_MAX_COLS) {
        snprintf(message, (size_t)size, "cols = %d: allowed 1 to %d columns", p->cols, LATTICE_MAX_COLS);
    } else if (p->depth < 1) {
        snprintf(message, (size_t)size, "depth = %d: the lattice needs at least 1 slice", p->depth);
    } else if (column >= 0) {
        snprintf(message, (size_t)size,
                 "column %d: mass = %g kg, damping_exponent = %g: allowed for each a finite number > 0", column + 1,
                 p->column[column].mass, p->column[column].damping_exponent);
    } else if (patch != LATTICE_WHOLE_FACE &&
               (patch < 1 || patch % 2 == 0 || patch > p->rows || patch > p->depth)) {
        snprintf(message, (size_t)size,
                 "load_patch = %d: allowed %d (the whole face) or an odd side P of a centred P x P patch, "
                 "1 <= P <= min(rows, depth) = %d",
                 patch, LATTICE_WHOLE_FACE, p->rows < p->depth ? p->rows : p->depth);
    } else if (patch != LATTICE_WHOLE_FACE && (p->rows % 2 == 0 || p->depth % 2 == 0)) {
        snprintf(message, (size_t)size,
                 "load_patch = %d: a centred patch needs an odd number of rows and an odd depth (rows = %d, depth = %d)",
                 patch, p->rows, p->depth);
    } else {
        return NULL;
    }
    return message;
}

static void between_slices_general(const LatticeParams *p, const double *u, const double *v, double *f,
                                   SpringPowers *powers);
static void between_slices_along_x(const LatticeParams *p, int mirror_y, int mirror_z, int rows, int slices,
                                   const double *ux, const double *vx, double *fx, SpringPowers *powers);

/* The right-hand side of the whole lattice (with_z 0, depth 1) or plate (with_z 1): every slice's springs in
 * its plane, then the springs between slices. Written once, compiled for each (rhs_rows, rhs_plate). */
static ALWAYS_INLINE void rhs_of_slices(const LatticeParams *p, const int with_z, int load_on,
                                        const signed char *wall_mode, const double *y, double *dydt) {
    const int rows = p->rows, cols = p->cols, slices = p->depth, slice_size = rows * cols, n = slice_size * slices;
    const int components = with_z ? 3 : 2;
    const int linear = p->spring_law == SPRING_LINEAR;
    const int links = cols - 1; /* horizontal springs in a row, and rising (falling) diagonals below it */
    const int even_links = EVEN(links), even_cols = EVEN(cols);
    const double *ux = y, *uy = y + n, *uz = with_z ? y + 2 * n : uy;
    const double *vx = y + components * n, *vy = vx + n, *vz = with_z ? vx + 2 * n : vy;
    double *fx = dydt + components * n, *fy = fx + n, *fz = with_z ? fx + 2 * n : fy; /* fz unused in a lattice */
    const double k_horizontal = p->k_horizontal, c_horizontal = p->c_horizontal;
    int alphas_differ; /* some diagonal's right end needs an exponential of its own */
    SpringPowers springs = {0.0, 0.0};
    RowBuffers w;
    int i, j, k;

    alphas_differ = prepare_row_buffers(p, &w);

    memcpy(dydt, vx, (size_t)components * (size_t)n * sizeof(double));

    for (k = 0; k < slices; k++) {
        start_slice(&w, cols);
        for (i = 0; i < rows; i++) {
            const size_t top = (size_t)k * (size_t)slice_size + (size_t)i * (size_t)cols, bottom = top + (size_t)cols;
            const double *ux0 = ux + top, *uy0 = uy + top, *uz0 = uz + top, *vx0 = vx + top, *vy0 = vy + top,
                         *vz0 = vz + top;
            const double *ux1 = ux + bottom, *uy1 = uy + bottom, *uz1 = uz + bottom, *vx1 = vx + bottom,
                         *vy1 = vy + bottom, *vz1 = vz + bottom;
            double *row_fx = fx + top, *row_fy = fy + top, *row_fz = fz + top;

            /* 1. geometry; a spring's ends are given by row (0 this row, 1 the next) and column */
#define GEOMETRY(family, j, ar, aj, br, bj)                                                 \
    {                                                                                       \
        const double dx = ux##br[bj] - ux##ar[aj], dy = uy##br[bj] - uy##ar[aj];            \
        w.rx[family][j] = dx;                                                               \
        w.ry[family][j] = dy;                                                               \
        if (with_z) {                                                                       \
            const double dz = uz##br[bj] - uz##ar[aj];                                      \
            w.rz[family][j] = dz;                                                           \
            w.squared[SLOT(family, j)] = dx * dx + dy * dy + dz * dz;                       \
        } else {                                                                            \
            w.squared[SLOT(family, j)] = dx * dx + dy * dy;                                 \
        }                                                                                   \
    }
#define GEOMETRY_H(j) GEOMETRY(HORIZONTAL, j, 0, j, 0, j + 1)
#define GEOMETRY_HRF(j)                        \
    GEOMETRY(HORIZONTAL, j, 0, j, 0, j + 1)    \
    GEOMETRY(RISING, j, 0, j, 1, j + 1)        \
    GEOMETRY(FALLING, j, 0, j + 1, 1, j)
#define GEOMETRY_V(j) GEOMETRY(VERTICAL, j, 0, j, 1, j)
            if (i + 1 < rows) {
                OVER(links, even_links, GEOMETRY_HRF)
                OVER(cols, even_cols, GEOMETRY_V)
            } else {
                OVER(links, even_links, GEOMETRY_H)
            }

            /* 2. stretches */
            row_stretches(linear, 0, i + 1 < rows, alphas_differ, links, cols, &w);

            /* 3. forces. Horizontal and vertical: k stretch r/|r| + c (v_b - v_a) on the a end (the b end gets
             * the opposite), dissipating c |v_a - v_b|^2. Diagonals: the a end is pushed by per_length_a r,
             * the b end by -per_length_b r, and the non-reciprocal power is g.(v_a + v_b), g = (f_a - f_b)/2. */
#define DAMPED(family, j, k, c, ar, aj, br, bj, FORCE)                                                   \
    {                                                                                                    \
        const double per_length = (k) * w.stretch[SLOT(family, j)] * w.inverse[SLOT(family, j)];         \
        const double dvx = vx##br[bj] - vx##ar[aj], dvy = vy##br[bj] - vy##ar[aj];                       \
        FORCE(0, j) = per_length * w.rx[family][j] + (c) * dvx;                                          \
        FORCE(1, j) = per_length * w.ry[family][j] + (c) * dvy;                                          \
        if (with_z) {                                                                                    \
            const double dvz = vz##br[bj] - vz##ar[aj];                                                  \
            FORCE(2, j) = per_length * w.rz[family][j] + (c) * dvz;                                      \
            w.dissipated[j] += (c) * (dvx * dvx + dvy * dvy + dvz * dvz);                                \
        } else {                                                                                         \
            w.dissipated[j] += (c) * (dvx * dvx + dvy * dvy);                                            \
        }                                                                                                \
    }
#define DIAGONAL(family, j, k_a, stretch_a, k_b, stretch_b, ar, aj, br, bj, A_FORCE, B_FORCE)                   \
    {                                                                                                           \
        const double per_length_a = (k_a) * (stretch_a) * w.inverse[SLOT(family, j)];                           \
        const double per_length_b = (k_b) * (stretch_b) * w.inverse[SLOT(family, j)];                          \
        A_FORCE(0, j) = per_length_a * w.rx[family][j];                                                         \
        A_FORCE(1, j) = per_length_a * w.ry[family][j];                                                         \
        B_FORCE(0, j) = per_length_b * w.rx[family][j];                                                         \
        B_FORCE(1, j) = per_length_b * w.ry[family][j];                                                         \
        if (with_z) {                                                                                           \
            A_FORCE(2, j) = per_length_a * w.rz[family][j];                                                     \
            B_FORCE(2, j) = per_length_b * w.rz[family][j];                                                     \
            w.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) *                                         \
                                  (w.rx[family][j] * (vx##ar[aj] + vx##br[bj]) +                                \
                                   w.ry[family][j] * (vy##ar[aj] + vy##br[bj]) +                                \
                                   w.rz[family][j] * (vz##ar[aj] + vz##br[bj]));                                \
        } else {                                                                                                \
            w.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) *                                         \
                                  (w.rx[family][j] * (vx##ar[aj] + vx##br[bj]) +                                \
                                   w.ry[family][j] * (vy##ar[aj] + vy##br[bj]));                                \
        }                                                                                                       \
    }
#define FORCES_H(j) DAMPED(HORIZONTAL, j, k_horizontal, c_horizontal, 0, j, 0, j + 1, HORIZONTAL_FORCE)
            /* rising: a = (i, j) is the left end, b = (i+1, j+1) the right; falling: a = (i, j+1) is the
             * right end, b = (i+1, j) the left (a right end's stretch is the left one's unless the alphas
             * differ) */
#define FORCES_HRF(j, rising_right, falling_right)                                                            \
    FORCES_H(j)                                                                                               \
    DIAGONAL(RISING, j, w.k_left[j], w.stretch[SLOT(RISING, j)], w.k_right[j], rising_right, 0, j, 1, j + 1,  \
             RISING_TOP_FORCE, RISING_BOTTOM_FORCE)                                                           \
    DIAGONAL(FALLING, j, w.k_right[j], falling_right, w.k_left[j], w.stretch[SLOT(FALLING, j)], 0, j + 1, 1, \
             j, FALLING_TOP_FORCE, FALLING_BOTTOM_FORCE)
#define FORCES_HRF_SAME(j) FORCES_HRF(j, w.stretch[SLOT(RISING, j)], w.stretch[SLOT(FALLING, j)])
#define FORCES_HRF_DIFFERENT(j) FORCES_HRF(j, w.stretch[RIGHT_END_SLOT(0, j)], w.stretch[RIGHT_END_SLOT(1, j)])
#define FORCES_V(j) DAMPED(VERTICAL, j, w.k_vertical[j], w.c_vertical[j], 0, j, 1, j, VERTICAL_FORCE)
#define FORCES_V_NONLINEAR(j) DAMPED(VERTICAL, j, w.k_vertical[j], w.c_effective[j], 0, j, 1, j, VERTICAL_FORCE)
            if (i + 1 < rows) {
                if (alphas_differ) {
                    OVER(links, even_links, FORCES_HRF_DIFFERENT)
                } else {
                    OVER(links, even_links, FORCES_HRF_SAME)
                }
                if (w.nonlinear_count) {
                    nonlinear_dampers(p, w.nonlinear_count, w.nonlinear, vx0, vy0, with_z ? vz0 : NULL, vx1, vy1,
                                      with_z ? vz1 : NULL, w.c_effective);
                    OVER(cols, even_cols, FORCES_V_NONLINEAR)
                } else {
                    OVER(cols, even_cols, FORCES_V)
                }
            } else {
                OVER(links, even_links, FORCES_H)
            }

            /* 4. gather */
#define GATHER(j, c, row_force)                                                                      \
    {                                                                                                \
        row_force[j] = w.carried[c][j] + (HORIZONTAL_FORCE(c, j) - HORIZONTAL_FORCE(c, j - 1)) +     \
                       w.vertical[c][j] + w.rising_top[c][j] + FALLING_TOP_FORCE(c, j - 1);          \
        w.next[c][j] = -(w.vertical[c][j] + RISING_BOTTOM_FORCE(c, j - 1) + w.falling_bottom[c][j]); \
    }
#define GATHER_X(j) GATHER(j, 0, row_fx)
#define GATHER_Y(j) GATHER(j, 1, row_fy)
#define GATHER_Z(j) GATHER(j, 2, row_fz)
#define GATHER_LAST(j, c, row_force) \
    row_force[j] = w.carried[c][j] + (HORIZONTAL_FORCE(c, j) - HORIZONTAL_FORCE(c, j - 1));
#define GATHER_LAST_X(j) GATHER_LAST(j, 0, row_fx)
#define GATHER_LAST_Y(j) GATHER_LAST(j, 1, row_fy)
#define GATHER_LAST_Z(j) GATHER_LAST(j, 2, row_fz)
            if (i + 1 < rows) {
                OVER(cols, even_cols, GATHER_X) /* x, y and z apart: the compiler cannot tell fx and fy apart */
                OVER(cols, even_cols, GATHER_Y)
                if (with_z) OVER(cols, even_cols, GATHER_Z)
#define CARRY(j)                        \
    {                                   \
        w.carried[0][j] = w.next[0][j]; \
        w.carried[1][j] = w.next[1][j]; \
        if (with_z) w.carried[2][j] = w.next[2][j]; \
    }
                OVER(cols, even_cols, CARRY)
            } else {
                OVER(cols, even_cols, GATHER_LAST_X)
                OVER(cols, even_cols, GATHER_LAST_Y)
                if (with_z) OVER(cols, even_cols, GATHER_LAST_Z)
            }
        }
        add_spring_powers(w.dissipated, w.nonreciprocal, cols, 1.0, &springs);
    }
    if (with_z) between_slices_general(p, y, vx, fx, &springs);
    external_forces(p, 0, 0, rows, slices, load_on, wall_mode, ux, vx, vy, fx, components, &springs,
                    dydt + 2 * components * n);
}

static VECTOR_CLONES void rhs_rows(const LatticeParams *p, int load_on, const signed char *wall_mode,
                                   const double *y, double *dydt) {
    rhs_of_slices(p, 0, load_on, wall_mode, y, dydt);
}

static VECTOR_CLONES void rhs_plate(const LatticeParams *p, int load_on, const signed char *wall_mode,
                                    const double *y, double *dydt) {
    rhs_of_slices(p, 1, load_on, wall_mode, y, dydt);
}

void lattice_rhs(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y, double *dydt) {
    if (p->depth > 1) {
        rhs_plate(p, load_on, wall_mode, y, dydt);
    } else {
        rhs_rows(p, load_on, wall_mode, y, dydt);
    }
}

/* The right-hand side over the layout without y and z (lattice_along_x): rhs_of_slices with every y and z part
 * left out, the same arithmetic on what is left (|r| = |dx|, which is what sqrt(dx^2) gives), and the same
 * four stages (see above rhs_of_slices). With mirrored, of the part of a mirror-symmetric lattice that carries
 * its solution (rows 0 .. (R-1)/2, the last of them the middle row, and slices 0 .. (D-1)/2 likewise; see
 * lattice.h): the rows above the middle are computed as the whole does, what the springs below the middle row
 * do to it is the mirror image of what those above it do, and every power but the middle row's own springs'
 * counts twice (the same for the slices in between_slices_along_x, and a slice's powers count twice but the
 * middle slice's). */
static VECTOR_CLONES void rhs_rows_along_x(const LatticeParams *p, int mirrored, int load_on,
                                           const signed char *wall_mode, const double *y, double *dydt) {
    const int mirror_y = mirrored && lattice_mirror_rows(p), mirror_z = mirrored && lattice_mirror_slices(p);
    const int rows = mirror_y ? (p->rows + 1) / 2 : p->rows, slices = mirror_z ? (p->depth + 1) / 2 : p->depth;
    const int cols = p->cols, slice_size = rows * cols, n = slice_size * slices;
    const int linear = p->spring_law == SPRING_LINEAR;
    const int links = cols - 1;
    const int even_links = EVEN(links), even_cols = EVEN(cols);
    const double *ux = y, *vx = y + n;
    double *fx = dydt + n;
    const double k_horizontal = p->k_horizontal, c_horizontal = p->c_horizontal;
    int alphas_differ;
    SpringPowers springs = {0.0, 0.0};
    RowBuffers w;
    int i, j, k;

    alphas_differ = prepare_row_buffers(p, &w);

    memcpy(dydt, vx, (size_t)n * sizeof(double));

    for (k = 0; k < slices; k++) {
        start_slice(&w, cols);
        for (i = 0; i < rows; i++) {
            const size_t top = (size_t)k * (size_t)slice_size + (size_t)i * (size_t)cols, bottom = top + (size_t)cols;
            const double *ux0 = ux + top, *vx0 = vx + top, *ux1 = ux + bottom, *vx1 = vx + bottom;
            double *row_fx = fx + top;
            if (mirror_y && i + 1 == rows) count_mirror_images(w.dissipated, w.nonreciprocal, cols);

            /* 1. geometry: r = (dx, 0, 0) */
#define GEOMETRY_X(family, j, ax, bx)                                        \
    {                                                                        \
        const double dx = (bx) - (ax);                                       \
        w.rx[family][j] = dx;                                                \
        w.squared[SLOT(family, j)] = dx; /* dx itself: packed_stretches_x */ \
    }
#define GEOMETRY_X_H(j) GEOMETRY_X(HORIZONTAL, j, ux0[j], ux0[j + 1])
#define GEOMETRY_X_HRF(j)                         \
    GEOMETRY_X(HORIZONTAL, j, ux0[j], ux0[j + 1]) \
    GEOMETRY_X(RISING, j, ux0[j], ux1[j + 1])     \
    GEOMETRY_X(FALLING, j, ux0[j + 1], ux1[j])
#define GEOMETRY_X_V(j) GEOMETRY_X(VERTICAL, j, ux0[j], ux1[j])
            if (i + 1 < rows) {
                OVER(links, even_links, GEOMETRY_X_HRF)
                OVER(cols, even_cols, GEOMETRY_X_V)
            } else {
                OVER(links, even_links, GEOMETRY_X_H)
            }

            /* 2. stretches */
            row_stretches(linear, 1, i + 1 < rows, alphas_differ, links, cols, &w);

            /* 3. forces, x only */
#define DAMPED_X(family, j, k, c, avx, bvx, out_x)                                               \
    {                                                                                            \
        const double per_length = (k) * w.stretch[SLOT(family, j)] * w.inverse[SLOT(family, j)]; \
        const double dvx = (bvx) - (avx);                                                        \
        out_x = per_length * w.rx[family][j] + (c) * dvx;                                        \
        w.dissipated[j] += (c) * (dvx * dvx);                                                    \
    }
#define DIAGONAL_X(family, j, k_a, stretch_a, k_b, stretch_b, avx, bvx, a_x, b_x)                        \
    {                                                                                                    \
        const double per_length_a = (k_a) * (stretch_a) * w.inverse[SLOT(family, j)];                    \
        const double per_length_b = (k_b) * (stretch_b) * w.inverse[SLOT(family, j)];                    \
        a_x = per_length_a * w.rx[family][j];                                                            \
        b_x = per_length_b * w.rx[family][j];                                                            \
        w.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) * (w.rx[family][j] * ((avx) + (bvx))); \
    }
#define FORCES_X_H(j) DAMPED_X(HORIZONTAL, j, k_horizontal, c_horizontal, vx0[j], vx0[j + 1], HORIZONTAL_FORCE(0, j))
#define FORCES_X_HRF(j, rising_right, falling_right)                                                          \
    FORCES_X_H(j)                                                                                             \
    DIAGONAL_X(RISING, j, w.k_left[j], w.stretch[SLOT(RISING, j)], w.k_right[j], rising_right, vx0[j],        \
               vx1[j + 1], w.rising_top[0][j], RISING_BOTTOM_FORCE(0, j))                                     \
    DIAGONAL_X(FALLING, j, w.k_right[j], falling_right, w.k_left[j], w.stretch[SLOT(FALLING, j)], vx0[j + 1], \
               vx1[j], FALLING_TOP_FORCE(0, j), w.falling_bottom[0][j])
#define FORCES_X_HRF_SAME(j) FORCES_X_HRF(j, w.stretch[SLOT(RISING, j)], w.stretch[SLOT(FALLING, j)])
#define FORCES_X_HRF_DIFFERENT(j) \
    FORCES_X_HRF(j, w.stretch[RIGHT_END_SLOT(0, j)], w.stretch[RIGHT_END_SLOT(1, j)])
#define FORCES_X_V(j) DAMPED_X(VERTICAL, j, w.k_vertical[j], w.c_vertical[j], vx0[j], vx1[j], w.vertical[0][j])
#define FORCES_X_V_NONLINEAR(j) \
    DAMPED_X(VERTICAL, j, w.k_vertical[j], w.c_effective[j], vx0[j], vx1[j], w.vertical[0][j])
            if (i + 1 < rows) {
                if (alphas_differ) {
                    OVER(links, even_links, FORCES_X_HRF_DIFFERENT)
                } else {
                    OVER(links, even_links, FORCES_X_HRF_SAME)
                }
                if (w.nonlinear_count) {
                    nonlinear_dampers(p, w.nonlinear_count, w.nonlinear, vx0, NULL, NULL, vx1, NULL, NULL,
                                      w.c_effective);
                    OVER(cols, even_cols, FORCES_X_V_NONLINEAR)
                } else {
                    OVER(cols, even_cols, FORCES_X_V)
                }
            } else {
                OVER(links, even_links, FORCES_X_H)
            }

            /* 4. gather */
            if (i + 1 < rows) {
                OVER(cols, even_cols, GATHER_X)
#define CARRY_X(j) w.carried[0][j] = w.next[0][j];
                OVER(cols, even_cols, CARRY_X)
            } else if (mirror_y) {
#define GATHER_MIDDLE_ALONG_X(j) \
    row_fx[j] = w.carried[0][j] + (HORIZONTAL_FORCE(0, j) - HORIZONTAL_FORCE(0, j - 1)) + w.carried[0][j];
                OVER(cols, even_cols, GATHER_MIDDLE_ALONG_X)
            } else {
                OVER(cols, even_cols, GATHER_LAST_X)
            }
        }
        add_spring_powers(w.dissipated, w.nonreciprocal, cols, mirror_z && k + 1 < slices ? 2.0 : 1.0, &springs);
    }
    if (slices > 1) between_slices_along_x(p, mirror_y, mirror_z, rows, slices, ux, vx, fx, &springs);
    external_forces(p, mirror_y, mirror_z, rows, slices, load_on, wall_mode, ux, vx, NULL, fx, 1, &springs,
                    dydt + 2 * n);
}

void lattice_rhs_along_x(const LatticeParams *p, int mirrored, int load_on, const signed char *wall_mode,
                         const double *y, double *dydt) {
    rhs_rows_along_x(p, mirrored, load_on, wall_mode, y, dydt);
}

/* Between slices k (the front) and k+1 (the back) of a plate, by row i of the front, the springs of
 * docs/model.md section 10 that leave the plane: depth (i, j, k) -> (i, j, k+1), of column j's material and
 * damped; depth rising (i, j, k) -> (i, j+1, k+1) and depth falling (i, j+1, k) -> (i, j, k+1), the xz
 * diagonals between columns j and j+1 (as the xy ones: their ends by the diagonal rule); side rising
 * (i, j, k) -> (i+1, j, k+1) and side falling (i+1, j, k) -> (i, j, k+1), the yz diagonals, inside column j
 * (its k_diag, alpha_diag at both ends: reciprocal). Each spring's a end is on the front and its b end on
 * the back. The same four stages as the rows (see above rhs_of_slices), in SliceBuffers. */
enum { DEPTH = 0, DEPTH_RISING = 1, DEPTH_FALLING = 2, SIDE_RISING = 3, SIDE_FALLING = 4, SLICE_FAMILIES = 5 };

/* Packed: depth (cols), depth rising, depth falling (links each), side rising, side falling (cols each), then
 * the right ends of the depth diagonals (links each; when their alphas differ from the left ends'). */
#define SLICE_SLOT(family, j)                                                                           \
    (((family) == DEPTH            ? 0                                                                  \
      : (family) == DEPTH_RISING  ? cols                                                                \
      : (family) == DEPTH_FALLING ? cols + links                                                        \
      : (family) == SIDE_RISING   ? cols + 2 * links                                                    \
                                  : 2 * cols + 2 * links) +                                             \
     (j))
#define SLICE_RIGHT_END_SLOT(diagonal, j) (3 * cols + 2 * links + (diagonal) * links + (j))
#define SLICE_PACKED_SPRINGS (7 * LATTICE_MAX_COLS)

typedef struct {
    double rx[SLICE_FAMILIES][LATTICE_MAX_COLS], ry[SLICE_FAMILIES][LATTICE_MAX_COLS],
        rz[SLICE_FAMILIES][LATTICE_MAX_COLS];
    double squared[SLICE_PACKED_SPRINGS], alpha[SLICE_PACKED_SPRINGS], stretch[SLICE_PACKED_SPRINGS],
        inverse[SLICE_PACKED_SPRINGS];
    double k_vertical[LATTICE_MAX_COLS], c_vertical[LATTICE_MAX_COLS], k_side[LATTICE_MAX_COLS],
        k_left[LATTICE_MAX_COLS], k_right[LATTICE_MAX_COLS];
    double c_effective[LATTICE_MAX_COLS]; /* the depth dampers' constants at this row's speeds (as RowBuffers) */
    int nonlinear[LATTICE_MAX_COLS], nonlinear_count;
    double dissipated[LATTICE_MAX_COLS], nonreciprocal[LATTICE_MAX_COLS];
    /* the forces by component: on the front end (the back end gets the opposite) of the reciprocal springs,
     * on each end of the depth diagonals; guards as in RowBuffers */
    double depth[3][LATTICE_MAX_COLS], side_rising[3][LATTICE_MAX_COLS], side_falling[3][LATTICE_MAX_COLS];
    double rising_front[3][LATTICE_MAX_COLS], rising_back[3][LATTICE_MAX_COLS + 2],
        falling_front[3][LATTICE_MAX_COLS + 2], falling_back[3][LATTICE_MAX_COLS];
    /* what the side diagonals of the row above do to a row of the front and of the back */
    double carried_front[3][LATTICE_MAX_COLS], carried_back[3][LATTICE_MAX_COLS], next_front[3][LATTICE_MAX_COLS],
        next_back[3][LATTICE_MAX_COLS];
} SliceBuffers;

#define DEPTH_FORCE(c, j) l.depth[c][j]
#define SIDE_RISING_FORCE(c, j) l.side_rising[c][j]
#define SIDE_FALLING_FORCE(c, j) l.side_falling[c][j]
#define RISING_FRONT_FORCE(c, j) l.rising_front[c][j]
#define RISING_BACK_FORCE(c, j) l.rising_back[c][(j) + 2]
#define FALLING_FRONT_FORCE(c, j) l.falling_front[c][(j) + 2]
#define FALLING_BACK_FORCE(c, j) l.falling_back[c][j]

/* OVER with j < even: GCC (12) cannot tell that j != even ends in these loops (and warns). */
#define SLICE_OVER(count, even, BODY)  \
    {                                  \
        for (j = 0; j < (even); j++) { \
            BODY(j)                    \
        }                              \
        if (j < (count)) {             \
            BODY(j)                    \
        }                              \
    }

/* All pairs of slices of the part of a plate that holds rows x slices (u, v and f: the x blocks, followed by
 * the y and z ones unless along_x), adding to f; a mirrored part's middle row and slice take the mirror
 * images of what they get from the rows above and the slices in front. */
static ALWAYS_INLINE void between_slices(const LatticeParams *p, const int along_x, int mirror_y, int mirror_z,
                                         int rows, int slices, const double *u, const double *v, double *f,
                                         SpringPowers *powers) {
    const int cols = p->cols, links = cols > 1 ? cols - 1 : 0, slice_size = rows * cols, n = slice_size * slices;
    const int linear = p->spring_law == SPRING_LINEAR;
    const int even_links = EVEN(links), even_cols = EVEN(cols);
    const double *ux = u, *uy = along_x ? u : u + n, *uz = along_x ? u : u + 2 * n;
    const double *vx = v, *vy = along_x ? v : v + n, *vz = along_x ? v : v + 2 * n;
    double *fx = f, *fy = along_x ? f : f + n, *fz = along_x ? f : f + 2 * n;
    const int components = along_x ? 1 : 3;
    const double carried_count = mirror_y ? 2.0 : 1.0; /* on the middle row, the side diagonals' images */
    int alphas_differ = 0, i, j, k, c;
    SliceBuffers l;

    for (j = 0; j < cols; j++) {
        const ColumnConstants *column = &p->column[j];
        l.k_vertical[j] = column->k;
        l.c_vertical[j] = l.c_effective[j] = column->c;
        l.k_side[j] = column->k_diag;
        l.alpha[SLICE_SLOT(DEPTH, j)] = column->alpha;
        l.alpha[SLICE_SLOT(SIDE_RISING, j)] = l.alpha[SLICE_SLOT(SIDE_FALLING, j)] = column->alpha_diag;
    }
    for (j = 0; j < links; j++) {
        const SpringEnds ends = diagonal_ends(p, j);
        l.alpha[SLICE_SLOT(DEPTH_RISING, j)] = l.alpha[SLICE_SLOT(DEPTH_FALLING, j)] = ends.alpha_a;
        l.alpha[SLICE_RIGHT_END_SLOT(0, j)] = l.alpha[SLICE_RIGHT_END_SLOT(1, j)] = ends.alpha_b;
        l.k_left[j] = ends.k_a;
        l.k_right[j] = ends.k_b;
        alphas_differ = alphas_differ || ends.alpha_a != ends.alpha_b;
    }
    l.nonlinear_count = nonlinear_columns(p, l.nonlinear);
    for (c = 0; c < 3; c++) {
        l.rising_front[c][links] = l.rising_back[c][1] = 0.0;
        l.falling_front[c][1] = l.falling_back[c][links] = 0.0;
    }

    for (k = 0; k + 1 < slices; k++) {
        /* the back is the middle slice of a mirrored part: it gets as much again from the slice behind it */
        const double back_count = mirror_z && k + 2 == slices ? 2.0 : 1.0;
        for (j = 0; j < cols; j++) {
            for (c = 0; c < 3; c++) l.carried_front[c][j] = l.carried_back[c][j] = 0.0;
            l.dissipated[j] = l.nonreciprocal[j] = 0.0;
        }
        for (i = 0; i < rows; i++) {
            const size_t front = ((size_t)k * (size_t)rows + (size_t)i) * (size_t)cols;
            const size_t back = front + (size_t)slice_size;
            const int below = i + 1 < rows;
            /* f0, f1: rows i and i+1 of the front; b0, b1: of the back (the side diagonals, undamped, need no
             * velocities of row i+1) */
            const double *uxf0 = ux + front, *uyf0 = uy + front, *uzf0 = uz + front;
            const double *uxf1 = uxf0 + cols, *uyf1 = uyf0 + cols, *uzf1 = uzf0 + cols;
            const double *uxb0 = ux + back, *uyb0 = uy + back, *uzb0 = uz + back;
            const double *uxb1 = uxb0 + cols, *uyb1 = uyb0 + cols, *uzb1 = uzb0 + cols;
            const double *vxf0 = vx + front, *vyf0 = vy + front, *vzf0 = vz + front;
            const double *vxb0 = vx + back, *vyb0 = vy + back, *vzb0 = vz + back;
            double *fxf0 = fx + front, *fyf0 = fy + front, *fzf0 = fz + front;
            double *fxb0 = fx + back, *fyb0 = fy + back, *fzb0 = fz + back;
            if (mirror_y && i + 1 == rows) count_mirror_images(l.dissipated, l.nonreciprocal, cols);

            /* 1. geometry (dx itself along x: packed_stretches_x) */
#define SLICE_GEOMETRY(family, j, ae, aj, be, bj)                                 \
    {                                                                             \
        const double dx = ux##be[bj] - ux##ae[aj];                                \
        l.rx[family][j] = dx;                                                     \
        if (along_x) {                                                            \
            l.squared[SLICE_SLOT(family, j)] = dx;                                \
        } else {                                                                  \
            const double dy = uy##be[bj] - uy##ae[aj], dz = uz##be[bj] - uz##ae[aj]; \
            l.ry[family][j] = dy;                                                 \
            l.rz[family][j] = dz;                                                 \
            l.squared[SLICE_SLOT(family, j)] = dx * dx + dy * dy + dz * dz;       \
        }                                                                         \
    }
#define SLICE_GEOMETRY_D(j) SLICE_GEOMETRY(DEPTH, j, f0, j, b0, j)
#define SLICE_GEOMETRY_RF(j)                                \
    SLICE_GEOMETRY(DEPTH_RISING, j, f0, j, b0, j + 1)       \
    SLICE_GEOMETRY(DEPTH_FALLING, j, f0, j + 1, b0, j)
#define SLICE_GEOMETRY_S(j)                                 \
    SLICE_GEOMETRY(SIDE_RISING, j, f0, j, b1, j)            \
    SLICE_GEOMETRY(SIDE_FALLING, j, f1, j, b0, j)
            SLICE_OVER(cols, even_cols, SLICE_GEOMETRY_D)
            SLICE_OVER(links, even_links, SLICE_GEOMETRY_RF)
            if (below) SLICE_OVER(cols, even_cols, SLICE_GEOMETRY_S)

            /* 2. stretches */
            stretches_of(linear, along_x, below ? 3 * cols + 2 * links : cols + 2 * links, l.squared, l.alpha,
                         l.stretch, l.inverse);
            if (alphas_differ) {
                for (j = 0; j < links; j++) {
                    l.squared[SLICE_RIGHT_END_SLOT(0, j)] = l.squared[SLICE_SLOT(DEPTH_RISING, j)];
                    l.squared[SLICE_RIGHT_END_SLOT(1, j)] = l.squared[SLICE_SLOT(DEPTH_FALLING, j)];
                }
                stretches_of(linear, along_x, 2 * links, l.squared + SLICE_RIGHT_END_SLOT(0, 0),
                             l.alpha + SLICE_RIGHT_END_SLOT(0, 0), l.stretch + SLICE_RIGHT_END_SLOT(0, 0),
                             l.inverse + SLICE_RIGHT_END_SLOT(0, 0));
            }

            /* 3. forces, as in the rows */
#define SLICE_PER_LENGTH(family, j, k) ((k) * l.stretch[SLICE_SLOT(family, j)] * l.inverse[SLICE_SLOT(family, j)])
#define SLICE_DAMPED(family, j, k, c, ae, aj, be, bj, FORCE)                                  \
    {                                                                                         \
        const double per_length = SLICE_PER_LENGTH(family, j, k);                             \
        const double dvx = vx##be[bj] - vx##ae[aj];                                           \
        FORCE(0, j) = per_length * l.rx[family][j] + (c) * dvx;                               \
        if (along_x) {                                                                        \
            l.dissipated[j] += (c) * (dvx * dvx);                                             \
        } else {                                                                              \
            const double dvy = vy##be[bj] - vy##ae[aj], dvz = vz##be[bj] - vz##ae[aj];        \
            FORCE(1, j) = per_length * l.ry[family][j] + (c) * dvy;                           \
            FORCE(2, j) = per_length * l.rz[family][j] + (c) * dvz;                           \
            l.dissipated[j] += (c) * (dvx * dvx + dvy * dvy + dvz * dvz);                     \
        }                                                                                     \
    }
#define SLICE_DIAGONAL(family, j, k_a, stretch_a, k_b, stretch_b, ae, aj, be, bj, A_FORCE, B_FORCE)          \
    {                                                                                                       \
        const double per_length_a = (k_a) * (stretch_a) * l.inverse[SLICE_SLOT(family, j)];                 \
        const double per_length_b = (k_b) * (stretch_b) * l.inverse[SLICE_SLOT(family, j)];                 \
        A_FORCE(0, j) = per_length_a * l.rx[family][j];                                                     \
        B_FORCE(0, j) = per_length_b * l.rx[family][j];                                                     \
        if (along_x) {                                                                                      \
            l.nonreciprocal[j] +=                                                                           \
                0.5 * (per_length_a - per_length_b) * (l.rx[family][j] * (vx##ae[aj] + vx##be[bj]));        \
        } else {                                                                                            \
            A_FORCE(1, j) = per_length_a * l.ry[family][j];                                                 \
            A_FORCE(2, j) = per_length_a * l.rz[family][j];                                                 \
            B_FORCE(1, j) = per_length_b * l.ry[family][j];                                                 \
            B_FORCE(2, j) = per_length_b * l.rz[family][j];                                                 \
            l.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) *                                     \
                                  (l.rx[family][j] * (vx##ae[aj] + vx##be[bj]) +                            \
                                   l.ry[family][j] * (vy##ae[aj] + vy##be[bj]) +                            \
                                   l.rz[family][j] * (vz##ae[aj] + vz##be[bj]));                            \
        }                                                                                                   \
    }
#define SLICE_SIDE(family, j, FORCE)                                       \
    {                                                                      \
        const double per_length = SLICE_PER_LENGTH(family, j, l.k_side[j]); \
        FORCE(0, j) = per_length * l.rx[family][j];                        \
        if (!along_x) {                                                    \
            FORCE(1, j) = per_length * l.ry[family][j];                    \
            FORCE(2, j) = per_length * l.rz[family][j];                    \
        }                                                                  \
    }
#define SLICE_FORCES_D(j) SLICE_DAMPED(DEPTH, j, l.k_vertical[j], l.c_vertical[j], f0, j, b0, j, DEPTH_FORCE)
#define SLICE_FORCES_D_NONLINEAR(j) \
    SLICE_DAMPED(DEPTH, j, l.k_vertical[j], l.c_effective[j], f0, j, b0, j, DEPTH_FORCE)
            /* depth rising: a = (i, j, k) is the left end; depth falling: a = (i, j+1, k) the right end */
#define SLICE_FORCES_RF(j, rising_right, falling_right)                                                         \
    SLICE_DIAGONAL(DEPTH_RISING, j, l.k_left[j], l.stretch[SLICE_SLOT(DEPTH_RISING, j)], l.k_right[j],          \
                   rising_right, f0, j, b0, j + 1, RISING_FRONT_FORCE, RISING_BACK_FORCE)                       \
    SLICE_DIAGONAL(DEPTH_FALLING, j, l.k_right[j], falling_right, l.k_left[j],                                  \
                   l.stretch[SLICE_SLOT(DEPTH_FALLING, j)], f0, j + 1, b0, j, FALLING_FRONT_FORCE,              \
                   FALLING_BACK_FORCE)
#define SLICE_FORCES_RF_SAME(j) \
    SLICE_FORCES_RF(j, l.stretch[SLICE_SLOT(DEPTH_RISING, j)], l.stretch[SLICE_SLOT(DEPTH_FALLING, j)])
#define SLICE_FORCES_RF_DIFFERENT(j) \
    SLICE_FORCES_RF(j, l.stretch[SLICE_RIGHT_END_SLOT(0, j)], l.stretch[SLICE_RIGHT_END_SLOT(1, j)])
#define SLICE_FORCES_S(j)                           \
    SLICE_SIDE(SIDE_RISING, j, SIDE_RISING_FORCE)   \
    SLICE_SIDE(SIDE_FALLING, j, SIDE_FALLING_FORCE)
            if (l.nonlinear_count) {
                nonlinear_dampers(p, l.nonlinear_count, l.nonlinear, vxf0, along_x ? NULL : vyf0,
                                  along_x ? NULL : vzf0, vxb0, along_x ? NULL : vyb0, along_x ? NULL : vzb0,
                                  l.c_effective);
                SLICE_OVER(cols, even_cols, SLICE_FORCES_D_NONLINEAR)
            } else {
                SLICE_OVER(cols, even_cols, SLICE_FORCES_D)
            }
            if (alphas_differ) {
                SLICE_OVER(links, even_links, SLICE_FORCES_RF_DIFFERENT)
            } else {
                SLICE_OVER(links, even_links, SLICE_FORCES_RF_SAME)
            }
            if (below) SLICE_OVER(cols, even_cols, SLICE_FORCES_S)

            /* 4. gather: the front (a ends) and the back (b ends), each component apart */
#define SLICE_GATHER(j, c, front_force, back_force)                                                            \
    {                                                                                                          \
        front_force[j] += l.carried_front[c][j] + (l.depth[c][j] + l.rising_front[c][j] +                      \
                                                   FALLING_FRONT_FORCE(c, j - 1) + l.side_rising[c][j]);       \
        back_force[j] += back_count * (l.carried_back[c][j] - (l.depth[c][j] + RISING_BACK_FORCE(c, j - 1) +   \
                                                               l.falling_back[c][j] + l.side_falling[c][j]));  \
        l.next_front[c][j] = l.side_falling[c][j];                                                             \
        l.next_back[c][j] = -l.side_rising[c][j];                                                              \
    }
#define SLICE_GATHER_LAST(j, c, front_force, back_force)                                                      \
    {                                                                                                         \
        front_force[j] += carried_count * l.carried_front[c][j] +                                             \
                          (l.depth[c][j] + l.rising_front[c][j] + FALLING_FRONT_FORCE(c, j - 1));             \
        back_force[j] += back_count * (carried_count * l.carried_back[c][j] -                                 \
                                       (l.depth[c][j] + RISING_BACK_FORCE(c, j - 1) + l.falling_back[c][j])); \
    }
#define SLICE_GATHER_X(j) SLICE_GATHER(j, 0, fxf0, fxb0)
#define SLICE_GATHER_Y(j) SLICE_GATHER(j, 1, fyf0, fyb0)
#define SLICE_GATHER_Z(j) SLICE_GATHER(j, 2, fzf0, fzb0)
#define SLICE_GATHER_LAST_X(j) SLICE_GATHER_LAST(j, 0, fxf0, fxb0)
#define SLICE_GATHER_LAST_Y(j) SLICE_GATHER_LAST(j, 1, fyf0, fyb0)
#define SLICE_GATHER_LAST_Z(j) SLICE_GATHER_LAST(j, 2, fzf0, fzb0)
#define SLICE_CARRY(j)                                    \
    {                                                     \
        for (c = 0; c < components; c++) {                \
            l.carried_front[c][j] = l.next_front[c][j];   \
            l.carried_back[c][j] = l.next_back[c][j];     \
        }                                                 \
    }
            if (below) {
                SLICE_OVER(cols, even_cols, SLICE_GATHER_X)
                if (!along_x) {
                    SLICE_OVER(cols, even_cols, SLICE_GATHER_Y)
                    SLICE_OVER(cols, even_cols, SLICE_GATHER_Z)
                }
                SLICE_OVER(cols, even_cols, SLICE_CARRY)
            } else {
                SLICE_OVER(cols, even_cols, SLICE_GATHER_LAST_X)
                if (!along_x) {
                    SLICE_OVER(cols, even_cols, SLICE_GATHER_LAST_Y)
                    SLICE_OVER(cols, even_cols, SLICE_GATHER_LAST_Z)
                }
            }
        }
        add_spring_powers(l.dissipated, l.nonreciprocal, cols, mirror_z ? 2.0 : 1.0, powers);
    }
}

static NOINLINE VECTOR_CLONES void between_slices_general(const LatticeParams *p, const double *u, const double *v,
                                                          double *f, SpringPowers *powers) {
    between_slices(p, 0, 0, 0, p->rows, p->depth, u, v, f, powers);
}

static NOINLINE VECTOR_CLONES void between_slices_along_x(const LatticeParams *p, int mirror_y, int mirror_z,
                                                          int rows, int slices, const double *ux,
                                                          const double *vx, double *fx, SpringPowers *powers) {
    between_slices(p, 1, mirror_y, mirror_z, rows, slices, ux, vx, fx, powers);
}

/* The backplate force over the column-C masses of rows x slices, f = k*rows + i at [f * stride], each counted
 * as often as it stands in the whole lattice (mirror_count). */
static double backplate_force_of_face(const LatticeParams *p, int rows, int slices, int mirror_y, int mirror_z,
                                      const double *ux_last_column, const double *vx_last_column, int stride) {
    double force = 0.0;
    int i, k;
    if (!p->has_backplate) return 0.0;
    for (k = 0; k < slices; k++) {
        for (i = 0; i < rows; i++) {
            const int at = (k * rows + i) * stride;
            const double penetration = ux_last_column[at] - p->backplate_gap - p->back_position;
            if (penetration > 0.0) {
                const double approach = vx_last_column[at] - p->back_velocity;
                const double mass_force = p->k_wall * penetration + p->c_wall * (approach > 0.0 ? approach : 0.0);
                force += mirror_count(mirror_y, mirror_z, rows, slices, i, k) * mass_force;
            }
        }
    }
    return force;
}

double lattice_backplate_force_from_column(const LatticeParams *p, const double *ux_last_column,
                                           const double *vx_last_column, int stride) {
    return backplate_force_of_face(p, p->rows, p->depth, 0, 0, ux_last_column, vx_last_column, stride);
}

double lattice_backplate_force_mirrored(const LatticeParams *p, const double *ux_last_column,
                                        const double *vx_last_column, int stride) {
    const int rows = lattice_mirror_rows(p), slices = lattice_mirror_slices(p);
    return backplate_force_of_face(p, rows ? rows : p->rows, slices ? slices : p->depth, rows != 0, slices != 0,
                                   ux_last_column, vx_last_column, stride);
}

double lattice_backplate_force(const LatticeParams *p, const double *y) {
    const int n = p->rows * p->cols * p->depth;
    return lattice_backplate_force_from_column(p, y + p->cols - 1, y + LATTICE_COMPONENTS(p->depth) * n + p->cols - 1,
                                               p->cols);
}

double lattice_load_weight(const LatticeParams *p, int i, int k) { return load_fraction(p, i, k); }

/* The front port over the face masses of rows x slices (each counted as often as it stands in the whole). */
static void front_port_of_face(const LatticeParams *p, int rows, int slices, int mirror_y, int mirror_z,
                               const double *ux, const double *vx, double *x_front, double *v_front) {
    const int cols = p->cols;
    double x = 0.0, v = 0.0;
    int i, k;
    for (k = 0; k < slices; k++) {
        for (i = 0; i < rows; i++) {
            const int a = (k * rows + i) * cols;
            const double weight = mirror_count(mirror_y, mirror_z, rows, slices, i, k) * load_fraction(p, i, k);
            x += weight * ux[a];
            v += weight * vx[a];
        }
    }
    *x_front = x;
    *v_front = v;
}

void lattice_front_port(const LatticeParams *p, const double *y, double *x_front, double *v_front) {
    const int n = p->rows * p->cols * p->depth;
    front_port_of_face(p, p->rows, p->depth, 0, 0, y, y + LATTICE_COMPONENTS(p->depth) * n, x_front, v_front);
}

void lattice_front_port_along_x(const LatticeParams *p, int mirrored, const double *y, double *x_front,
                                double *v_front) {
    const int mirror_rows = mirrored ? lattice_mirror_rows(p) : 0, mirror_slices = mirrored ? lattice_mirror_slices(p) : 0;
    const int rows = mirror_rows ? mirror_rows : p->rows, slices = mirror_slices ? mirror_slices : p->depth;
    front_port_of_face(p, rows, slices, mirror_rows != 0, mirror_slices != 0, y, y + rows * p->cols * slices, x_front,
                       v_front);
}

/* Potential of one spring: for a non-reciprocal pair, the mean of its two ends' potentials. uz NULL in a
 * lattice of one slice. */
static double spring_energy(const double *ux, const double *uy, const double *uz, int a, int b, int spring_law,
                            SpringEnds ends) {
    const double rx = ux[b] - ux[a], ry = uy[b] - uy[a];
    const double squared = uz ? rx * rx + ry * ry + (uz[b] - uz[a]) * (uz[b] - uz[a]) : rx * rx + ry * ry;
    const double distance = sqrt(squared);
    return 0.5 * (lattice_spring_potential(spring_law, ends.k_a, ends.alpha_a, distance) +
                  lattice_spring_potential(spring_law, ends.k_b, ends.alpha_b, distance));
}

void lattice_energies(const LatticeParams *p, const double *y, double *kinetic, double *potential) {
    const int rows = p->rows, cols = p->cols, slices = p->depth, slice_size = rows * cols, n = slice_size * slices;
    const int components = LATTICE_COMPONENTS(slices), law = p->spring_law;
    const double *ux = y, *uy = y + n, *uz = components == 3 ? y + 2 * n : NULL;
    const double *vx = y + components * n, *vy = vx + n, *vz = components == 3 ? vx + 2 * n : NULL;
    const SpringEnds horizontal = {p->k_horizontal, p->alpha_horizontal, p->k_horizontal, p->alpha_horizontal};
    const int unit = unit_masses(p);
    double speed_squared = 0.0, weighted = 0.0, energy = 0.0; /* sum |v|^2; sum m |v|^2 of unequal masses */
    int i, j, k;
    for (i = 0; i < n; i++) {
        const double squared =
            vz ? vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i] : vx[i] * vx[i] + vy[i] * vy[i];
        if (unit) {
            speed_squared += squared;
        } else {
            weighted += p->column[i % cols].mass * squared;
        }
    }
    for (k = 0; k < slices; k++) {
        for (i = 0; i < rows; i++) {
            for (j = 0; j + 1 < cols; j++) {
                const int a = k * slice_size + i * cols + j;
                energy += spring_energy(ux, uy, uz, a, a + 1, law, horizontal);
            }
        }
    }
    for (k = 0; k < slices; k++) {
        for (j = 0; j < cols; j++) {
            const ColumnConstants *column = &p->column[j];
            const SpringEnds vertical = {column->k, column->alpha, column->k,
                                         column->alpha};
            for (i = 0; i + 1 < rows; i++) {
                const int a = k * slice_size + i * cols + j;
                energy += spring_energy(ux, uy, uz, a, a + cols, law, vertical);
            }
        }
    }
    for (k = 0; k < slices; k++) {
        for (j = 0; j + 1 < cols; j++) {
            const SpringEnds rising = diagonal_ends(p, j), falling = reversed(rising);
            for (i = 0; i + 1 < rows; i++) {
                const int a = k * slice_size + i * cols + j;
                energy += spring_energy(ux, uy, uz, a, a + cols + 1, law, rising);
                energy += spring_energy(ux, uy, uz, a + 1, a + cols, law, falling);
            }
        }
    }
    for (k = 0; k + 1 < slices; k++) { /* between slices k and k+1 (between_slices) */
        for (j = 0; j < cols; j++) {
            const ColumnConstants *column = &p->column[j];
            const SpringEnds depth = {column->k, column->alpha, column->k,
                                      column->alpha};
            const SpringEnds side = {column->k_diag, column->alpha_diag, column->k_diag,
                                     column->alpha_diag};
            for (i = 0; i < rows; i++) {
                const int a = k * slice_size + i * cols + j;
                energy += spring_energy(ux, uy, uz, a, a + slice_size, law, depth);
                if (i + 1 < rows) {
                    energy += spring_energy(ux, uy, uz, a, a + slice_size + cols, law, side);
                    energy += spring_energy(ux, uy, uz, a + cols, a + slice_size, law, side);
                }
            }
        }
        for (j = 0; j + 1 < cols; j++) {
            const SpringEnds rising = diagonal_ends(p, j), falling = reversed(rising);
            for (i = 0; i < rows; i++) {
                const int a = k * slice_size + i * cols + j;
                energy += spring_energy(ux, uy, uz, a, a + slice_size + 1, law, rising);
                energy += spring_energy(ux, uy, uz, a + 1, a + slice_size, law, falling);
            }
        }
    }
    if (p->has_backplate) {
        for (k = 0; k < slices; k++) {
            for (i = 0; i < rows; i++) {
                const double penetration =
                    ux[k * slice_size + i * cols + cols - 1] - p->backplate_gap - p->back_position;
                if (penetration > 0.0) energy += 0.5 * p->k_wall * penetration * penetration;
            }
        }
    }
    *kinetic = unit ? 0.5 * speed_squared : 0.5 * weighted;
    *potential = energy;
}

double lattice_backplate_potential(const LatticeParams *p, const double *y) {
    const int rows = p->rows, cols = p->cols, slice_size = rows * cols;
    double energy = 0.0;
    int i, k;
    if (!p->has_backplate) return 0.0;
    for (k = 0; k < p->depth; k++) {
        for (i = 0; i < rows; i++) {
            const double penetration = y[k * slice_size + i * cols + cols - 1] - p->backplate_gap - p->back_position;
            if (penetration > 0.0) energy += 0.5 * p->k_wall * penetration * penetration;
        }
    }
    return energy;
}
