/* The hull as a model of the FMI glue (docs/model.md section 11): the body the armour is mounted on, a mass m on
 * a spring k and a damper c to the ground, pushed by the backplate force F:
 *
 *     m x'' = F - k x - c x'
 *
 * It implements the model API (common/model_api.h) in model.c, on the code every component shares
 * (common/component_model.c); its variables are fmu_src/hull/variables.py's table (model_variables.h,
 * generated). Co-Simulation holds F over each communication step, or extrapolates it linearly with the derivative
 * a master sets (model_set_input_derivative), and integrates the step with classic RK4 in substeps short against
 * the hull's own time scales; model_get_output_derivative gives its outputs' (its states') derivatives at the
 * communication point.
 *
 * Its continuous-time contract: the states x, v and the damper's dissipated energy, no discrete states, no event
 * indicators.
 */
#ifndef HULL_MODEL_H
#define HULL_MODEL_H

#include "model_api.h"

#endif
