/* FMI 3.0 co-simulation entry points of a tribofmu FMU: find Python (loader_common.h), then
 * forward to pythonfmu3's binary, keeping what only C can see (see fmi2_loader.c). In
 * addition, the functions pythonfmu3 does not implement throw a C++ exception out of an
 * extern "C" function there (the host aborts); they are answered here with fmi3Error, and
 * model-exchange / scheduled-execution instantiation with NULL.
 */
#include "loader_common.h"

#include <stdbool.h>
#include <stdint.h>

typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef float fmi3Float32;
typedef double fmi3Float64;
typedef int8_t fmi3Int8;
typedef uint8_t fmi3UInt8;
typedef int16_t fmi3Int16;
typedef uint16_t fmi3UInt16;
typedef int32_t fmi3Int32;
typedef uint32_t fmi3UInt32;
typedef int64_t fmi3Int64;
typedef uint64_t fmi3UInt64;
typedef bool fmi3Boolean;
typedef char fmi3Char;
typedef const fmi3Char *fmi3String;
typedef uint8_t fmi3Byte;
typedef const fmi3Byte *fmi3Binary;
typedef bool fmi3Clock;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef int fmi3DependencyKind;
typedef int fmi3IntervalQualifier;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String);
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment, fmi3Float64, fmi3Boolean,
                                               fmi3Boolean, fmi3Boolean, fmi3Boolean, fmi3Boolean *,
                                               fmi3Float64 *);
typedef void (*fmi3ClockUpdateCallback)(fmi3InstanceEnvironment);
typedef void (*fmi3LockPreemptionCallback)(void);
typedef void (*fmi3UnlockPreemptionCallback)(void);

typedef struct tf_instance {
    struct tf_instance *next;
    void *inner;
    fmi3InstanceEnvironment host_env;
    fmi3LogMessageCallback host_log;
    int logging_on;
    size_t n_categories;
    char **categories;
    int worst;
    const char *fatal_call;
} tf_instance;

static int tf_category_on(tf_instance *I, const char *category)
{
    if (!I->logging_on) return 0;
    if (I->n_categories == 0) return 1;
    for (size_t i = 0; i < I->n_categories; ++i)
        if (category && strcmp(I->categories[i], category) == 0) return 1;
    return 0;
}

static const char *tf_status_category(int status)
{
    static const char *names[] = { "logStatusOK", "logStatusWarning", "logStatusDiscard",
                                   "logStatusError", "logStatusFatal" };
    return status >= 0 && status <= 4 ? names[status] : "logAll";
}

/* pythonfmu3 passes its own component as the environment, not ours: the instance is the one
 * whose call is running on this thread. */
static void tf_from_wrapper(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                            fmi3String message)
{
    (void)env;
    tf_instance *I = tf_current;
    if (!I) return;
    if (category && strcmp(category, TRIBOFMU_STATUS_CATEGORY) == 0) {
        if ((int)status > I->worst) I->worst = (int)status;
        category = tf_status_category(status);
    }
    if (I->host_log && (status >= fmi3Warning || tf_category_on(I, category)))
        I->host_log(I->host_env, status, category, message ? message : "");
}

static void tf_log(tf_instance *I, fmi3Status status, const char *fmt, ...)
{
    char text[TF_MSG];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    if (I && I->host_log) I->host_log(I->host_env, status, tf_status_category(status), text);
}

static int tf_is_live(tf_instance *c)
{
    pthread_mutex_lock(&tf_lock);
    tf_instance *I = tf_instances;
    while (I && I != c) I = I->next;
    pthread_mutex_unlock(&tf_lock);
    return I != NULL;
}

static tf_instance *tf_enter(fmi3Instance c, const char *call)
{
    tf_instance *I = (tf_instance *)c;
    if (!c || !tf_is_live(I)) {
        fprintf(stderr, "tribofmu: %s called with %s instance %p; returned fmi3Error\n", call,
                c ? "an unknown or already freed" : "a NULL", c);
        return NULL;
    }
    if (I->fatal_call) {
        tf_log(I, fmi3Error, "%s refused: the instance failed with fmi3Fatal in %s, after which "
               "FMI 3.0 allows only fmi3FreeInstance", call, I->fatal_call);
        return NULL;
    }
    I->worst = fmi3OK;
    tf_current = I;
    return I;
}

