/* DOP853, the 5(4) pairs and Fine's Nystrom pair (adaptive), RK4 and semi-implicit Euler (fixed step), with dense
 * output. See solver.h. */
#include "solver.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "compiler.h"
#include "dop853_coefficients.h"

/* Step-size control as in SciPy's solve_ivp (Hairer's DOP853 with its norms and safety factors). */
#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
#define DOP853_ERROR_ORDER 7

/* A step that would leave less than this fraction of itself before the limit goes to the limit. */
#define SLIVER 1e-9

/* Workspace rows. */
#define ROW_Y 0
#define ROW_Y_OLD 1
#define ROW_SCRATCH 2
#define ROW_K 3
#define ROW_DENSE (ROW_K + SOLVER_STAGE_ROWS)
#define ROW_WEIGHT (ROW_DENSE + SOLVER_DENSE_ROWS)
#define STAGE_END 12 /* K[12] = f(y_new), the derivative at the end of the last step, in its phase */

static double *row(double *work, int n, int r) { return work + (size_t)r * (size_t)n; }
static const double *row_const(const double *work, int n, int r) { return work + (size_t)r * (size_t)n; }

const double *solver_state(const double *work) { return work + ROW_Y; }

int solver_is_adaptive(int method) {
    return method == SOLVER_DOP853 || method == SOLVER_TSIT5 || method == SOLVER_DOPRI5 ||
           method == SOLVER_RKN5;
}

/* Explicit Runge-Kutta pairs of seven stages whose last is f(y_new) (reused as the next step's first), with a
 * free dense output of degree 4 from the step's own stages: stages 0..5 in K[0..5], the seventh in
 * K[STAGE_END]. e = b - b_hat (the embedded solution), its last weight on f(y_new); the dense output is
 * y(t_old + x h) = y_old + h sum_q b_q(x) k_q with b_q(x) = sum_p dense[q][p] x^(p+1) (b_q(1) = b[q]). */
#define PAIR_STAGES 6 /* in K[0..5]; the seventh is f(y_new) */
typedef struct {
    double a[PAIR_STAGES][PAIR_STAGES], b[PAIR_STAGES], e[PAIR_STAGES + 1], dense[PAIR_STAGES + 1][4];
    int error_order;
} FsalPair;

/* Tsitouras' 5(4) pair (Ch. Tsitouras, Comput. Math. Appl. 62 (2011) 770-775) as diffrax and OrdinaryDiffEq.jl
 * tabulate it, with their interpolation's seven polynomials expanded. */
static const FsalPair TSIT5 = {
    {
    {0.0},
    {0.161},
    {-0.008480655492356988544426874250230774675121177393430391537369234245294192976164141156943,
     0.3354806554923569885444268742502307746751211773934303915373692342452941929761641411569},
    {2.897153057105493432130432594192938764924887287701866490314866693455023795137503079289,
     -6.359448489975074843148159912383825625952700647415626703305928850207288721235210244366,
     4.362295432869581411017727318190886861027813359713760212991062156752264926097707165077},
    {5.325864828439256604428877920840511317836476253097040101202360397727981648835607691791,
     -11.74888356406282787774717033978577296188744178259862899288666928009020615663593781589,
     7.495539342889836208304604784564358155658679161518186721010132816213648793440552049753,
     -0.09249506636175524925650207933207191611349983406029535244034750452930469056411389539635},
    {5.861455442946420028659251486982647890394337666164814434818157239052507339770711679748,
     -12.92096931784710929170611868178335939541780751955743459166312250439928519268343184452,
     8.159367898576158643180400794539253485181918321135053305748355423955009222648673734986,
     -0.07158497328140099722453054252582973869127213147363544882721139659546372402303777878835,
     -0.02826905039406838290900305721271224146717633626879770007617876201276764571291579142206},
},
    {
    0.09646076681806522951816731316512876333711995238157997181903319145764851595234062815396,
    0.01,
    0.4798896504144995747752495322905965199130404621990332488332634944254542060153074523509,
    1.379008574103741893192274821856872770756462643091360525934940067397245698027561293331,
    -3.290069515436080679901047585711363850115683290894936158531296799594813811049925401677,
    2.324710524099773982415355918398765796109060233222962411944060046314465391054716027841},
{
    0.09646076681806522951816731316512876333711995238157997181903319145764851595234062815396 -
        0.09468075576583945807478876255758922856117527357724631226139574065785592789071067303271,
    0.01 - 0.009183565540343253096776363936645313759813746240984095238905939532922955247253608687270,
    0.4798896504144995747752495322905965199130404621990332488332634944254542060153074523509 -
        0.4877705284247615707855642599631228241516691959761363774365216240304071651579571959813,
    1.379008574103741893192274821856872770756462643091360525934940067397245698027561293331 -
        1.234297566930478985655109673884237654035539930748192848315425833500484878378061439761,
    -3.290069515436080679901047585711363850115683290894936158531296799594813811049925401677 +
        2.707712349983525454881109975059321670689605166938197378763992255714444407154902012702,
    2.324710524099773982415355918398765796109060233222962411944060046314465391054716027841 -
        1.866628418170587035753719399566211498666255505244122593996591602841258328965767580089,
    -1.0 / 66.0},
{
    {1.0, -2.763706197274826, 2.9132554618219126, -1.0530884977290216},
    {0.0, 0.1317, -0.2234, 0.1017},
    {0.0, 3.930296236894751, -5.941033872131505, 2.490627285651253},
    {0.0, -12.411077166933676, 30.338188630282318, -16.548102889244902},
    {0.0, 37.50931341651104, -88.1789048947664, 47.37952196281928},
    {0.0, -27.896526289197286, 65.09189467479368, -34.87065786149661},
    {0.0, 1.5, -4.0, 2.5}},
    4};

/* Dormand and Prince's 5(4) pair (J. Comput. Appl. Math. 6 (1980) 19-26) with Shampine's dense output, as
 * SciPy's RK45 tabulates them. */
