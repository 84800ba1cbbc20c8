/* The lattice (a plate LATTICE_DEPTH masses deep: docs/model.md section 10) as a model of the FMI glue: it
 * implements the model API (common/model_api.h) in model.c (variables, initialisation, the continuous-time
 * contract) and cosimulation.c (the Co-Simulation driver).
 *
 * Its continuous-time contract:
 * Continuous states (model_state_count): the lattice's displacements and velocities (x and y; x, y and z in a
 *   plate of slices) and its three energy integrals (external work, dissipation, non-reciprocal work), in
 *   lattice.h's layout.
 * Discrete states, changed only by model_event_update: whether the load acts (a time event at t_active)
 *   and each column-C mass's backplate mode (free, receding, approaching). The event update switches the
 *   backplate modes to those of the state (an indicator that is exactly zero by the direction the mass moves
 *   in, so that a switch does not wait for an indicator to leave zero: an importer that restarts on an exact
 *   zero may never report it leaving).
 * Event indicators (model_event_indicator_count; none without a backplate): each column-C mass's contact
 *   (f = k*R + i, row by row, slice by slice), ux - backplate_gap (> 0 in contact), then each one's damping,
 *   vx while in contact (> 0 the damper acts);
 *   off the plate the damper cannot switch, so the damping indicator repeats the contact one.
 * model_advance stops the run early (MODEL_LIMIT_REACHED) when peak_backplate_force exceeds peak_force_limit.
 */
#ifndef LATTICE_MODEL_H
#define LATTICE_MODEL_H

#include "model_api.h"

#endif
