/* The physics of docs/model.md: springs, damping, load, backplate. See lattice.h for the state layout. */
#include "lattice.h"

#include <math.h>
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

/* Weight of row i (0-based) in the load: 1/2 for the first and last rows, 1 for the others, normalised. */
static double row_load_fraction(int rows, int i) {
    if (rows == 1) return 1.0;
    return ((i == 0 || i == rows - 1) ? 0.5 : 1.0) / (double)(rows - 1); /* the weights sum to rows - 1 */
}

/* The two diagonals between columns j and j+1 use these ends: the one in column j, the one in j+1. */
static SpringEnds diagonal_ends(const LatticeParams *p, int j) {
    const ColumnConstants *left = &p->column[j], *right = &p->column[j + 1];
    return spring_ends(p->diagonal_rule, left->k_diag, left->alpha_diag, right->k_diag, right->alpha_diag);
}

static SpringEnds reversed(SpringEnds ends) {
    const SpringEnds swapped = {ends.k_b, ends.alpha_b, ends.k_a, ends.alpha_a};
    return swapped;
}

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
 * so a build at -O3 gives the same numbers as one at -O2. */

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
 * (x, y): one object, so the compiler addresses them all from one register. The forces are all stored at
 * [j] (stores at [j + 1] would keep GCC from vectorising); the gather reads some at [j - 1], where a zero
 * guard stands for the spring that does not exist left of column 0 (those arrays start two elements into
 * their storage, keeping the alignment), and others at [cols - 1], where a zero guard stands for the one
 * right of the last column. */
typedef struct {
    double rx[FAMILIES][LATTICE_MAX_COLS], ry[FAMILIES][LATTICE_MAX_COLS];
    /* packed by SLOT; a diagonal's left end is the one in column j, its right end the one in j+1 */
    double squared[PACKED_SPRINGS], alpha[PACKED_SPRINGS], stretch[PACKED_SPRINGS], inverse[PACKED_SPRINGS];
    double k_vertical[LATTICE_MAX_COLS], c_vertical[LATTICE_MAX_COLS], k_left[LATTICE_MAX_COLS],
        k_right[LATTICE_MAX_COLS];
    double dissipated[LATTICE_MAX_COLS], nonreciprocal[LATTICE_MAX_COLS]; /* powers, summed by column */
    double horizontal[2][LATTICE_MAX_COLS + 2], rising_bottom[2][LATTICE_MAX_COLS + 2],
        falling_top[2][LATTICE_MAX_COLS + 2];
    double vertical[2][LATTICE_MAX_COLS], rising_top[2][LATTICE_MAX_COLS], falling_bottom[2][LATTICE_MAX_COLS];
    /* what the springs from the row above do to a row, and what this row's do to the next */
    double carried[2][LATTICE_MAX_COLS], next[2][LATTICE_MAX_COLS];
} RowBuffers;

/* the arrays with a guard at [-1] */
#define HORIZONTAL_FORCE(c, j) w.horizontal[c][(j) + 2]
#define RISING_BOTTOM_FORCE(c, j) w.rising_bottom[c][(j) + 2]
#define FALLING_TOP_FORCE(c, j) w.falling_top[c][(j) + 2]

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
    if (along_x) {
        packed_stretches_x(linear, w->squared, w->alpha, count, w->stretch, w->inverse);
    } else {
        packed_stretches(linear, w->squared, w->alpha, count, w->stretch, w->inverse);
    }
}

/* The buffers' per-lattice part (column constants, alphas, the zero guards and accumulators) for rhs_rows and
 * rhs_rows_along_x; returns whether some diagonal's right end needs an exponential of its own. */
