/* What every component model of the armour system (fmu_src/projectile/, fmu_src/hull/: docs/model.md section 11)
 * shares: the model API functions that do not depend on the component's physics, and the checks its own
 * functions start with. The Reference FMUs keep such code in their shared sources and only the model in model.c;
 * here a component's model.c keeps its physics (derivatives, Co-Simulation step, input derivatives).
 *
 * A file of its own rather than part of instance.c: instance.c is the FMI glue every FMU carries, the lattice's
 * too, and reaches a model only through model_api.h; this code reads a component's generated variable table
 * (model_variables.h, builder/component.py) and the fields a component's struct Model starts with, which the
 * lattice has not. The builder compiles it into a component's FMU only (builder/sources.py), so the lattice's
 * FMU is built from the glue and its own folder alone.
 *
 * A component is a model whose variables are all Real and described by its VARIABLES table, whose continuous
 * states and their derivatives are variables of that table (its state and derivative indices), with no discrete
 * states and no event indicators, whose steps cannot fail once its parameters are checked, and which never
 * stops a run early. Its model.c defines struct Model starting with a ComponentCore named `core`
 * (COMPONENT_CORE_COMES_FIRST checks it), and implements model_size, model_set_real (through
 * component_set_real), model_get_real, model_set_input_derivative, model_get_output_derivative (through
 * component_get_output_derivative), component_start (model_initialize's start of the states), model_advance,
 * model_driver_initialize and model_driver_check.
 */
#ifndef COMPONENT_MODEL_H
#define COMPONENT_MODEL_H

#include <stddef.h>

#include "model_api.h"
#include "model_variables.h" /* the component's, generated */

#if N_EVENT_INDICATORS != 0
#error "component_model.c gives no event indicators: a component with some implements its own"
#endif

/* The fields the shared code reads and writes, at the start of every component's struct Model. */
typedef struct {
    double value[N_VALUE_REFERENCES]; /* every variable's value, by value reference */
    double time;
    int initialized;    /* 1 after model_initialize: the parameters are fixed and checked */
    int model_exchange; /* the importer integrates (model_exchange_begin) */
} ComponentCore;

/* A compile-time check, after a component's struct Model: its ComponentCore `core` comes first, where the shared
 * code finds it (C converts a pointer to a struct into a pointer to its first member). */
#define COMPONENT_CORE_COMES_FIRST(type) typedef char component_core_comes_first[offsetof(type, core) == 0 ? 1 : -1]

/* 0 when vr is one of the component's value references, else -1 and why. */
int component_check_reference(unsigned int vr, char *message, size_t message_size);

/* model_set_real's checks (an unknown reference, an output or local, a parameter after initialisation, a value
 * out of its range) and the store; the component's model_set_real adds what a new value changes. */
int component_set_real(Model *m, unsigned int vr, double value, char *message, size_t message_size);

/* The component's: sets its states at the start of a run, from its parameters (model_initialize calls it once
 * they are checked). */
void component_start(Model *m);

/* model_get_output_derivative of the outputs that are continuous states: their derivatives are the contract's
 * (model_get_real of the derivative variable). Refuses the others, and orders other than 1, with why. */
int component_get_output_derivative(Model *m, unsigned int vr, int order, double *value, char *message,
                                    size_t message_size);

#endif