static fmi3Status tf_leave(tf_instance *I, fmi3Status status, const char *call)
{
    tf_current = NULL;
    if (status == fmi3Fatal) I->fatal_call = call;
    if (I->worst > (int)status && I->worst <= fmi3Fatal) status = (fmi3Status)I->worst;
    I->worst = fmi3OK;
    return status;
}

#define TF_REAL(type, name) \
    static type tf_##name = NULL; \
    if (!tf_##name) tf_##name = (type)tf_sym(#name); \
    if (!tf_##name) { tf_current = NULL; tf_log(I, fmi3Error, "%s: not in the pythonfmu3 binary", #name); return fmi3Error; }

#define TF_FORWARD(name, params, args) \
    TF_EXPORT fmi3Status name params \
    { \
        tf_instance *I = tf_enter(instance, #name); \
        if (!I) return fmi3Error; \
        typedef fmi3Status (*fn_t) params; \
        TF_REAL(fn_t, name) \
        instance = I->inner; \
        return tf_leave(I, tf_##name args, #name); \
    }

static fmi3Status tf_unsupported(fmi3Instance instance, const char *call)
{
    tf_instance *I = tf_enter(instance, call);
    if (!I) return fmi3Error;
    tf_current = NULL;
    tf_log(I, fmi3Error, "%s is not supported by this FMU (a co-simulation FMU whose variables "
           "are Float64, Int32, UInt64, Boolean and String)", call);
    return fmi3Error;
}

#define TF_UNSUPPORTED(name, params) \
    TF_EXPORT fmi3Status name params { return tf_unsupported(instance, #name); }

TF_EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

/* One message naming what is wrong (the host's logger, else stderr), and no instance. */
static void tf_refuse_instantiate(tf_instance *I, const char *problem)
{
    if (I->host_log)
        tf_log(I, fmi3Error, "fmi3InstantiateCoSimulation failed: %s", problem);
    else
        fprintf(stderr, "tribofmu: fmi3InstantiateCoSimulation failed: %s\n", problem);
    free(I);
}

TF_EXPORT fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    tf_instance *I = (tf_instance *)calloc(1, sizeof *I);
    if (!I) return NULL;
    I->host_env = instanceEnvironment;
    I->host_log = logMessage;
    I->logging_on = loggingOn;

    const char *problem = NULL;
    char checked[TF_MSG], resources[PATH_MAX];
    if (!instanceName)
        problem = "instanceName is NULL";
    else if (!(problem = tf_check_resources("resourcePath", resourcePath, resources,
                                            sizeof resources - 1, checked, sizeof checked)))
        problem = tf_check_token("instantiationToken", "instantiationToken", instantiationToken,
                                 resources, checked, sizeof checked);
    if (problem) {
        tf_refuse_instantiate(I, problem);
        return NULL;
    }
    strcat(resources, "/");  /* FMI 3.0: a folder path ends with its separator */
    pthread_mutex_lock(&tf_lock);
    if (!tf_ensure_python())
        problem = tf_python_problem;
    else if (!tf_open_wrapper())
        problem = tf_wrapper_problem;
    pthread_mutex_unlock(&tf_lock);

    typedef fmi3Instance (*fn_t)(fmi3String, fmi3String, fmi3String, fmi3Boolean, fmi3Boolean,
                                 fmi3Boolean, fmi3Boolean, const fmi3ValueReference[], size_t,
                                 fmi3InstanceEnvironment, fmi3LogMessageCallback,
                                 fmi3IntermediateUpdateCallback);
    fn_t instantiate = problem ? NULL : (fn_t)tf_sym("fmi3InstantiateCoSimulation");
    if (!problem && !instantiate) problem = "fmi3InstantiateCoSimulation is not in the pythonfmu3 binary";
    if (!problem) {
        tf_current = I;
        I->inner = instantiate(instanceName, instantiationToken, resources, visible, true,
                               eventModeUsed, earlyReturnAllowed, requiredIntermediateVariables,
                               nRequiredIntermediateVariables, I, tf_from_wrapper, intermediateUpdate);
        tf_current = NULL;
        if (!I->inner) problem = "pythonfmu3 could not create the instance";
    }
    if (problem) {
        tf_refuse_instantiate(I, problem);
        return NULL;
    }
    pthread_mutex_lock(&tf_lock);
    I->next = tf_instances;
    tf_instances = I;
    pthread_mutex_unlock(&tf_lock);
    return I;
}

TF_EXPORT fmi3Instance fmi3InstantiateModelExchange(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateModelExchange: this FMU supports co-simulation only");
    return NULL;
}

TF_EXPORT fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: this FMU supports co-simulation only");
    return NULL;
}

TF_EXPORT void fmi3FreeInstance(fmi3Instance instance)
{
    tf_instance *I = (tf_instance *)instance;
    pthread_mutex_lock(&tf_lock);
    tf_instance **p = &tf_instances;
    while (*p && *p != I) p = &(*p)->next;
    int live = *p != NULL;
    if (live) *p = I->next;
    pthread_mutex_unlock(&tf_lock);
    if (!live) {
        if (instance) fprintf(stderr, "tribofmu: fmi3FreeInstance called with an unknown or "
                              "already freed instance %p; ignored\n", instance);
        return;
    }
    typedef fmi3Status (*free_state_t)(fmi3Instance, fmi3FMUState *);
    typedef void (*free_t)(fmi3Instance);
    free_state_t free_state = (free_state_t)tf_sym("fmi3FreeFMUState");
    free_t free_instance = (free_t)tf_sym("fmi3FreeInstance");
    tf_state *s;
    tf_current = I;
    while ((s = tf_take_state_of(I)) != NULL) {
        if (!I->fatal_call && free_state) free_state(I->inner, &s->inner);
        free(s);
    }
    if (!I->fatal_call && free_instance) free_instance(I->inner);
    tf_current = NULL;
    for (size_t i = 0; i < I->n_categories; ++i) free(I->categories[i]);
    free(I->categories);
    free(I);
}

TF_EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                                         size_t nCategories, const fmi3String categories[])
{
    tf_instance *I = tf_enter(instance, "fmi3SetDebugLogging");
    if (!I) return fmi3Error;
    tf_current = NULL;
    for (size_t i = 0; i < I->n_categories; ++i) free(I->categories[i]);
    free(I->categories);
    I->categories = NULL;
    I->n_categories = 0;
    if (nCategories && categories) {
        I->categories = (char **)calloc(nCategories, sizeof(char *));
        for (size_t i = 0; I->categories && i < nCategories; ++i)
            I->categories[I->n_categories++] = strdup(categories[i] ? categories[i] : "");
    }
    I->logging_on = loggingOn;
    return fmi3OK;
}

TF_FORWARD(fmi3EnterInitializationMode,
           (fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
            fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime),
           (instance, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime))
TF_FORWARD(fmi3ExitInitializationMode, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3EnterEventMode, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3EnterStepMode, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3EnterConfigurationMode, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3ExitConfigurationMode, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3Terminate, (fmi3Instance instance), (instance))
TF_FORWARD(fmi3Reset, (fmi3Instance instance), (instance))

#define TF_GETSET(suffix, type) \
    TF_FORWARD(fmi3Get##suffix, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                 type values[], size_t nValues), (instance, vr, nvr, values, nValues)) \
    TF_FORWARD(fmi3Set##suffix, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                 const type values[], size_t nValues), (instance, vr, nvr, values, nValues))
TF_GETSET(Float64, fmi3Float64)
TF_GETSET(Int32, fmi3Int32)
TF_GETSET(UInt64, fmi3UInt64)
TF_GETSET(Boolean, fmi3Boolean)
TF_GETSET(String, fmi3String)

#define TF_GETSET_UNSUPPORTED(suffix, type) \
    TF_UNSUPPORTED(fmi3Get##suffix, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                     type values[], size_t nValues)) \
    TF_UNSUPPORTED(fmi3Set##suffix, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                     const type values[], size_t nValues))
TF_GETSET_UNSUPPORTED(Float32, fmi3Float32)
TF_GETSET_UNSUPPORTED(Int8, fmi3Int8)
TF_GETSET_UNSUPPORTED(UInt8, fmi3UInt8)
TF_GETSET_UNSUPPORTED(Int16, fmi3Int16)
TF_GETSET_UNSUPPORTED(UInt16, fmi3UInt16)
TF_GETSET_UNSUPPORTED(UInt32, fmi3UInt32)
TF_GETSET_UNSUPPORTED(Int64, fmi3Int64)

TF_FORWARD(fmi3DoStep,
           (fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
            fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
            fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
            fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime),
           (instance, currentCommunicationPoint, communicationStepSize,
            noSetFMUStatePriorToCurrentPoint, eventHandlingNeeded, terminateSimulation, earlyReturn,
            lastSuccessfulTime))

TF_UNSUPPORTED(fmi3GetBinary, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               size_t valueSizes[], fmi3Binary values[], size_t nValues))
TF_UNSUPPORTED(fmi3SetBinary, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const size_t valueSizes[], const fmi3Binary values[], size_t nValues))
TF_UNSUPPORTED(fmi3GetClock, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                              fmi3Clock values[]))
TF_UNSUPPORTED(fmi3SetClock, (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                              const fmi3Clock values[]))
TF_UNSUPPORTED(fmi3GetNumberOfVariableDependencies,
               (fmi3Instance instance, fmi3ValueReference vr, size_t *nDependencies))
TF_UNSUPPORTED(fmi3GetVariableDependencies,
               (fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
                fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
                fmi3DependencyKind dependencyKinds[], size_t nDependencies))
TF_UNSUPPORTED(fmi3GetDirectionalDerivative,
               (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
TF_UNSUPPORTED(fmi3GetAdjointDerivative,
               (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
TF_UNSUPPORTED(fmi3GetOutputDerivatives,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues))
TF_UNSUPPORTED(fmi3GetIntervalDecimal,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]))
TF_UNSUPPORTED(fmi3GetIntervalFraction,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]))
TF_UNSUPPORTED(fmi3GetShiftDecimal,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[]))
TF_UNSUPPORTED(fmi3GetShiftFraction,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
TF_UNSUPPORTED(fmi3SetIntervalDecimal,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                const fmi3Float64 intervals[]))
TF_UNSUPPORTED(fmi3SetIntervalFraction,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
TF_UNSUPPORTED(fmi3SetShiftDecimal,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                const fmi3Float64 shifts[]))
TF_UNSUPPORTED(fmi3SetShiftFraction,
               (fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
TF_UNSUPPORTED(fmi3EvaluateDiscreteStates, (fmi3Instance instance))
TF_UNSUPPORTED(fmi3UpdateDiscreteStates,
               (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                fmi3Float64 *nextEventTime))
TF_UNSUPPORTED(fmi3ActivateModelPartition,
               (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime))
TF_UNSUPPORTED(fmi3EnterContinuousTimeMode, (fmi3Instance instance))
TF_UNSUPPORTED(fmi3CompletedIntegratorStep,
               (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation))
TF_UNSUPPORTED(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time))
TF_UNSUPPORTED(fmi3SetContinuousStates,
               (fmi3Instance instance, const fmi3Float64 states[], size_t nContinuousStates))
TF_UNSUPPORTED(fmi3GetContinuousStateDerivatives,
               (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates))
TF_UNSUPPORTED(fmi3GetEventIndicators,
               (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators))
TF_UNSUPPORTED(fmi3GetContinuousStates,
               (fmi3Instance instance, fmi3Float64 states[], size_t nContinuousStates))
TF_UNSUPPORTED(fmi3GetNominalsOfContinuousStates,
               (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates))
TF_UNSUPPORTED(fmi3GetNumberOfEventIndicators, (fmi3Instance instance, size_t *nEventIndicators))
TF_UNSUPPORTED(fmi3GetNumberOfContinuousStates, (fmi3Instance instance, size_t *nContinuousStates))

/* ---- FMU states ----------------------------------------------------------------------- */

static tf_state *tf_known_state(tf_instance *I, fmi3FMUState state, const char *call)
{
    tf_state *s = state ? tf_find_state(state) : NULL;
    if (!s) {
        tf_current = NULL;
        tf_log(I, fmi3Error, "%s: %p is not an FMU state of this FMU (never made by "
               "fmi3GetFMUState/fmi3DeserializeFMUState, or already freed)", call, state);
    }
    return s;
}

TF_EXPORT fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *state)
{
    tf_instance *I = tf_enter(instance, "fmi3GetFMUState");
    if (!I) return fmi3Error;
    if (!state) {
        tf_current = NULL;
        tf_log(I, fmi3Error, "fmi3GetFMUState: the FMUState pointer is NULL");
        return fmi3Error;
    }
    typedef fmi3Status (*get_t)(fmi3Instance, fmi3FMUState *);
    typedef fmi3Status (*free_t)(fmi3Instance, fmi3FMUState *);
    TF_REAL(get_t, fmi3GetFMUState)
    TF_REAL(free_t, fmi3FreeFMUState)
    tf_state *existing = *state ? tf_find_state(*state) : NULL;
    fmi3FMUState inner = NULL;
    fmi3Status status = tf_leave(I, tf_fmi3GetFMUState(I->inner, &inner), "fmi3GetFMUState");
    if (status > fmi3Warning) return status;
    if (existing) {
        fmi3FMUState old = existing->inner;
        existing->inner = inner;
        existing->owner = I;
        tf_fmi3FreeFMUState(I->inner, &old);
        return status;
    }
    tf_state *s = tf_new_state(I, inner);
    if (!s) {
        tf_fmi3FreeFMUState(I->inner, &inner);
        tf_log(I, fmi3Error, "fmi3GetFMUState: out of memory");
        return fmi3Error;
    }
    *state = s;
    return status;
}

TF_EXPORT fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state)
{
    tf_instance *I = tf_enter(instance, "fmi3SetFMUState");
    if (!I) return fmi3Error;
    tf_state *s = tf_known_state(I, state, "fmi3SetFMUState");
    if (!s) return fmi3Error;
    typedef fmi3Status (*set_t)(fmi3Instance, fmi3FMUState);
    TF_REAL(set_t, fmi3SetFMUState)
    return tf_leave(I, tf_fmi3SetFMUState(I->inner, s->inner), "fmi3SetFMUState");
}

TF_EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *state)
{
    tf_instance *I = tf_enter(instance, "fmi3FreeFMUState");
    if (!I) return fmi3Error;
    if (!state || !*state) { tf_current = NULL; return fmi3OK; }
    tf_state *s = tf_known_state(I, *state, "fmi3FreeFMUState");
    if (!s) return fmi3Error;
    typedef fmi3Status (*free_t)(fmi3Instance, fmi3FMUState *);
    TF_REAL(free_t, fmi3FreeFMUState)
    fmi3Status status = tf_leave(I, tf_fmi3FreeFMUState(I->inner, &s->inner), "fmi3FreeFMUState");
    tf_forget_state(s);
    *state = NULL;
    return status;
}