static const FsalPair DOPRI5 = {
    {{0.0},
     {1.0 / 5.0},
     {3.0 / 40.0, 9.0 / 40.0},
     {44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0},
     {19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0},
     {9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0}},
    {35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0},
    {-71.0 / 57600.0, 0.0, 71.0 / 16695.0, -71.0 / 1920.0, 17253.0 / 339200.0, -22.0 / 525.0, 1.0 / 40.0},
    {{1.0, -8048581381.0 / 2820520608.0, 8663915743.0 / 2820520608.0, -12715105075.0 / 11282082432.0},
     {0.0, 0.0, 0.0, 0.0},
     {0.0, 131558114200.0 / 32700410799.0, -68118460800.0 / 10900136933.0, 87487479700.0 / 32700410799.0},
     {0.0, -1754552775.0 / 470086768.0, 14199869525.0 / 1410260304.0, -10690763975.0 / 1880347072.0},
     {0.0, 127303824393.0 / 49829197408.0, -318862633887.0 / 49829197408.0, 701980252875.0 / 199316789632.0},
     {0.0, -282668133.0 / 205662961.0, 2019193451.0 / 616988883.0, -1453857185.0 / 822651844.0},
     {0.0, 40617522.0 / 29380423.0, -110615467.0 / 29380423.0, 69997945.0 / 29380423.0}},
    4};

static const FsalPair *fsal_pair(int method) { return method == SOLVER_TSIT5 ? &TSIT5 : &DOPRI5; }

/* A general Runge-Kutta-Nystrom pair for x'' = f(x, x') (the lattice's damping makes f depend on x'), seven
 * stages whose last is f(y_new) (reused as the next step's first). Over the solver's state [x (m), v = x' (m),
 * q (the rest: integrals q' = g(x, v))]: stage i is evaluated at X_i = x + c_i h v + h^2 sum_j a_ij A_j,
 * V_i = v + h sum_j abar_ij A_j, Q_i = q + h sum_j abar_ij G_j, where [V_j, A_j, G_j] = f(X_j, V_j, Q_j);
 * the step is x + h v + h^2 sum b_j A_j, v + h sum bp_j A_j, q + h sum bp_j G_j, and the error estimate
 * h^2 sum btilde_j A_j for x, h sum bptilde_j [A_j, G_j] for v and q (the seventh weight on f(y_new)). The
 * positions come twice as accurate per stage as a general pair's: that is what it buys on a mechanical
 * model. Dense output: x by the quintic Hermite through x, v, A at both ends, v by its derivative, q by the
 * cubic Hermite (all free). */
#define NYSTROM_STAGES 7
typedef struct {
    double a[NYSTROM_STAGES][NYSTROM_STAGES - 1], abar[NYSTROM_STAGES][NYSTROM_STAGES - 1];
    double b[NYSTROM_STAGES], bp[NYSTROM_STAGES], btilde[NYSTROM_STAGES], bptilde[NYSTROM_STAGES], c[NYSTROM_STAGES];
} NystromPair;

/* Fine's general RKN 5(4) pair (J. M. Fine, Low order practical Runge-Kutta-Nystrom methods, Computing 38
 * (1987) 281-297), exact rationals as OrdinaryDiffEq.jl tabulates it (FineRKN5Tableau in rkn_tableaus.jl;
 * btilde = b - bhat). bench/method_study.py found it the cheapest of eight methods at the search accuracy. */
