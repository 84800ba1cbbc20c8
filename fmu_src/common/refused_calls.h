/* The FMI calls this FMU refuses, one row each, for both FMI versions: the function, its parameters as the FMI
 * header declares them, their names, and the reason the importer is told (logged under the function's name with
 * fmi2Error / fmi3Error returned). A row's kind says when the call is refused:
 *   REFUSED               always;
 *   REFUSED_UNLESS_EMPTY  unless it names no variable (nvr 0: an empty call is fine);
 *   NO_VARIABLES_OF_TYPE  the same, once the state machine allows the call (its MASK_ in state_masks.h).
 * NO_VARIABLES_OF_TYPE's reason is the type's name. Each glue defines the kinds its table uses for its FMI version
 * and expands the table once, so no refused function is written by hand. They are defined at all because an
 * importer may look up every function the FMI header declares (tests/test_refused_calls.py compares them). */
#ifndef FMU_REFUSED_CALLS_H
#define FMU_REFUSED_CALLS_H

/* FMI 2.0 */
#define FMI2_REFUSED_CALLS                                                                                           \
    REFUSED(fmi2GetDirectionalDerivative,                                                                            \
            (fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,                              \
             const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],                         \
             fmi2Real dvUnknown[]),                                                                                  \
            (c, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown, dvUnknown), "not provided by this FMU")         \
    REFUSED(fmi2CancelStep, (fmi2Component c), (c),                                                                  \
            "doStep is synchronous in this FMU: there is nothing to cancel")                                         \
    REFUSED(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value), (c, s, value),              \
            "doStep is synchronous in this FMU: no pending status")                                                  \
    REFUSED(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value),                     \
            (c, s, value), "not provided by this FMU")                                                               \
    REFUSED(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value),                       \
            (c, s, value), "not provided by this FMU")

/* FMI 3.0: the value accessors of the types this FMU has no variables of share one parameter list. */
#define FMI3_VALUES(type) (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, type values[], size_t nValues)
#define FMI3_VALUE_NAMES (c, vr, nvr, values, nValues)
#define FMI3_BINARY(type, size_type)                                                                                 \
    (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_type valueSizes[], type values[],               \
     size_t nValues)
