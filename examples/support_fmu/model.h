/* BackplateSupport as a model of the shared FMI glue (fmu_src/common, fmi2/): the body the backplate is mounted
 * on, one mass on a spring and a damper to the ground, pushed by the force the lattice puts on its backplate:
 *
 *     m x'' = F - k x - c x'        F_support = k x + c x'  (the force passed on to what is behind)
 *
 * It implements the model API (model_api.h) in model.c. Value references:
 *   0 m, 1 k, 2 c, 3 max_substep (parameters), 4 F (input), 5 x, 6 v, 7 F_support (outputs).
 * Co-Simulation holds F over each communication step (what a co-simulation master gives it) and integrates the
 * step with classic RK4 in substeps of at most max_substep. Its continuous-time contract: the states x and v,
 * no discrete states, no event indicators.
 */
#ifndef SUPPORT_MODEL_H
#define SUPPORT_MODEL_H

#include "model_api.h"

enum { VR_M, VR_K, VR_C, VR_MAX_SUBSTEP, VR_F, VR_X, VR_V, VR_F_SUPPORT, N_VALUE_REFERENCES };

#endif