static int prepare_row_buffers(const LatticeParams *p, RowBuffers *w) {
    const int cols = p->cols, links = cols - 1;
    int alphas_differ = 0, j, c;
    for (j = 0; j < cols; j++) {
        const ColumnConstants *column = &p->column[j];
        w->k_vertical[j] = column->k;
        w->c_vertical[j] = column->c;
        w->alpha[SLOT(VERTICAL, j)] = column->alpha;
        w->carried[0][j] = w->carried[1][j] = 0.0;
        w->dissipated[j] = w->nonreciprocal[j] = 0.0;
    }
    for (j = 0; j < links; j++) {
        const SpringEnds ends = diagonal_ends(p, j);
        w->alpha[SLOT(HORIZONTAL, j)] = p->alpha_horizontal;
        w->alpha[SLOT(RISING, j)] = w->alpha[SLOT(FALLING, j)] = ends.alpha_a;
        w->alpha[RIGHT_END_SLOT(0, j)] = w->alpha[RIGHT_END_SLOT(1, j)] = ends.alpha_b;
        w->k_left[j] = ends.k_a;
        w->k_right[j] = ends.k_b;
        alphas_differ = alphas_differ || ends.alpha_a != ends.alpha_b;
    }
    for (c = 0; c < 2; c++) { /* the guards: the springs left of column 0 and right of the last */
        w->horizontal[c][1] = w->horizontal[c][links + 2] = 0.0;
        w->rising_top[c][links] = w->rising_bottom[c][1] = 0.0;
        w->falling_top[c][1] = w->falling_bottom[c][links] = 0.0;
    }
    return alphas_differ;
}

/* Before the middle row of a mirrored half: every spring so far has a mirror image below the middle row, so
 * the powers summed so far count twice. */
static void count_mirror_images(RowBuffers *w, int cols) {
    int j;
    for (j = 0; j < cols; j++) {
        w->dissipated[j] *= 2.0;
        w->nonreciprocal[j] *= 2.0;
    }
}

/* What acts beyond the springs, after the rows: the springs' powers summed by column, the load on column 1,
 * the backplate on column C, the mass; the powers into powers[0..3) (W_ext, D, W_nr). Rows counted twice
 * but the middle one when mirrored; vy and fy NULL along x. */
static void external_forces(const LatticeParams *p, int mirrored, int rows, int load_on, const signed char *wall_mode,
                            const double *ux, const double *vx, const double *vy, double *fx, double *fy,
                            const RowBuffers *w, double *powers) {
    const int cols = p->cols, n = rows * cols;
    double power_external = 0.0, power_dissipated = 0.0, power_nonreciprocal = 0.0;
    int i, j;
    for (j = 0; j < cols; j++) {
        power_dissipated += w->dissipated[j];
        power_nonreciprocal += w->nonreciprocal[j];
    }

    if (load_on) {
        const double angle = p->load_angle_deg * (M_PI / 180.0);
        const double cos_angle = cos(angle), sin_angle = sin(angle);
        for (i = 0; i < rows; i++) {
            const int a = i * cols;
            const double share = p->load_total * row_load_fraction(p->rows, i);
            const double counted = mirrored && i + 1 < rows ? 2.0 : 1.0; /* a row and its mirror image */
            fx[a] += share * cos_angle;
            if (fy) {
                fy[a] += share * sin_angle;
                power_external += counted * (share * (cos_angle * vx[a] + sin_angle * vy[a]));
            } else {
                power_external += counted * (share * (cos_angle * vx[a]));
            }
        }
    }

    if (p->has_backplate) {
        for (i = 0; i < rows; i++) {
            const int a = i * cols + cols - 1;
            const double penetration = ux[a] - p->backplate_gap;
            const int mode = wall_mode ? wall_mode[i] : lattice_wall_mode(p, ux[a], vx[a]);
            if (mode != WALL_FREE) {
                const double damped_velocity = mode == WALL_APPROACHING ? vx[a] : 0.0;
                const double counted = mirrored && i + 1 < rows ? 2.0 : 1.0;
                fx[a] -= p->k_wall * penetration + p->c_wall * damped_velocity;
                power_dissipated += counted * (p->c_wall * damped_velocity * vx[a]);
            }
        }
    }

    if (p->mass != 1.0) { /* (multiplying by 1 changes nothing) */
        const double inverse_mass = 1.0 / p->mass;
        for (i = 0; i < n; i++) fx[i] *= inverse_mass;
        if (fy) {
            for (i = 0; i < n; i++) fy[i] *= inverse_mass;
        }
    }
    powers[0] = power_external;
    powers[1] = power_dissipated;
    powers[2] = power_nonreciprocal;
}