static const NystromPair FINE_RKN5 = {
    {
        {0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        {32.0 / 1521.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        {4.0 / 169.0, 4.0 / 169.0, 0.0, 0.0, 0.0, 0.0},
        {175.0 / 5184.0, 0.0, 1625.0 / 5184.0, 0.0, 0.0, 0.0},
        {-342497279.0 / 5618900760.0, 6827067.0 / 46824173.0, 35048741.0 / 102161832.0, -2201514.0 / 234120865.0, 0.0, 0.0},
        {-7079.0 / 52152.0, 767.0 / 2173.0, 14027.0 / 52152.0, 30.0 / 2173.0, 0.0, 0.0},
        {4817.0 / 51600.0, 0.0, 388869.0 / 1216880.0, 3276.0 / 23575.0, -1142053.0 / 22015140.0, 0.0},
    },
    {
        {0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        {8.0 / 39.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        {1.0 / 13.0, 3.0 / 13.0, 0.0, 0.0, 0.0, 0.0},
        {7385.0 / 6912.0, -9425.0 / 2304.0, 13325.0 / 3456.0, 0.0, 0.0, 0.0},
        {223324757.0 / 91364240.0, -174255393.0 / 18272848.0, 382840094.0 / 46824173.0, -39627252.0 / 234120865.0, 0.0, 0.0},
        {108475.0 / 36464.0, -9633.0 / 848.0, 7624604.0 / 806183.0, 8100.0 / 49979.0, -4568212.0 / 19446707.0, 0.0},
        {4817.0 / 51600.0, 0.0, 1685099.0 / 3650640.0, 19656.0 / 23575.0, -53676491.0 / 88060560.0, 53.0 / 240.0},
    },
    {4817.0 / 51600.0, 0.0, 388869.0 / 1216880.0, 3276.0 / 23575.0, -1142053.0 / 22015140.0, 0.0, 0.0}, /* B */
    {4817.0 / 51600.0, 0.0, 1685099.0 / 3650640.0, 19656.0 / 23575.0, -53676491.0 / 88060560.0, 53.0 / 240.0, 0.0}, /* BP */
    {8151.0 / 2633750.0, 0.0, -1377519.0 / 186334750.0, 586872.0 / 28879375.0, -36011118.0 / 2247378875.0, 0.0, 0.0}, /* BTILDE */
    {8151.0 / 2633750.0, 0.0, -5969249.0 / 559004250.0, 3521232.0 / 28879375.0, -846261273.0 / 4494757750.0, 4187.0 / 36750.0, -1.0 / 25.0}, /* BPTILDE */
    {0.0, 8.0 / 39.0, 4.0 / 13.0, 5.0 / 6.0, 43.0 / 47.0, 1.0, 1.0}, /* C */
};

static void evaluate(Solver *s, OdeFunction f, void *context, double t, const double *y, double *dydt) {
    f(context, s->phase, t, y, dydt);
    s->rhs_evaluations++;
}

void solver_init(Solver *s, double *work, int method, int n, int n_second_order, int blocks, double rtol,
                 double atol, double fixed_step, int phase, const double *y0) {
    memset(s, 0, sizeof(*s));
    s->method = method;
    s->n = n;
    s->n_second_order = n_second_order;
    s->block = n / blocks;
    s->rtol = rtol;
    s->atol = atol;
    s->fixed_step = fixed_step;
    s->phase = phase;
    s->norm_size = n;
    memset(work, 0, SOLVER_WORKSPACE_SIZE(n) * sizeof(double));
    memcpy(row(work, n, ROW_Y), y0, (size_t)s->block * sizeof(double));
    memcpy(row(work, n, ROW_Y_OLD), y0, (size_t)s->block * sizeof(double));
}

double *solver_end_derivative(Solver *s, double *work) {
    return s->end_derivative_valid ? row(work, s->n, ROW_K + STAGE_END) : NULL;
}

void solver_set_norm_weights(Solver *s, double *work, const double *weight, double norm_size) {
    memset(row(work, s->n, ROW_WEIGHT), 0, (size_t)s->n * sizeof(double));
    memcpy(row(work, s->n, ROW_WEIGHT), weight, (size_t)s->block * sizeof(double));
    s->weighted = 1;
    s->norm_size = norm_size;
}

/* The weight of component i in the error norms (1 unless solver_set_norm_weights gave others): exact, so an
 * unweighted norm is bit for bit the plain one. */
static double norm_weight(const Solver *s, const double *work, int i) {
    return s->weighted ? work[(size_t)ROW_WEIGHT * (size_t)s->n + (size_t)i] : 1.0;
}

void solver_set_phase(Solver *s, int phase) {
    if (phase != s->phase) {
        s->phase = phase;
        s->end_derivative_valid = 0;
    }
}

/* Root mean square of v_i / scale_i (weighted as the error norms are). */
static double scaled_rms(const Solver *s, const double *work, const double *v, const double *scale) {
    double sum = 0.0;
    int i;
    for (i = 0; i < s->n; i++) sum += norm_weight(s, work, i) * ((v[i] / scale[i]) * (v[i] / scale[i]));
    return sqrt(sum / s->norm_size);
}

/* Hairer's starting step (as SciPy's select_initial_step); K[0] holds f(y0); uses the scratch rows. */
static double initial_step(Solver *s, double *work, OdeFunction f, void *context, double t_span, int error_order) {
    const int n = s->n;
    const double *y0 = row(work, n, ROW_Y), *f0 = row(work, n, ROW_K);
    double *scale = row(work, n, ROW_DENSE), *y1 = row(work, n, ROW_DENSE + 1), *f1 = row(work, n, ROW_DENSE + 2);
    double d0, d1, d2, h0, h1;
    int i;
    for (i = 0; i < n; i++) scale[i] = s->atol + fabs(y0[i]) * s->rtol;
    d0 = scaled_rms(s, work, y0, scale);
    d1 = scaled_rms(s, work, f0, scale);
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > t_span) h0 = t_span;
    for (i = 0; i < n; i++) y1[i] = y0[i] + h0 * f0[i];
    evaluate(s, f, context, s->t + h0, y1, f1);
    for (i = 0; i < n; i++) f1[i] -= f0[i];
    d2 = scaled_rms(s, work, f1, scale) / h0;
    if (d1 <= 1e-15 && d2 <= 1e-15) {
        h1 = fmax(1e-6, h0 * 1e-3);
    } else {
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / (error_order + 1));
    }
    return fmin(100.0 * h0, fmin(h1, t_span));
}

/* out[i] = start + w0 k0[i] + w1 k1[i] + ... for 1 to 4 stage rows, added one after the other, where start
 * is base[i] (first pass), out[i] (the next passes) or nothing (no base: 0 + w0 k0[i] is w0 k0[i]). Each
 * loop runs over an even count, then one element more: at -O2 GCC vectorises a loop only when its trip
 * count is a multiple of the vector length, and RESTRICT tells it the rows do not overlap. Vectorised or
 * not, the arithmetic is the same. */
#define OVER_COMPONENTS(statement)            \
    {                                         \
        const int even = EVEN(n);             \
        int i;                                \
        for (i = 0; i < even; i++) statement; \
        if (i < n) statement;                 \
    }
#define TERMS1 w0 * k0[i]
#define TERMS2 TERMS1 + w1 * k1[i]
#define TERMS3 TERMS2 + w2 * k2[i]
#define TERMS4 TERMS3 + w3 * k3[i]
#define ROWS1 const double *RESTRICT k0, double w0
#define ROWS2 ROWS1, const double *RESTRICT k1, double w1
#define ROWS3 ROWS2, const double *RESTRICT k2, double w2
#define ROWS4 ROWS3, const double *RESTRICT k3, double w3
#define DEFINE_KERNELS(terms)                                                                              \
    static NOINLINE VECTOR_CLONES void from_base##terms(double *RESTRICT out, const double *RESTRICT base, \
                                                        ROWS##terms, int n) {                              \
        OVER_COMPONENTS(out[i] = base[i] + TERMS##terms)                                                   \
    }                                                                                                      \
    static NOINLINE VECTOR_CLONES void from_zero##terms(double *RESTRICT out, ROWS##terms, int n) {        \
        OVER_COMPONENTS(out[i] = TERMS##terms)                                                             \
    }                                                                                                      \
    static NOINLINE VECTOR_CLONES void accumulate##terms(double *RESTRICT out, ROWS##terms, int n) {       \
        OVER_COMPONENTS(out[i] = out[i] + TERMS##terms)                                                    \
    }
DEFINE_KERNELS(1)
DEFINE_KERNELS(2)
DEFINE_KERNELS(3)
DEFINE_KERNELS(4)

/* Two combinations of the same four stage rows at once (the embedded error estimates), each row read once:
 * out_a[i] = start_a + a0 k0[i] + ... + a3 k3[i], out_b likewise, start being nothing (first) or out[i]. */
#define PAIR_TERMS(w) w[0] * k0[i] + w[1] * k1[i] + w[2] * k2[i] + w[3] * k3[i]
static NOINLINE VECTOR_CLONES void pair_from_zero4(double *RESTRICT out_a, double *RESTRICT out_b,
                                                   const double *RESTRICT k0, const double *RESTRICT k1,
                                                   const double *RESTRICT k2, const double *RESTRICT k3,
                                                   const double *RESTRICT a, const double *RESTRICT b, int n) {
    const double a_[4] = {a[0], a[1], a[2], a[3]}, b_[4] = {b[0], b[1], b[2], b[3]};
    OVER_COMPONENTS((out_a[i] = PAIR_TERMS(a_), out_b[i] = PAIR_TERMS(b_)))
}
static NOINLINE VECTOR_CLONES void pair_accumulate4(double *RESTRICT out_a, double *RESTRICT out_b,
                                                    const double *RESTRICT k0, const double *RESTRICT k1,
                                                    const double *RESTRICT k2, const double *RESTRICT k3,
                                                    const double *RESTRICT a, const double *RESTRICT b, int n) {
    const double a_[4] = {a[0], a[1], a[2], a[3]}, b_[4] = {b[0], b[1], b[2], b[3]};
    OVER_COMPONENTS((out_a[i] = out_a[i] + PAIR_TERMS(a_), out_b[i] = out_b[i] + PAIR_TERMS(b_)))
}

/* y_out = base + h * sum_q coefficient[q] K[q] over the q < stages with a non-zero coefficient (base may
 * be NULL for zero), summed in the order of q for every component. This and the right-hand side are where
 * the time goes: the stage rows are added up to four at a time, in passes the compiler vectorises. y_out
 * must not be base or a stage row. */
/* out = base + sum_q w[q] k[q][.] over count components, the rows given as pointers (combine's engine; the
 * Nystrom pair combines parts of rows with it). */
static void combine_rows(double *y_out, const double *base, const double *const *k, const double *w, int used,
                         int n) {
    int q;
    for (q = 0; q < used; q += 4) {
        const int terms = used - q < 4 ? used - q : 4;
        const double *const *r = k + q;
        const double *c = w + q;
        if (q == 0 && base) {
            switch (terms) {
            case 1: from_base1(y_out, base, r[0], c[0], n); break;
            case 2: from_base2(y_out, base, r[0], c[0], r[1], c[1], n); break;
            case 3: from_base3(y_out, base, r[0], c[0], r[1], c[1], r[2], c[2], n); break;
            default: from_base4(y_out, base, r[0], c[0], r[1], c[1], r[2], c[2], r[3], c[3], n); break;
            }
        } else if (q == 0) {
            switch (terms) {
            case 1: from_zero1(y_out, r[0], c[0], n); break;
            case 2: from_zero2(y_out, r[0], c[0], r[1], c[1], n); break;
            case 3: from_zero3(y_out, r[0], c[0], r[1], c[1], r[2], c[2], n); break;
            default: from_zero4(y_out, r[0], c[0], r[1], c[1], r[2], c[2], r[3], c[3], n); break;
            }
        } else {
            switch (terms) {
            case 1: accumulate1(y_out, r[0], c[0], n); break;
            case 2: accumulate2(y_out, r[0], c[0], r[1], c[1], n); break;
            case 3: accumulate3(y_out, r[0], c[0], r[1], c[1], r[2], c[2], n); break;
            default: accumulate4(y_out, r[0], c[0], r[1], c[1], r[2], c[2], r[3], c[3], n); break;
            }
        }
    }
    if (used == 0) {
        if (base) {
            memcpy(y_out, base, (size_t)n * sizeof(double));
        } else {
            memset(y_out, 0, (size_t)n * sizeof(double));
        }
    }
}

static void combine(double *y_out, const double *base, double h, const double *coefficient, int stages,
                    const double *work, int n) {
    const double *k[SOLVER_STAGE_ROWS];
    double w[SOLVER_STAGE_ROWS];
    int used = 0, q;
    for (q = 0; q < stages; q++) {
        if (coefficient[q] == 0.0) continue;
        k[used] = row_const(work, n, ROW_K + q);
        w[used++] = h * coefficient[q];
    }
    combine_rows(y_out, base, k, w, used, n);
}

/* out_a and out_b as combine(out, NULL, 1, coefficient_x, stages, ...) gives them, in one pass per four
 * stage rows, when both coefficient rows have the same zeros and a multiple of four non-zeros (DOP853's
 * E5 and E3: eight); otherwise one combine each. */
static void combine_pair(double *out_a, double *out_b, const double *coefficient_a, const double *coefficient_b,
                         int stages, const double *work, int n) {
    const double *k[SOLVER_STAGE_ROWS];
    double a[SOLVER_STAGE_ROWS], b[SOLVER_STAGE_ROWS];
    int used = 0, same_zeros = 1, q;
    for (q = 0; q < stages; q++) {
        same_zeros = same_zeros && (coefficient_a[q] == 0.0) == (coefficient_b[q] == 0.0);
        if (coefficient_a[q] == 0.0) continue;
        k[used] = row_const(work, n, ROW_K + q);
        a[used] = coefficient_a[q];
        b[used++] = coefficient_b[q];
    }
    if (!same_zeros || used == 0 || used % 4 != 0) {
        combine(out_a, NULL, 1.0, coefficient_a, stages, work, n);
        combine(out_b, NULL, 1.0, coefficient_b, stages, work, n);
        return;
    }
    pair_from_zero4(out_a, out_b, k[0], k[1], k[2], k[3], a, b, n);
    for (q = 4; q < used; q += 4) {
        pair_accumulate4(out_a, out_b, k[q], k[q + 1], k[q + 2], k[q + 3], a + q, b + q, n);
    }
}

static int all_finite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++) {
        if (!isfinite(v[i])) return 0;
    }
    return 1;
}