#define FMI3_BINARY_NAMES (c, vr, nvr, valueSizes, values, nValues)
#define FMI3_CLOCKS(type) (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, type values[])
#define FMI3_CLOCK_NAMES (c, vr, nvr, values)
#define FMI3_DERIVATIVE                                                                                              \
    (fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[],       \
     size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
#define FMI3_DERIVATIVE_NAMES (c, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, nSensitivity)

#define FMI3_REFUSED_CALLS                                                                                           \
    NO_VARIABLES_OF_TYPE(fmi3GetFloat32, FMI3_VALUES(fmi3Float32), FMI3_VALUE_NAMES, "Float32")                      \
    NO_VARIABLES_OF_TYPE(fmi3GetInt8, FMI3_VALUES(fmi3Int8), FMI3_VALUE_NAMES, "Int8")                               \
    NO_VARIABLES_OF_TYPE(fmi3GetUInt8, FMI3_VALUES(fmi3UInt8), FMI3_VALUE_NAMES, "UInt8")                            \
    NO_VARIABLES_OF_TYPE(fmi3GetInt16, FMI3_VALUES(fmi3Int16), FMI3_VALUE_NAMES, "Int16")                            \
    NO_VARIABLES_OF_TYPE(fmi3GetUInt16, FMI3_VALUES(fmi3UInt16), FMI3_VALUE_NAMES, "UInt16")                         \
    NO_VARIABLES_OF_TYPE(fmi3GetUInt32, FMI3_VALUES(fmi3UInt32), FMI3_VALUE_NAMES, "UInt32")                         \
    NO_VARIABLES_OF_TYPE(fmi3GetUInt64, FMI3_VALUES(fmi3UInt64), FMI3_VALUE_NAMES, "UInt64")                         \
    NO_VARIABLES_OF_TYPE(fmi3GetBoolean, FMI3_VALUES(fmi3Boolean), FMI3_VALUE_NAMES, "Boolean")                      \
    NO_VARIABLES_OF_TYPE(fmi3GetString, FMI3_VALUES(fmi3String), FMI3_VALUE_NAMES, "String")                         \
    NO_VARIABLES_OF_TYPE(fmi3GetBinary, FMI3_BINARY(fmi3Binary, size_t), FMI3_BINARY_NAMES, "Binary")                \
    NO_VARIABLES_OF_TYPE(fmi3SetFloat32, FMI3_VALUES(const fmi3Float32), FMI3_VALUE_NAMES, "Float32")                \
    NO_VARIABLES_OF_TYPE(fmi3SetInt8, FMI3_VALUES(const fmi3Int8), FMI3_VALUE_NAMES, "Int8")                         \
    NO_VARIABLES_OF_TYPE(fmi3SetUInt8, FMI3_VALUES(const fmi3UInt8), FMI3_VALUE_NAMES, "UInt8")                      \
    NO_VARIABLES_OF_TYPE(fmi3SetInt16, FMI3_VALUES(const fmi3Int16), FMI3_VALUE_NAMES, "Int16")                      \
    NO_VARIABLES_OF_TYPE(fmi3SetUInt16, FMI3_VALUES(const fmi3UInt16), FMI3_VALUE_NAMES, "UInt16")                   \
    NO_VARIABLES_OF_TYPE(fmi3SetUInt32, FMI3_VALUES(const fmi3UInt32), FMI3_VALUE_NAMES, "UInt32")                   \
    NO_VARIABLES_OF_TYPE(fmi3SetUInt64, FMI3_VALUES(const fmi3UInt64), FMI3_VALUE_NAMES, "UInt64")                   \
    NO_VARIABLES_OF_TYPE(fmi3SetBoolean, FMI3_VALUES(const fmi3Boolean), FMI3_VALUE_NAMES, "Boolean")                \
    NO_VARIABLES_OF_TYPE(fmi3SetString, FMI3_VALUES(const fmi3String), FMI3_VALUE_NAMES, "String")                   \
    NO_VARIABLES_OF_TYPE(fmi3SetBinary, FMI3_BINARY(const fmi3Binary, const size_t), FMI3_BINARY_NAMES,              \
                         "Binary")                                                                                   \
    REFUSED_UNLESS_EMPTY(fmi3GetClock, FMI3_CLOCKS(fmi3Clock), FMI3_CLOCK_NAMES, "this FMU has no clocks")           \
    REFUSED_UNLESS_EMPTY(fmi3SetClock, FMI3_CLOCKS(const fmi3Clock), FMI3_CLOCK_NAMES, "this FMU has no clocks")     \
    REFUSED(fmi3GetNumberOfVariableDependencies,                                                                     \
            (fmi3Instance c, fmi3ValueReference valueReference, size_t *nDependencies),                              \
            (c, valueReference, nDependencies), "not provided by this FMU")                                          \
    REFUSED(fmi3GetVariableDependencies,                                                                             \
            (fmi3Instance c, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],                       \
             fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],                               \
             fmi3DependencyKind dependencyKinds[], size_t nDependencies),                                            \
            (c, dependent, elementIndicesOfDependent, independents, elementIndicesOfIndependents,                    \
             dependencyKinds, nDependencies),                                                                        \
            "not provided by this FMU")                                                                              \
    REFUSED(fmi3GetDirectionalDerivative, FMI3_DERIVATIVE, FMI3_DERIVATIVE_NAMES, "not provided by this FMU")        \
    REFUSED(fmi3GetAdjointDerivative, FMI3_DERIVATIVE, FMI3_DERIVATIVE_NAMES, "not provided by this FMU")            \
    REFUSED(fmi3EnterConfigurationMode, (fmi3Instance c), (c), "this FMU has no structural parameters")              \
    REFUSED(fmi3ExitConfigurationMode, (fmi3Instance c), (c), "this FMU has no structural parameters")               \
    REFUSED(fmi3GetIntervalDecimal,                                                                                  \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 intervals[],                     \
             fmi3IntervalQualifier qualifiers[]),                                                                    \
            (c, vr, nvr, intervals, qualifiers), "this FMU has no clocks")                                           \
    REFUSED(fmi3GetIntervalFraction,                                                                                 \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],                       \
             fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]),                                          \
            (c, vr, nvr, counters, resolutions, qualifiers), "this FMU has no clocks")                               \
    REFUSED(fmi3GetShiftDecimal,                                                                                     \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[]),                       \
            (c, vr, nvr, shifts), "this FMU has no clocks")                                                          \
    REFUSED(fmi3GetShiftFraction,                                                                                    \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],                       \
             fmi3UInt64 resolutions[]),                                                                              \
            (c, vr, nvr, counters, resolutions), "this FMU has no clocks")                                           \
    REFUSED(fmi3SetIntervalDecimal,                                                                                  \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 intervals[]),              \
            (c, vr, nvr, intervals), "this FMU has no clocks")                                                       \
    REFUSED(fmi3SetIntervalFraction,                                                                                 \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3UInt64 counters[],                 \
             const fmi3UInt64 resolutions[]),                                                                        \
            (c, vr, nvr, counters, resolutions), "this FMU has no clocks")                                           \
    REFUSED(fmi3SetShiftDecimal,                                                                                     \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 shifts[]),                 \
            (c, vr, nvr, shifts), "this FMU has no clocks")                                                          \
    REFUSED(fmi3SetShiftFraction,                                                                                    \
            (fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3UInt64 counters[],                 \
             const fmi3UInt64 resolutions[]),                                                                        \
            (c, vr, nvr, counters, resolutions), "this FMU has no clocks")                                           \
    REFUSED(fmi3EvaluateDiscreteStates, (fmi3Instance c), (c), "this FMU has no clocks")                             \
    REFUSED(fmi3ActivateModelPartition,                                                                              \
            (fmi3Instance c, fmi3ValueReference clockReference, fmi3Float64 activationTime),                         \
            (c, clockReference, activationTime), "this FMU has no scheduled execution")

#endif