int lattice_wall_mode(const LatticeParams *p, double ux, double vx) {
    if (!p->has_backplate || ux - p->backplate_gap <= 0.0) return WALL_FREE;
    return vx > 0.0 ? WALL_APPROACHING : WALL_RECEDING;
}

int lattice_mirror_rows(const LatticeParams *p) {
    const int symmetric_load = p->load_angle_deg == 0.0 || p->load_total == 0.0;
    return (p->rows >= 3 && p->rows % 2 == 1 && symmetric_load) ? (p->rows + 1) / 2 : 0;
}

/* The right-hand side of the whole lattice. */
static VECTOR_CLONES void rhs_rows(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y,
                                   double *dydt) {
    const int rows = p->rows, cols = p->cols, n = rows * cols;
    const int linear = p->spring_law == SPRING_LINEAR;
    const int links = cols - 1; /* horizontal springs in a row, and rising (falling) diagonals below it */
    const int even_links = EVEN(links), even_cols = EVEN(cols);
    const double *ux = y, *uy = y + n, *vx = y + 2 * n, *vy = y + 3 * n;
    double *fx = dydt + 2 * n, *fy = dydt + 3 * n;
    const double k_horizontal = p->k_horizontal, c_horizontal = p->c_horizontal;
    int alphas_differ; /* some diagonal's right end needs an exponential of its own */
    RowBuffers w;
    int i, j;

    alphas_differ = prepare_row_buffers(p, &w);

    memcpy(dydt, vx, (size_t)n * sizeof(double));
    memcpy(dydt + n, vy, (size_t)n * sizeof(double));

    for (i = 0; i < rows; i++) {
        const size_t top = (size_t)i * (size_t)cols, bottom = top + (size_t)cols;
        const double *ux0 = ux + top, *uy0 = uy + top, *vx0 = vx + top, *vy0 = vy + top;
        const double *ux1 = ux + bottom, *uy1 = uy + bottom, *vx1 = vx + bottom, *vy1 = vy + bottom;
        double *row_fx = fx + top, *row_fy = fy + top;

        /* 1. geometry */
#define GEOMETRY(family, j, ax, ay, bx, by)              \
    {                                                    \
        const double dx = (bx) - (ax), dy = (by) - (ay); \
        w.rx[family][j] = dx;                            \
        w.ry[family][j] = dy;                            \
        w.squared[SLOT(family, j)] = dx * dx + dy * dy;  \
    }
#define GEOMETRY_H(j) GEOMETRY(HORIZONTAL, j, ux0[j], uy0[j], ux0[j + 1], uy0[j + 1])
#define GEOMETRY_HRF(j)                                             \
    GEOMETRY(HORIZONTAL, j, ux0[j], uy0[j], ux0[j + 1], uy0[j + 1]) \
    GEOMETRY(RISING, j, ux0[j], uy0[j], ux1[j + 1], uy1[j + 1])     \
    GEOMETRY(FALLING, j, ux0[j + 1], uy0[j + 1], ux1[j], uy1[j])
#define GEOMETRY_V(j) GEOMETRY(VERTICAL, j, ux0[j], uy0[j], ux1[j], uy1[j])
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
#define DAMPED(family, j, k, c, avx, avy, bvx, bvy, out_x, out_y)                                \
    {                                                                                            \
        const double per_length = (k) * w.stretch[SLOT(family, j)] * w.inverse[SLOT(family, j)]; \
        const double dvx = (bvx) - (avx), dvy = (bvy) - (avy);                                   \
        out_x = per_length * w.rx[family][j] + (c) * dvx;                                        \
        out_y = per_length * w.ry[family][j] + (c) * dvy;                                        \
        w.dissipated[j] += (c) * (dvx * dvx + dvy * dvy);                                        \
    }
#define DIAGONAL(family, j, k_a, stretch_a, k_b, stretch_b, avx, avy, bvx, bvy, a_x, a_y, b_x, b_y)  \
    {                                                                                                \
        const double per_length_a = (k_a) * (stretch_a) * w.inverse[SLOT(family, j)];                \
        const double per_length_b = (k_b) * (stretch_b) * w.inverse[SLOT(family, j)];                \
        a_x = per_length_a * w.rx[family][j];                                                        \
        a_y = per_length_a * w.ry[family][j];                                                        \
        b_x = per_length_b * w.rx[family][j];                                                        \
        b_y = per_length_b * w.ry[family][j];                                                        \
        w.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) *                                  \
                            (w.rx[family][j] * ((avx) + (bvx)) + w.ry[family][j] * ((avy) + (bvy))); \
    }
#define FORCES_H(j)                                                                           \
    DAMPED(HORIZONTAL, j, k_horizontal, c_horizontal, vx0[j], vy0[j], vx0[j + 1], vy0[j + 1], \
           HORIZONTAL_FORCE(0, j), HORIZONTAL_FORCE(1, j))
        /* rising: a = (i, j) is the left end, b = (i+1, j+1) the right; falling: a = (i, j+1) is the
         * right end, b = (i+1, j) the left (a right end's stretch is the left one's unless the alphas
         * differ) */
#define FORCES_HRF(j, rising_right, falling_right)                                                           \
    FORCES_H(j)                                                                                              \
    DIAGONAL(RISING, j, w.k_left[j], w.stretch[SLOT(RISING, j)], w.k_right[j], rising_right, vx0[j], vy0[j], \
             vx1[j + 1], vy1[j + 1], w.rising_top[0][j], w.rising_top[1][j], RISING_BOTTOM_FORCE(0, j),      \
             RISING_BOTTOM_FORCE(1, j))                                                                      \
    DIAGONAL(FALLING, j, w.k_right[j], falling_right, w.k_left[j], w.stretch[SLOT(FALLING, j)], vx0[j + 1],  \
             vy0[j + 1], vx1[j], vy1[j], FALLING_TOP_FORCE(0, j), FALLING_TOP_FORCE(1, j),                   \
             w.falling_bottom[0][j], w.falling_bottom[1][j])
#define FORCES_HRF_SAME(j) FORCES_HRF(j, w.stretch[SLOT(RISING, j)], w.stretch[SLOT(FALLING, j)])
#define FORCES_HRF_DIFFERENT(j) FORCES_HRF(j, w.stretch[RIGHT_END_SLOT(0, j)], w.stretch[RIGHT_END_SLOT(1, j)])
#define FORCES_V(j)                                                                                         \
    DAMPED(VERTICAL, j, w.k_vertical[j], w.c_vertical[j], vx0[j], vy0[j], vx1[j], vy1[j], w.vertical[0][j], \
           w.vertical[1][j])
        if (i + 1 < rows) {
            if (alphas_differ) {
                OVER(links, even_links, FORCES_HRF_DIFFERENT)
            } else {
                OVER(links, even_links, FORCES_HRF_SAME)
            }
            OVER(cols, even_cols, FORCES_V)
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
#define GATHER_LAST_X(j) row_fx[j] = w.carried[0][j] + (HORIZONTAL_FORCE(0, j) - HORIZONTAL_FORCE(0, j - 1));
#define GATHER_LAST_Y(j) row_fy[j] = w.carried[1][j] + (HORIZONTAL_FORCE(1, j) - HORIZONTAL_FORCE(1, j - 1));
        if (i + 1 < rows) {
            OVER(cols, even_cols, GATHER_X) /* x and y apart: the compiler cannot tell fx and fy apart */
            OVER(cols, even_cols, GATHER_Y)
#define CARRY(j)                        \
    {                                   \
        w.carried[0][j] = w.next[0][j]; \
        w.carried[1][j] = w.next[1][j]; \
    }
            OVER(cols, even_cols, CARRY)
        } else {
            OVER(cols, even_cols, GATHER_LAST_X)
            OVER(cols, even_cols, GATHER_LAST_Y)
        }
    }
    external_forces(p, 0, rows, load_on, wall_mode, ux, vx, vy, fx, fy, &w, dydt + 4 * n);
}