/* Accepts y_new (in the scratch row) as the state at t + h. */
static void accept(Solver *s, double *work, double h) {
    const int n = s->n;
    memcpy(row(work, n, ROW_Y_OLD), row(work, n, ROW_Y), (size_t)n * sizeof(double));
    memcpy(row(work, n, ROW_Y), row(work, n, ROW_SCRATCH), (size_t)n * sizeof(double));
    s->t_old = s->t;
    s->h_last = h;
    s->t = s->t + h;
    s->dense_power = 0;
    s->steps_accepted++;
}

/* The step that ends on the limit when the proposal reaches it, or would leave only a sliver. */
/* An adaptive step shrunk to rounding: the solution is diverging or too stiff for the tolerances. */
static int step_collapsed(const Solver *s, double h_abs, char *message, size_t message_size) {
    const double min_step = 10.0 * fabs(nextafter(s->t, INFINITY) - s->t);
    if (h_abs >= min_step) return 0;
    snprintf(message, message_size,
             "step size collapsed to %g s at t = %.9g s (the solution is diverging or too stiff for rtol = %g, "
             "atol = %g)",
             h_abs, s->t, s->rtol, s->atol);
    return 1;
}

static double clip_to_limit(double t, double h, double t_limit) {
    if (t + h * (1.0 + SLIVER) >= t_limit) return t_limit - t;
    return h;
}