TF_EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t *size)
{
    tf_instance *I = tf_enter(instance, "fmi3SerializedFMUStateSize");
    if (!I) return fmi3Error;
    tf_state *s = tf_known_state(I, state, "fmi3SerializedFMUStateSize");
    if (!s) return fmi3Error;
    typedef fmi3Status (*size_fn)(fmi3Instance, fmi3FMUState, size_t *);
    TF_REAL(size_fn, fmi3SerializedFMUStateSize)
    return tf_leave(I, tf_fmi3SerializedFMUStateSize(I->inner, s->inner, size), "fmi3SerializedFMUStateSize");
}

TF_EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state,
                                           fmi3Byte serializedState[], size_t size)
{
    tf_instance *I = tf_enter(instance, "fmi3SerializeFMUState");
    if (!I) return fmi3Error;
    tf_state *s = tf_known_state(I, state, "fmi3SerializeFMUState");
    if (!s) return fmi3Error;
    typedef fmi3Status (*ser_t)(fmi3Instance, fmi3FMUState, fmi3Byte[], size_t);
    TF_REAL(ser_t, fmi3SerializeFMUState)
    return tf_leave(I, tf_fmi3SerializeFMUState(I->inner, s->inner, serializedState, size),
                    "fmi3SerializeFMUState");
}

TF_EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                             size_t size, fmi3FMUState *state)
{
    tf_instance *I = tf_enter(instance, "fmi3DeserializeFMUState");
    if (!I) return fmi3Error;
    if (!state) {
        tf_current = NULL;
        tf_log(I, fmi3Error, "fmi3DeserializeFMUState: the FMUState pointer is NULL");
        return fmi3Error;
    }
    typedef fmi3Status (*de_t)(fmi3Instance, const fmi3Byte[], size_t, fmi3FMUState *);
    typedef fmi3Status (*free_t)(fmi3Instance, fmi3FMUState *);
    TF_REAL(de_t, fmi3DeserializeFMUState)
    TF_REAL(free_t, fmi3FreeFMUState)
    fmi3FMUState inner = NULL;
    fmi3Status status = tf_leave(I, tf_fmi3DeserializeFMUState(I->inner, serializedState, size, &inner),
                                 "fmi3DeserializeFMUState");
    if (status > fmi3Warning) return status;
    tf_state *s = tf_new_state(I, inner);
    if (!s) {
        tf_fmi3FreeFMUState(I->inner, &inner);
        tf_log(I, fmi3Error, "fmi3DeserializeFMUState: out of memory");
        return fmi3Error;
    }
    *state = s;
    return status;
}