int lattice_along_x(const LatticeParams *p) { return p->load_angle_deg == 0.0 || p->load_total == 0.0; }

/* The right-hand side over the layout without y (lattice_along_x): rhs_rows with every y part left out, the
 * same arithmetic on what is left (|r| = |dx|, which is what sqrt(dx^2) gives), and the same four stages (see
 * above rhs_rows). With mirrored, of the upper half of a mirror-symmetric lattice (rows 0 .. (R-1)/2, the
 * last of them the middle row; see lattice.h): the rows above the middle are computed as the whole does,
 * what the springs below the middle row do to it is the mirror image of what those above it do, and every
 * power but the middle row's own springs' counts twice. */
static VECTOR_CLONES void rhs_rows_along_x(const LatticeParams *p, int mirrored, int load_on,
                                           const signed char *wall_mode, const double *y, double *dydt) {
    const int rows = mirrored ? (p->rows + 1) / 2 : p->rows, cols = p->cols, n = rows * cols;
    const int linear = p->spring_law == SPRING_LINEAR;
    const int links = cols - 1;
    const int even_links = EVEN(links), even_cols = EVEN(cols);
    const double *ux = y, *vx = y + n;
    double *fx = dydt + n;
    const double k_horizontal = p->k_horizontal, c_horizontal = p->c_horizontal;
    int alphas_differ;
    RowBuffers w;
    int i, j;

    alphas_differ = prepare_row_buffers(p, &w);

    memcpy(dydt, vx, (size_t)n * sizeof(double));

    for (i = 0; i < rows; i++) {
        const size_t top = (size_t)i * (size_t)cols, bottom = top + (size_t)cols;
        const double *ux0 = ux + top, *vx0 = vx + top, *ux1 = ux + bottom, *vx1 = vx + bottom;
        double *row_fx = fx + top;
        if (mirrored && i + 1 == rows) count_mirror_images(&w, cols);

        /* 1. geometry: r = (dx, 0) */
#define GEOMETRY_X(family, j, ax, bx)                 \
    {                                                 \
        const double dx = (bx) - (ax);                \
        w.rx[family][j] = dx;                         \
        w.squared[SLOT(family, j)] = dx; /* dx itself: packed_stretches_x */ \
    }
#define GEOMETRY_X_H(j) GEOMETRY_X(HORIZONTAL, j, ux0[j], ux0[j + 1])
#define GEOMETRY_X_HRF(j)                               \
    GEOMETRY_X(HORIZONTAL, j, ux0[j], ux0[j + 1])       \
    GEOMETRY_X(RISING, j, ux0[j], ux1[j + 1])           \
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
#define DIAGONAL_X(family, j, k_a, stretch_a, k_b, stretch_b, avx, bvx, a_x, b_x)                   \
    {                                                                                               \
        const double per_length_a = (k_a) * (stretch_a) * w.inverse[SLOT(family, j)];               \
        const double per_length_b = (k_b) * (stretch_b) * w.inverse[SLOT(family, j)];               \
        a_x = per_length_a * w.rx[family][j];                                                       \
        b_x = per_length_b * w.rx[family][j];                                                       \
        w.nonreciprocal[j] += 0.5 * (per_length_a - per_length_b) * (w.rx[family][j] * ((avx) + (bvx))); \
    }
#define FORCES_X_H(j) DAMPED_X(HORIZONTAL, j, k_horizontal, c_horizontal, vx0[j], vx0[j + 1], HORIZONTAL_FORCE(0, j))
#define FORCES_X_HRF(j, rising_right, falling_right)                                                        \
    FORCES_X_H(j)                                                                                           \
    DIAGONAL_X(RISING, j, w.k_left[j], w.stretch[SLOT(RISING, j)], w.k_right[j], rising_right, vx0[j],      \
               vx1[j + 1], w.rising_top[0][j], RISING_BOTTOM_FORCE(0, j))                                   \
    DIAGONAL_X(FALLING, j, w.k_right[j], falling_right, w.k_left[j], w.stretch[SLOT(FALLING, j)], vx0[j + 1], \
               vx1[j], FALLING_TOP_FORCE(0, j), w.falling_bottom[0][j])
#define FORCES_X_HRF_SAME(j) FORCES_X_HRF(j, w.stretch[SLOT(RISING, j)], w.stretch[SLOT(FALLING, j)])
#define FORCES_X_HRF_DIFFERENT(j) \
    FORCES_X_HRF(j, w.stretch[RIGHT_END_SLOT(0, j)], w.stretch[RIGHT_END_SLOT(1, j)])
#define FORCES_X_V(j) DAMPED_X(VERTICAL, j, w.k_vertical[j], w.c_vertical[j], vx0[j], vx1[j], w.vertical[0][j])
        if (i + 1 < rows) {
            if (alphas_differ) {
                OVER(links, even_links, FORCES_X_HRF_DIFFERENT)
            } else {
                OVER(links, even_links, FORCES_X_HRF_SAME)
            }
            OVER(cols, even_cols, FORCES_X_V)
        } else {
            OVER(links, even_links, FORCES_X_H)
        }

        /* 4. gather */
        if (i + 1 < rows) {
            OVER(cols, even_cols, GATHER_X)
#define CARRY_X(j) w.carried[0][j] = w.next[0][j];
            OVER(cols, even_cols, CARRY_X)
        } else if (mirrored) {
#define GATHER_MIDDLE_ALONG_X(j) \
    row_fx[j] = w.carried[0][j] + (HORIZONTAL_FORCE(0, j) - HORIZONTAL_FORCE(0, j - 1)) + w.carried[0][j];
            OVER(cols, even_cols, GATHER_MIDDLE_ALONG_X)
        } else {
            OVER(cols, even_cols, GATHER_LAST_X)
        }
    }
    external_forces(p, mirrored, rows, load_on, wall_mode, ux, vx, NULL, fx, NULL, &w, dydt + 2 * n);
}