/* SciPy's step-size control once an attempt has its error norm: an accepted step (1) proposes the next size,
 * a rejected one (0) shrinks h_abs for another attempt. */
static int step_accepted(Solver *s, double error_norm, double error_exponent, const double *y_new, double *h_abs,
                         int *rejected) {
    if (error_norm < 1.0 && all_finite(y_new, s->n)) {
        double factor = error_norm == 0.0 ? MAX_FACTOR : fmin(MAX_FACTOR, SAFETY * pow(error_norm, error_exponent));
        if (*rejected) factor = fmin(1.0, factor);
        s->h_next = *h_abs * factor;
        return 1;
    }
    *h_abs *= isfinite(error_norm) ? fmax(MIN_FACTOR, SAFETY * pow(error_norm, error_exponent)) : MIN_FACTOR;
    *rejected = 1;
    s->steps_rejected++;
    return 0;
}

/* Root mean square of the embedded error estimate over atol + rtol max(|y|, |y_new|), weighted (the 5(4)
 * pairs and the Nystrom pair). */
static double error_norm_of(const Solver *s, const double *work, const double *y, const double *y_new,
                            const double *error) {
    double error_squared = 0.0;
    int i;
    for (i = 0; i < s->n; i++) {
        const double size_old = fabs(y[i]), size_new = fabs(y_new[i]);
        const double scale = s->atol + (size_new > size_old ? size_new : size_old) * s->rtol;
        const double e = error[i] / scale;
        error_squared += norm_weight(s, work, i) * (e * e);
    }
    return sqrt(error_squared / s->norm_size);
}

static int dop853_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                       size_t message_size) {
    const int n = s->n;
    const double *y = row(work, n, ROW_Y);
    double *y_new = row(work, n, ROW_SCRATCH);
    /* the dense rows are free until the step is accepted: the two error estimates go there */
    double *error5 = row(work, n, ROW_DENSE), *error3 = row(work, n, ROW_DENSE + 1);
    const double error_exponent = -1.0 / (DOP853_ERROR_ORDER + 1);
    double h_abs = s->h_next;
    int rejected = 0, stage, i;

    if (h_abs <= 0.0) h_abs = initial_step(s, work, f, context, t_limit - s->t, DOP853_ERROR_ORDER);

    for (;;) {
        double h, err5_squared = 0.0, err3_squared = 0.0, error_norm;
        if (step_collapsed(s, h_abs, message, message_size)) return -1;
        h = clip_to_limit(s->t, h_abs, t_limit);
        h_abs = h;
        for (stage = 1; stage < DOP853_N_STAGES; stage++) {
            combine(y_new, y, h, DOP853_A[stage], stage, work, n);
            evaluate(s, f, context, s->t + DOP853_C[stage] * h, y_new, row(work, n, ROW_K + stage));
        }
        combine(y_new, y, h, DOP853_B, DOP853_N_STAGES, work, n);

        /* the two embedded error estimates, as SciPy's DOP853 combines them; their weights of f(y_new) (E5[12],
         * E3[12]) are zero, so f(y_new) is evaluated only once the step is accepted */
        combine_pair(error5, error3, DOP853_E5, DOP853_E3, DOP853_N_STAGES, work, n);
        for (i = 0; i < n; i++) {
            const double size_old = fabs(y[i]), size_new = fabs(y_new[i]); /* fmax, but not a call */
            const double scale = s->atol + (size_new > size_old ? size_new : size_old) * s->rtol;
            const double err5 = error5[i] / scale, err3 = error3[i] / scale, weight = norm_weight(s, work, i);
            err5_squared += weight * (err5 * err5);
            err3_squared += weight * (err3 * err3);
        }
        if (err5_squared == 0.0 && err3_squared == 0.0) {
            error_norm = 0.0;
        } else {
            error_norm = h * err5_squared / sqrt((err5_squared + 0.01 * err3_squared) * s->norm_size);
        }

        if (step_accepted(s, error_norm, error_exponent, y_new, &h_abs, &rejected)) {
            evaluate(s, f, context, s->t + h, y_new, row(work, n, ROW_K + STAGE_END));
            accept(s, work, h);
            return 0;
        }
    }
}

/* Where stage `stage` of a pair sits in its step, as a fraction of it: the row sum of its coefficients. */
static double stage_fraction(const double *a, int stage) {
    double sum = 0.0;
    int j;
    for (j = 0; j < stage; j++) sum += a[j];
    return sum;
}

/* Tsit5 and DOPRI5, their steps controlled as SciPy's RK45 does (RMS norm of the embedded error over
 * atol + rtol max(|y|, |y_new|), the same safety and factor limits as DOP853). f(y_new) is part of the error
 * estimate, so it is taken for a rejected step too; for an accepted one it is the next step's first stage. */
