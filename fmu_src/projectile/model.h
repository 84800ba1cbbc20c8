/* The projectile as a model of the FMI glue (docs/model.md section 11): a rigid body of mass projectile_mass
 * moving along +x, touching the lattice's loaded face at t = 0 (position 0) at projectile_speed, with
 * Hunt-Crossley contact against the face at x_front moving at v_front:
 *
 *     delta = x_p - x_front,  delta' = v_p - v_front,
 *     F_c = max(k_c delta^n (1 + lambda delta'), 0) for delta > 0, else 0;   mass x_p'' = -F_c
 *
 * It implements the model API (common/model_api.h) in model.c, on the code every component shares
 * (common/component_model.c); its variables are fmu_src/projectile/variables.py's table (model_variables.h,
 * generated).
 *
 * Co-Simulation: over a communication step [t0, t0 + H] the face is extrapolated from the inputs,
 * x_f = x_front + s tau + a tau^2 / 2 and v_f = v_front + a tau (tau = t - t0; s = v_front, or the derivative of
 * x_front a master sets; a the derivative of v_front a master sets, else 0), the projectile's motion is
 * integrated with classic RK4 in substeps short against the contact's time scale, and contact_force is the
 * impulse over the step divided by H: mass (v_p(t0) - v_p(t0 + H)) / H. A master that holds it over the next
 * step hands the face exactly the momentum the projectile lost. model_get_output_derivative gives the states'
 * derivatives at the communication point, and 0 for contact_force, a step's mean to be held.
 *
 * Its continuous-time contract: the states projectile_position, projectile_velocity and face_work (the work of
 * the contact force on the face), no discrete states, no event indicators (the force is continuous in the state: it rises from 0 as delta^n and falls to 0 where the
 * damping term would pull).
 */
#ifndef PROJECTILE_MODEL_H
#define PROJECTILE_MODEL_H

#include "model_api.h"

#endif