void lattice_rhs_along_x(const LatticeParams *p, int mirrored, int load_on, const signed char *wall_mode,
                         const double *y, double *dydt) {
    rhs_rows_along_x(p, mirrored, load_on, wall_mode, y, dydt);
}

void lattice_rhs(const LatticeParams *p, int load_on, const signed char *wall_mode, const double *y, double *dydt) {
    rhs_rows(p, load_on, wall_mode, y, dydt);
}

static double backplate_force_of_rows(const LatticeParams *p, int rows, int mirrored, const double *ux_last_column,
                                      const double *vx_last_column, int stride) {
    double force = 0.0;
    int i;
    if (!p->has_backplate) return 0.0;
    for (i = 0; i < rows; i++) {
        const double penetration = ux_last_column[i * stride] - p->backplate_gap;
        if (penetration > 0.0) {
            const double vx = vx_last_column[i * stride];
            const double row_force = p->k_wall * penetration + p->c_wall * (vx > 0.0 ? vx : 0.0);
            force += mirrored && i + 1 < rows ? 2.0 * row_force : row_force;
        }
    }
    return force;
}

double lattice_backplate_force_from_column(const LatticeParams *p, const double *ux_last_column,
                                           const double *vx_last_column, int stride) {
    return backplate_force_of_rows(p, p->rows, 0, ux_last_column, vx_last_column, stride);
}

double lattice_backplate_force_mirrored(const LatticeParams *p, const double *ux_last_column,
                                        const double *vx_last_column, int stride) {
    return backplate_force_of_rows(p, (p->rows + 1) / 2, 1, ux_last_column, vx_last_column, stride);
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
        const SpringEnds vertical = {column->k, column->alpha, column->k,
                                     column->alpha};
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