static int fsal_pair_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                          size_t message_size) {
    const FsalPair *pair = fsal_pair(s->method);
    const int n = s->n;
    const double *y = row(work, n, ROW_Y);
    double *y_new = row(work, n, ROW_SCRATCH), *error = row(work, n, ROW_DENSE);
    const double *f_new = row(work, n, ROW_K + STAGE_END);
    const double error_exponent = -1.0 / (pair->error_order + 1);
    double h_abs = s->h_next;
    int rejected = 0, stage;

    if (h_abs <= 0.0) h_abs = initial_step(s, work, f, context, t_limit - s->t, pair->error_order);

    for (;;) {
        double h;
        if (step_collapsed(s, h_abs, message, message_size)) return -1;
        h = clip_to_limit(s->t, h_abs, t_limit);
        h_abs = h;
        for (stage = 1; stage < PAIR_STAGES; stage++) {
            combine(y_new, y, h, pair->a[stage], stage, work, n);
            evaluate(s, f, context, s->t + stage_fraction(pair->a[stage], stage) * h, y_new,
                     row(work, n, ROW_K + stage));
        }
        combine(y_new, y, h, pair->b, PAIR_STAGES, work, n);
        evaluate(s, f, context, s->t + h, y_new, row(work, n, ROW_K + STAGE_END));
        combine(error, NULL, h, pair->e, PAIR_STAGES, work, n);
        accumulate1(error, f_new, h * pair->e[PAIR_STAGES], n); /* the last weight, on f(y_new) */
        if (step_accepted(s, error_norm_of(s, work, y, y_new, error), error_exponent, y_new, &h_abs, &rejected)) {
            accept(s, work, h);
            return 0;
        }
    }
}

/* One accepted step of the Nystrom pair, its size controlled as the FSAL pairs' (error order 4). */
static int nystrom_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                        size_t message_size) {
    const NystromPair *pair = &FINE_RKN5;
    const int n = s->n, block = s->block, m = s->n_second_order, rest = block - m;
    const double *y = row(work, n, ROW_Y);
    double *y_new = row(work, n, ROW_SCRATCH), *error = row(work, n, ROW_DENSE);
    double *stage_state = row(work, n, ROW_DENSE + 1);
    const double error_exponent = -1.0 / (4 + 1);
    double h_abs = s->h_next;
    int rejected = 0, stage, j, offset;

    if (h_abs <= 0.0) h_abs = initial_step(s, work, f, context, t_limit - s->t, 4);

    for (;;) {
        const double *accelerations[NYSTROM_STAGES + 1]; /* [A_j, G_j] of stage j: the rates of v and q */
        const double *rows[NYSTROM_STAGES + 1];
        double weights[NYSTROM_STAGES + 1], h;
        int used;
        if (step_collapsed(s, h_abs, message, message_size)) return -1;
        h = clip_to_limit(s->t, h_abs, t_limit);
        h_abs = h;
        for (j = 0; j < NYSTROM_STAGES - 1; j++) accelerations[j] = row_const(work, n, ROW_K + j) + m;
        accelerations[NYSTROM_STAGES - 1] = row_const(work, n, ROW_K + STAGE_END) + m;
        for (stage = 1; stage < NYSTROM_STAGES; stage++) {
            const int last = stage == NYSTROM_STAGES - 1; /* the seventh stage is at y_new itself */
            const double *a = last ? pair->b : pair->a[stage], *abar = last ? pair->bp : pair->abar[stage];
            double *out = last ? y_new : stage_state;
            for (offset = 0; offset < n; offset += block) { /* each block a second-order system of its own */
                /* x part: x + c h v + h^2 sum a A */
                rows[0] = y + offset + m;
                weights[0] = (last ? 1.0 : pair->c[stage]) * h;
                used = 1;
                for (j = 0; j < stage && j < NYSTROM_STAGES - 1; j++) {
                    if (a[j] == 0.0) continue;
                    rows[used] = accelerations[j] + offset;
                    weights[used++] = h * h * a[j];
                }
                combine_rows(out + offset, y + offset, rows, weights, used, m);
                /* v and q part: [v, q] + h sum abar [A, G] */
                used = 0;
                for (j = 0; j < stage && j < NYSTROM_STAGES - 1; j++) {
                    if (abar[j] == 0.0) continue;
                    rows[used] = accelerations[j] + offset;
                    weights[used++] = h * abar[j];
                }
                combine_rows(out + offset + m, y + offset + m, rows, weights, used, rest);
            }
            evaluate(s, f, context, s->t + (last ? 1.0 : pair->c[stage]) * h, out,
                     row(work, n, last ? ROW_K + STAGE_END : ROW_K + stage));
        }
        /* the error estimate */
        for (offset = 0; offset < n; offset += block) {
            used = 0;
            for (j = 0; j < NYSTROM_STAGES; j++) {
                if (pair->btilde[j] == 0.0) continue;
                rows[used] = accelerations[j] + offset;
                weights[used++] = h * h * pair->btilde[j];
            }
            combine_rows(error + offset, NULL, rows, weights, used, m);
            used = 0;
            for (j = 0; j < NYSTROM_STAGES; j++) {
                if (pair->bptilde[j] == 0.0) continue;
                rows[used] = accelerations[j] + offset;
                weights[used++] = h * pair->bptilde[j];
            }
            combine_rows(error + offset + m, NULL, rows, weights, used, rest);
        }
        if (step_accepted(s, error_norm_of(s, work, y, y_new, error), error_exponent, y_new, &h_abs, &rejected)) {
            accept(s, work, h);
            return 0;
        }
    }
}

