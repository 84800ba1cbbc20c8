/* The FMI state machine as one table, as the Reference FMUs keep it: for each function, the bitmask of the
 * instance states (instance.h) in which an importer may call it. Each glue checks a call with its own
 * CHECK_STATE(function), which looks up MASK_<function> here; an FMI 3 function whose states are those of its
 * FMI 2 counterpart is defined as that mask, so the two versions cannot disagree. The error state is in no
 * mask: there only reset and free are allowed (they check nothing). */
#ifndef FMU_STATE_MASKS_H
#define FMU_STATE_MASKS_H

#include "instance.h"

#define MODEL_EXCHANGE_STATES (IN(STATE_EVENT_MODE) | IN(STATE_CONTINUOUS_TIME))
#define STEPPING_STATES (IN(STATE_STEP) | IN(STATE_STEP_STOPPED))

/* FMI 2.0 */
#define MASK_fmi2SetupExperiment IN(STATE_INSTANTIATED)
#define MASK_fmi2EnterInitializationMode IN(STATE_INSTANTIATED)
#define MASK_fmi2ExitInitializationMode IN(STATE_INITIALIZATION_MODE)
#define MASK_fmi2Terminate (STEPPING_STATES | MODEL_EXCHANGE_STATES)
#define MASK_fmi2GetReal ANY_STATE
#define MASK_fmi2GetInteger ANY_STATE
#define MASK_fmi2GetBoolean ANY_STATE
#define MASK_fmi2GetString ANY_STATE
#define MASK_fmi2SetReal ANY_STATE
#define MASK_fmi2SetInteger ANY_STATE
#define MASK_fmi2SetBoolean ANY_STATE
#define MASK_fmi2SetString ANY_STATE
#define MASK_fmi2GetFMUstate ANY_STATE
#define MASK_fmi2SetFMUstate ANY_STATE
/* Co-Simulation */
#define MASK_fmi2DoStep STEPPING_STATES
#define MASK_fmi2SetRealInputDerivatives (IN(STATE_INITIALIZATION_MODE) | IN(STATE_STEP))
#define MASK_fmi2GetRealOutputDerivatives (STEPPING_STATES | IN(STATE_TERMINATED))
/* Model Exchange */
#define MASK_fmi2EnterEventMode MODEL_EXCHANGE_STATES
#define MASK_fmi2NewDiscreteStates IN(STATE_EVENT_MODE)
#define MASK_fmi2EnterContinuousTimeMode IN(STATE_EVENT_MODE)
#define MASK_fmi2CompletedIntegratorStep IN(STATE_CONTINUOUS_TIME)
#define MASK_fmi2SetTime MODEL_EXCHANGE_STATES
#define MASK_fmi2SetContinuousStates IN(STATE_CONTINUOUS_TIME)
#define MASK_fmi2GetDerivatives (MODEL_EXCHANGE_STATES | IN(STATE_TERMINATED))
#define MASK_fmi2GetEventIndicators (MODEL_EXCHANGE_STATES | IN(STATE_TERMINATED))
#define MASK_fmi2GetContinuousStates (MODEL_EXCHANGE_STATES | IN(STATE_TERMINATED))
#define MASK_fmi2GetNominalsOfContinuousStates ANY_STATE

/* FMI 3.0: its counterparts of FMI 2.0 functions first, then what only FMI 3.0 has. */
#define MASK_fmi3EnterInitializationMode MASK_fmi2EnterInitializationMode
#define MASK_fmi3ExitInitializationMode MASK_fmi2ExitInitializationMode
#define MASK_fmi3Terminate MASK_fmi2Terminate
#define MASK_fmi3GetFloat64 MASK_fmi2GetReal
#define MASK_fmi3SetFloat64 MASK_fmi2SetReal
#define MASK_fmi3GetInt32 MASK_fmi2GetInteger
#define MASK_fmi3SetInt32 MASK_fmi2SetInteger
#define MASK_fmi3GetBoolean MASK_fmi2GetBoolean
#define MASK_fmi3SetBoolean MASK_fmi2SetBoolean
#define MASK_fmi3GetString MASK_fmi2GetString
#define MASK_fmi3SetString MASK_fmi2SetString
#define MASK_fmi3GetFMUState MASK_fmi2GetFMUstate
#define MASK_fmi3SetFMUState MASK_fmi2SetFMUstate
#define MASK_fmi3DoStep MASK_fmi2DoStep
#define MASK_fmi3GetOutputDerivatives MASK_fmi2GetRealOutputDerivatives
#define MASK_fmi3EnterEventMode MASK_fmi2EnterEventMode
#define MASK_fmi3UpdateDiscreteStates MASK_fmi2NewDiscreteStates
#define MASK_fmi3EnterContinuousTimeMode MASK_fmi2EnterContinuousTimeMode
#define MASK_fmi3CompletedIntegratorStep MASK_fmi2CompletedIntegratorStep
#define MASK_fmi3SetTime MASK_fmi2SetTime
#define MASK_fmi3SetContinuousStates MASK_fmi2SetContinuousStates
#define MASK_fmi3GetContinuousStateDerivatives MASK_fmi2GetDerivatives
#define MASK_fmi3GetEventIndicators MASK_fmi2GetEventIndicators
#define MASK_fmi3GetContinuousStates MASK_fmi2GetContinuousStates
#define MASK_fmi3GetNominalsOfContinuousStates MASK_fmi2GetNominalsOfContinuousStates
/* The value types FMI 2.0 does not have: Int64 moves the enumerations; the FMU declares none of the others
 * (an empty call is fine). */
#define MASK_fmi3GetInt64 ANY_STATE
#define MASK_fmi3SetInt64 ANY_STATE
#define MASK_fmi3GetFloat32 ANY_STATE
#define MASK_fmi3SetFloat32 ANY_STATE
#define MASK_fmi3GetInt8 ANY_STATE
#define MASK_fmi3SetInt8 ANY_STATE
#define MASK_fmi3GetUInt8 ANY_STATE
#define MASK_fmi3SetUInt8 ANY_STATE
#define MASK_fmi3GetInt16 ANY_STATE
#define MASK_fmi3SetInt16 ANY_STATE
#define MASK_fmi3GetUInt16 ANY_STATE
#define MASK_fmi3SetUInt16 ANY_STATE
#define MASK_fmi3GetUInt32 ANY_STATE
#define MASK_fmi3SetUInt32 ANY_STATE
#define MASK_fmi3GetUInt64 ANY_STATE
#define MASK_fmi3SetUInt64 ANY_STATE
#define MASK_fmi3GetBinary ANY_STATE
#define MASK_fmi3SetBinary ANY_STATE
/* Co-Simulation's step mode, entered from the initialization mode's exit (this FMU has no event mode there) */
#define MASK_fmi3EnterStepMode IN(STATE_STEP)

#endif