static int fixed_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                      size_t message_size) {
    const int n = s->n, m = s->n_second_order;
    const double *y = row(work, n, ROW_Y);
    const double *k1 = row(work, n, ROW_K);
    double *y_new = row(work, n, ROW_SCRATCH);
    const double h = clip_to_limit(s->t, s->fixed_step, t_limit);
    int i;

    if (s->method == SOLVER_RK4) {
        double *stage_state = row(work, n, ROW_DENSE);
        double *k2 = row(work, n, ROW_K + 1), *k3 = row(work, n, ROW_K + 2), *k4 = row(work, n, ROW_K + 3);
        for (i = 0; i < n; i++) stage_state[i] = y[i] + 0.5 * h * k1[i];
        evaluate(s, f, context, s->t + 0.5 * h, stage_state, k2);
        for (i = 0; i < n; i++) stage_state[i] = y[i] + 0.5 * h * k2[i];
        evaluate(s, f, context, s->t + 0.5 * h, stage_state, k3);
        for (i = 0; i < n; i++) stage_state[i] = y[i] + h * k3[i];
        evaluate(s, f, context, s->t + h, stage_state, k4);
        for (i = 0; i < n; i++) y_new[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    } else {
        /* velocities first with the old forces, then positions with the new velocities (each block) */
        int offset;
        for (offset = 0; offset < n; offset += s->block) {
            for (i = offset + m; i < offset + s->block; i++) y_new[i] = y[i] + h * k1[i];
            for (i = offset; i < offset + m; i++) y_new[i] = y[i] + h * y_new[m + i];
        }
    }
    if (!all_finite(y_new, n)) {
        snprintf(message, message_size,
                 "state became non-finite at t = %.9g s: fixed_step = %g s is beyond the stability limit of "
                 "this solver",
                 s->t + h, s->fixed_step);
        return -1;
    }
    evaluate(s, f, context, s->t + h, y_new, row(work, n, ROW_K + STAGE_END));
    if (s->method == SOLVER_SEMI_IMPLICIT_EULER) {
        /* the work integrals by the trapezoidal rule: the positions moved with the new velocities, so
         * work taken with the old ones alone would lag the kinetic energy by a whole step */
        const double *k_end = row(work, n, ROW_K + STAGE_END);
        int offset;
        for (offset = 0; offset < n; offset += s->block) {
            for (i = offset + 2 * m; i < offset + s->block; i++) y_new[i] = y[i] + 0.5 * h * (k1[i] + k_end[i]);
        }
    }
    accept(s, work, h);
    return 0;
}

int solver_step(Solver *s, double *work, OdeFunction f, void *context, double t_limit, char *message,
                size_t message_size) {
    const int n = s->n;
    if (!(t_limit > s->t)) {
        snprintf(message, message_size, "internal: step requested to t = %.17g from t = %.17g", t_limit, s->t);
        return -1;
    }
    /* K[0] = f(y) in the current phase: reuse the end derivative of the last step when it is still valid. */
    if (s->end_derivative_valid) {
        memcpy(row(work, n, ROW_K), row(work, n, ROW_K + STAGE_END), (size_t)n * sizeof(double));
    } else {
        evaluate(s, f, context, s->t, row(work, n, ROW_Y), row(work, n, ROW_K));
    }
    {
        const int status =
            s->method == SOLVER_DOP853        ? dop853_step(s, work, f, context, t_limit, message, message_size)
            : s->method == SOLVER_RKN5   ? nystrom_step(s, work, f, context, t_limit, message, message_size)
            : solver_is_adaptive(s->method)   ? fsal_pair_step(s, work, f, context, t_limit, message, message_size)
                                            : fixed_step(s, work, f, context, t_limit, message, message_size);
        s->end_derivative_valid = status == 0;
        return status;
    }
}

/* The cubic Hermite part of the dense output (the first three rows of SciPy's dense coefficients). */
static NOINLINE void hermite_coefficients(const double *RESTRICT y_old, const double *RESTRICT y,
                                          const double *RESTRICT f_old, const double *RESTRICT f_new, double h, int n,
                                          double *RESTRICT dense0, double *RESTRICT dense1,
                                          double *RESTRICT dense2) {
    const int even = EVEN(n);
    int i;
    for (i = 0; i < even; i++) {
        const double delta = y[i] - y_old[i];
        dense0[i] = delta;
        dense1[i] = h * f_old[i] - delta;
        dense2[i] = 2.0 * delta - h * (f_new[i] + f_old[i]);
    }
    for (; i < n; i++) {
        const double delta = y[i] - y_old[i];
        dense0[i] = delta;
        dense1[i] = h * f_old[i] - delta;
        dense2[i] = 2.0 * delta - h * (f_new[i] + f_old[i]);
    }
}

void solver_prepare_dense(Solver *s, double *work, OdeFunction f, void *context) {
    const int n = s->n;
    const double h = s->h_last;
    const double *y_old = row(work, n, ROW_Y_OLD), *y = row(work, n, ROW_Y);
    const double *f_old = row(work, n, ROW_K), *f_new = row(work, n, ROW_K + STAGE_END);
    double *dense[SOLVER_DENSE_ROWS];
    int r;
    if (s->dense_power != 0 || s->steps_accepted == 0) return;
    if (s->method == SOLVER_TSIT5 || s->method == SOLVER_DOPRI5) {
        s->dense_power = DENSE_FROM_STAGES; /* free: read from the stage rows, which stay until the next step */
        return;
    }
    for (r = 0; r < SOLVER_DENSE_ROWS; r++) dense[r] = row(work, n, ROW_DENSE + r);
    if (s->method == SOLVER_RKN5) {
        /* x: the quintic Hermite's top coefficients (c3, c4, c5 of x0 + h v0 s + h^2 A0 s^2 / 2 + ...) in the
         * first m entries of the first three rows; q: the cubic Hermite in the entries past 2m */
        const int m = s->n_second_order, block = s->block;
        int i, o;
        for (o = 0; o < n; o += block) { /* each block: its positions, then its rest past 2m */
            for (i = o; i < o + m; i++) {
                const double v0 = y_old[m + i], v1 = y[m + i], a0 = f_old[m + i], a1 = f_new[m + i];
                const double r0 = (y[i] - y_old[i]) - h * v0 - 0.5 * h * h * a0;
                const double r1 = h * (v1 - v0) - h * h * a0, r2 = h * h * (a1 - a0);
                dense[0][i] = 10.0 * r0 - 4.0 * r1 + 0.5 * r2;
                dense[1][i] = -15.0 * r0 + 7.0 * r1 - r2;
                dense[2][i] = 6.0 * r0 - 3.0 * r1 + 0.5 * r2;
            }
            hermite_coefficients(y_old + o + 2 * m, y + o + 2 * m, f_old + o + 2 * m, f_new + o + 2 * m, h,
                                 block - 2 * m, dense[0] + o + 2 * m, dense[1] + o + 2 * m, dense[2] + o + 2 * m);
        }
        s->dense_power = DENSE_NYSTROM;
        return;
    }
    hermite_coefficients(y_old, y, f_old, f_new, h, n, dense[0], dense[1], dense[2]);
    if (s->method != SOLVER_DOP853) {
        s->dense_power = 3; /* cubic Hermite */
        return;
    }
    {
        double *stage_state = row(work, n, ROW_SCRATCH);
        int stage;
        for (stage = DOP853_N_STAGES + 1; stage < DOP853_N_STAGES_EXTENDED; stage++) {
            combine(stage_state, y_old, h, DOP853_A[stage], stage, work, n);
            evaluate(s, f, context, s->t_old + DOP853_C[stage] * h, stage_state, row(work, n, ROW_K + stage));
        }
    }
    for (r = 0; r < DOP853_INTERPOLATOR_POWER - 3; r++) {
        combine(dense[3 + r], NULL, h, DOP853_D[r], DOP853_N_STAGES_EXTENDED, work, n);
    }
    s->dense_power = DOP853_INTERPOLATOR_POWER;
}

/* The weights b_q(x) of a pair's dense output, kept for the last x asked: the model reads many components at
 * one time (the backplate's column, a whole state). Only this cache changes in the Solver a reader holds as
 * const, and it depends on x alone. */
static const double *pair_dense_weights(Solver *s, double x) {
    if (x != s->dense_x || s->dense_weights[PAIR_STAGES + 1] != 1.0) {
        const FsalPair *pair = fsal_pair(s->method);
        int q;
        for (q = 0; q <= PAIR_STAGES; q++) {
            const double *c = pair->dense[q];
            s->dense_weights[q] = (((c[3] * x + c[2]) * x + c[1]) * x + c[0]) * x;
        }
        s->dense_weights[PAIR_STAGES + 1] = 1.0; /* marks the cache filled (a fresh Solver has 0) */
        s->dense_x = x;
    }
    return s->dense_weights;
}

double solver_interpolate(const Solver *s, const double *work, int component, double t) {
    const size_t n = (size_t)s->n, i = (size_t)component;
    const double *dense = work + (size_t)ROW_DENSE * n + i;
    const double x = (t - s->t_old) / s->h_last, x1 = 1.0 - x;
    double value = 0.0;
    int r;
    if (t == s->t) return work[(size_t)ROW_Y * n + i];
    if (s->dense_power == DENSE_NYSTROM) {
        /* within its block (at offset): position or rate of position `position`, or past 2m the rest */
        const size_t block = (size_t)s->block, offset = i / block * block, local = i - offset;
        const size_t m = (size_t)s->n_second_order, position = offset + (local < m ? local : local - m);
        const double *coefficients = work + (size_t)ROW_DENSE * n + position; /* c3, c4, c5 of the position */
        const double h = s->h_last, v0 = work[(size_t)ROW_Y_OLD * n + m + position];
        const double a0 = work[(size_t)ROW_K * n + m + position];
        const double c3 = coefficients[0], c4 = coefficients[n], c5 = coefficients[2 * n];
        if (local >= 2 * m) {
            value = (((dense[2 * n] * x + dense[n]) * x1 + dense[0]) * x);
            return work[(size_t)ROW_Y_OLD * n + i] + value;
        }
        if (local < m) {
            return work[(size_t)ROW_Y_OLD * n + i] +
                   x * (h * v0 + x * (0.5 * h * h * a0 + x * (c3 + x * (c4 + x * c5))));
        }
        return v0 + x * (h * a0 + x * (3.0 * c3 + x * (4.0 * c4 + x * 5.0 * c5)) / h);
    }
    if (s->dense_power == DENSE_FROM_STAGES) {
        const double *k = work + (size_t)ROW_K * n + i, *w = pair_dense_weights((Solver *)s, x);
        double sum = 0.0;
        int q;
        for (q = 0; q < PAIR_STAGES; q++) sum += w[q] * k[(size_t)q * n];
        sum += w[PAIR_STAGES] * k[(size_t)STAGE_END * n];
        return work[(size_t)ROW_Y_OLD * n + i] + s->h_last * sum;
    }
    /* SciPy's evaluation of the dense output: from the highest row down, add the row, then multiply by x
     * (even rows) or 1 - x (odd rows); spelled out for the usual powers */
    switch (s->dense_power) {
    case 7:
        value = (((((((value + dense[6 * n]) * x + dense[5 * n]) * x1 + dense[4 * n]) * x + dense[3 * n]) * x1 +
                   dense[2 * n]) * x + dense[n]) * x1 + dense[0]) * x;
        break;
    case 3:
        value = (((value + dense[2 * n]) * x + dense[n]) * x1 + dense[0]) * x;
        break;
    default:
        for (r = s->dense_power - 1; r >= 0; r--) {
            value += dense[(size_t)r * n];
            value *= (r % 2 == 0) ? x : x1;
        }
        break;
    }
    return work[(size_t)ROW_Y_OLD * n + i] + value;
}

void solver_truncate(Solver *s, double *work, OdeFunction f, void *context, double t_end) {
    const int n = s->n;
    double *scratch = row(work, n, ROW_SCRATCH);
    int i;
    if (t_end >= s->t) return;
    solver_prepare_dense(s, work, f, context);
    if (s->dense_power == DENSE_FROM_STAGES) {
        /* the whole state at once: the stage rows combined as a step's are (same weights as interpolation) */
        const double *w = pair_dense_weights(s, (t_end - s->t_old) / s->h_last);
        combine(scratch, row(work, n, ROW_Y_OLD), s->h_last, w, PAIR_STAGES, work, n);
        accumulate1(scratch, row(work, n, ROW_K + STAGE_END), s->h_last * w[PAIR_STAGES], n);
    } else {
        for (i = 0; i < n; i++) scratch[i] = solver_interpolate(s, work, i, t_end);
    }
    memcpy(row(work, n, ROW_Y), scratch, (size_t)n * sizeof(double));
    s->t = t_end;
    s->end_derivative_valid = 0; /* f at the new end is taken afresh, in the new mode */
}

double solver_interpolate_hermite(const Solver *s, const double *work, int component, double t) {
    const size_t n = (size_t)s->n, i = (size_t)component;
    const double h = s->h_last, x = (t - s->t_old) / h;
    double y_old, delta, f_old, f_new;
    if (s->dense_power != 0) return solver_interpolate(s, work, component, t); /* also after a truncation */
    y_old = work[ROW_Y_OLD * n + i];
    delta = work[ROW_Y * n + i] - y_old;
    f_old = work[ROW_K * n + i];
    f_new = work[(ROW_K + STAGE_END) * n + i];
    return y_old + x * (delta + (1.0 - x) * ((h * f_old - delta) + x * (2.0 * delta - h * (f_new + f_old))));
}
