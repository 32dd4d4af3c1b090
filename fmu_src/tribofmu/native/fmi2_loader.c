/* FMI 2.0 co-simulation entry points of a tribofmu FMU: find Python (loader_common.h), then
 * forward to pythonfmu's binary. Between host and pythonfmu it keeps what only C can see:
 *  - the instances and FMU states it handed out, so a freed or foreign pointer gets
 *    fmi2Error and a message instead of a crash inside pythonfmu;
 *  - instances that failed with fmi2Fatal: pythonfmu has released their Python objects, so any
 *    further call would crash; they get fmi2Error, and fmi2FreeInstance releases what is left;
 *  - the status the Python side asks for through TRIBOFMU_STATUS_CATEGORY messages;
 *  - warnings and errors reach the host's logger even with debug logging off (pythonfmu drops
 *    every message then); debug messages follow fmi2SetDebugLogging as before.
 */
#include "loader_common.h"

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define fmi2True 1
#define fmi2False 0

typedef struct tf_instance {
    struct tf_instance *next;
    void *inner;                       /* pythonfmu's component */
    fmi2CallbackFunctions host;        /* the host's callbacks */
    fmi2CallbackFunctions to_wrapper;  /* ours, given to pythonfmu (it keeps the pointer) */
    char *name;
    int logging_on;
    size_t n_categories;
    char **categories;
    int worst;                         /* worst status the Python side asked for in this call */
    const char *fatal_call;            /* the call that returned fmi2Fatal, if any */
} tf_instance;

/* ---- logging -------------------------------------------------------------------------- */

static int tf_category_on(tf_instance *I, const char *category)
{
    if (!I->logging_on) return 0;
    if (I->n_categories == 0) return 1;
    for (size_t i = 0; i < I->n_categories; ++i)
        if (category && strcmp(I->categories[i], category) == 0) return 1;
    return 0;
}

/* The status category a host filters on, for a message of this status. */
static const char *tf_status_category(int status)
{
    static const char *names[] = { "logStatusOK", "logStatusWarning", "logStatusDiscard",
                                   "logStatusError", "logStatusFatal", "logStatusPending" };
    return status >= 0 && status <= 5 ? names[status] : "logAll";
}

/* pythonfmu's messages arrive here (a printf format with no arguments, as FMI 2.0 says). */
static void tf_from_wrapper(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                            fmi2String category, fmi2String message, ...)
{
    tf_instance *I = tf_current ? tf_current : (tf_instance *)env;
    if (!I) return;
    if (category && strcmp(category, TRIBOFMU_STATUS_CATEGORY) == 0) {
        if ((int)status > I->worst) I->worst = (int)status;
        category = tf_status_category(status);
    }
    if (!I->host.logger) return;
    if (status >= fmi2Warning || tf_category_on(I, category))
        I->host.logger(I->host.componentEnvironment, name ? name : I->name, status, category,
                       message ? message : "");
}

static void tf_log(tf_instance *I, fmi2Status status, const char *fmt, ...)
{
    char text[TF_MSG], escaped[2 * TF_MSG];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    tf_escape_percent(text, escaped, sizeof escaped);
    if (I && I->host.logger)
        I->host.logger(I->host.componentEnvironment, I->name, status, tf_status_category(status), escaped);
}

/* ---- instances ------------------------------------------------------------------------ */

static int tf_is_live(tf_instance *c)
{
    pthread_mutex_lock(&tf_lock);
    tf_instance *I = tf_instances;
    while (I && I != c) I = I->next;
    pthread_mutex_unlock(&tf_lock);
    return I != NULL;
}

/* The instance behind c, or NULL (fmi2Error) when c is unknown or has failed fatally. */
static tf_instance *tf_enter(fmi2Component c, const char *call)
{
    tf_instance *I = (tf_instance *)c;
    if (!c || !tf_is_live(I)) {
        /* no instance, so no logger: stderr is all there is */
        fprintf(stderr, "tribofmu: %s called with %s instance %p; returned fmi2Error\n", call,
                c ? "an unknown or already freed" : "a NULL", c);
        return NULL;
    }
    if (I->fatal_call) {
        tf_log(I, fmi2Error, "%s refused: the instance failed with fmi2Fatal in %s, after which "
               "FMI 2.0 allows only fmi2FreeInstance", call, I->fatal_call);
        return NULL;
    }
    I->worst = fmi2OK;
    tf_current = I;
    return I;
}

static fmi2Status tf_leave(tf_instance *I, fmi2Status status, const char *call)
{
    tf_current = NULL;
    if (status == fmi2Fatal) I->fatal_call = call;  /* pythonfmu dropped its Python objects */
    if (I->worst > (int)status && I->worst <= fmi2Fatal) status = (fmi2Status)I->worst;
    I->worst = fmi2OK;
    return status;
}

#define TF_REAL(type, name) \
    static type tf_##name = NULL; \
    if (!tf_##name) tf_##name = (type)tf_sym(#name); \
    if (!tf_##name) { tf_current = NULL; tf_log(I, fmi2Error, "%s: not in the pythonfmu binary", #name); return fmi2Error; }

/* A call forwarded as is: fmi2Status f(fmi2Component, ARGS) */
#define TF_FORWARD(name, params, args) \
    TF_EXPORT fmi2Status name params \
    { \
        tf_instance *I = tf_enter(c, #name); \
        if (!I) return fmi2Error; \
        typedef fmi2Status (*fn_t) params; \
        TF_REAL(fn_t, name) \
        c = I->inner; \
        return tf_leave(I, tf_##name args, #name); \
    }

TF_EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
TF_EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

/* One message naming what is wrong (the host's logger, else stderr), and no instance. */
static void tf_refuse_instantiate(tf_instance *I, const char *problem)
{
    if (I->host.logger)
        tf_log(I, fmi2Error, "fmi2Instantiate failed: %s", problem);
    else
        fprintf(stderr, "tribofmu: fmi2Instantiate of %s failed: %s\n", I->name, problem);
    free(I->name);
    free(I);
}

TF_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                        fmi2String fmuResourceLocation,
                                        const fmi2CallbackFunctions *functions,
                                        fmi2Boolean visible, fmi2Boolean loggingOn)
{
    tf_instance *I = (tf_instance *)calloc(1, sizeof *I);
    if (!I) return NULL;
    if (functions) I->host = *functions;
    I->name = strdup(instanceName ? instanceName : "");
    I->logging_on = loggingOn;
    I->to_wrapper.logger = tf_from_wrapper;
    I->to_wrapper.allocateMemory = I->host.allocateMemory;
    I->to_wrapper.freeMemory = I->host.freeMemory;
    I->to_wrapper.componentEnvironment = I;

    const char *problem = NULL;
    char checked[TF_MSG], resources[PATH_MAX];
    if (!instanceName)
        problem = "instanceName is NULL";
    else if (!functions || !functions->logger)
        problem = "the callback functions (or their logger) are NULL, as FMI 2.0 does not allow";
    else if (fmuType != fmi2CoSimulation)
        problem = "this FMU supports co-simulation only (fmuType must be fmi2CoSimulation)";
    else if (!(problem = tf_check_resources("fmuResourceLocation", fmuResourceLocation, resources,
                                            sizeof resources, checked, sizeof checked)))
        problem = tf_check_token("fmuGUID", "guid", fmuGUID, resources, checked, sizeof checked);
    if (problem) {
        tf_refuse_instantiate(I, problem);
        return NULL;
    }
    pthread_mutex_lock(&tf_lock);
    if (!tf_ensure_python())
        problem = tf_python_problem;
    else if (!tf_open_wrapper())
        problem = tf_wrapper_problem;
    pthread_mutex_unlock(&tf_lock);

    typedef fmi2Component (*fn_t)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                  const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
    fn_t instantiate = problem ? NULL : (fn_t)tf_sym("fmi2Instantiate");
    if (!problem && !instantiate) problem = "fmi2Instantiate is not in the pythonfmu binary";
    if (!problem) {
        tf_current = I;
        /* pythonfmu always logs to us; we filter for the host */
        /* the checked folder: pythonfmu only cuts "file://" and decodes "%20" */
        I->inner = instantiate(instanceName, fmuType, fmuGUID, resources, &I->to_wrapper,
                               visible, fmi2True);
        tf_current = NULL;
        if (!I->inner) problem = "pythonfmu could not create the instance (see the message before)";
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

TF_EXPORT void fmi2FreeInstance(fmi2Component c)
{
    tf_instance *I = (tf_instance *)c;
    pthread_mutex_lock(&tf_lock);
    tf_instance **p = &tf_instances;
    while (*p && *p != I) p = &(*p)->next;
    int live = *p != NULL;
    if (live) *p = I->next;
    pthread_mutex_unlock(&tf_lock);
    if (!live) {
        if (c) fprintf(stderr, "tribofmu: fmi2FreeInstance called with an unknown or already "
                       "freed instance %p; ignored\n", c);
        return;
    }
    typedef fmi2Status (*free_state_t)(fmi2Component, fmi2FMUstate *);
    typedef void (*free_t)(fmi2Component);
    free_state_t free_state = (free_state_t)tf_sym("fmi2FreeFMUstate");
    free_t free_instance = (free_t)tf_sym("fmi2FreeInstance");
    tf_state *s;
    while ((s = tf_take_state_of(I)) != NULL) {
        /* after fmi2Fatal the Python objects are in an unknown state: leak rather than crash */
        if (!I->fatal_call && free_state) free_state(I->inner, &s->inner);
        free(s);
    }
    tf_current = I;
    if (!I->fatal_call && free_instance) free_instance(I->inner);
    tf_current = NULL;
    for (size_t i = 0; i < I->n_categories; ++i) free(I->categories[i]);
    free(I->categories);
    free(I->name);
    free(I);
}

TF_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                         const fmi2String categories[])
{
    tf_instance *I = tf_enter(c, "fmi2SetDebugLogging");
    if (!I) return fmi2Error;
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
    return fmi2OK;
}

TF_FORWARD(fmi2SetupExperiment,
           (fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
            fmi2Boolean stopTimeDefined, fmi2Real stopTime),
           (c, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime))
TF_FORWARD(fmi2EnterInitializationMode, (fmi2Component c), (c))
TF_FORWARD(fmi2ExitInitializationMode, (fmi2Component c), (c))
TF_FORWARD(fmi2Terminate, (fmi2Component c), (c))
TF_FORWARD(fmi2Reset, (fmi2Component c), (c))
TF_FORWARD(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]),
           (c, vr, nvr, value))
TF_FORWARD(fmi2DoStep,
           (fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
            fmi2Boolean noSetFMUStatePriorToCurrentPoint),
           (c, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint))
TF_FORWARD(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Status *value), (c, s, value))
TF_FORWARD(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Real *value), (c, s, value))
TF_FORWARD(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Integer *value), (c, s, value))
TF_FORWARD(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value), (c, s, value))
TF_FORWARD(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind s, fmi2String *value), (c, s, value))

/* Not supported by these FMUs (modelDescription says so); answered here. */
static fmi2Status tf_unsupported(fmi2Component c, const char *call)
{
    tf_instance *I = tf_enter(c, call);
    if (!I) return fmi2Error;
    tf_current = NULL;
    tf_log(I, fmi2Error, "%s is not supported by this FMU", call);
    return fmi2Error;
}

TF_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { return tf_unsupported(c, "fmi2CancelStep"); }
TF_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                  const fmi2ValueReference z[], size_t nz,
                                                  const fmi2Real dv[], fmi2Real dz[])
{
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return tf_unsupported(c, "fmi2GetDirectionalDerivative");
}
TF_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                 const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return tf_unsupported(c, "fmi2SetRealInputDerivatives");
}
TF_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                  const fmi2Integer order[], fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return tf_unsupported(c, "fmi2GetRealOutputDerivatives");
}

/* ---- FMU states: the host holds our handles, never pythonfmu's Python objects ---------- */

static tf_state *tf_known_state(tf_instance *I, fmi2FMUstate state, const char *call)
{
    tf_state *s = state ? tf_find_state(state) : NULL;
    if (!s) {
        tf_current = NULL;
        tf_log(I, fmi2Error, "%s: %p is not an FMU state of this FMU (never made by "
               "fmi2GetFMUstate/fmi2DeSerializeFMUstate, or already freed)", call, state);
    }
    return s;
}

TF_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    tf_instance *I = tf_enter(c, "fmi2GetFMUstate");
    if (!I) return fmi2Error;
    if (!state) {
        tf_current = NULL;
        tf_log(I, fmi2Error, "fmi2GetFMUstate: the FMUstate pointer is NULL");
        return fmi2Error;
    }
    typedef fmi2Status (*get_t)(fmi2Component, fmi2FMUstate *);
    typedef fmi2Status (*free_t)(fmi2Component, fmi2FMUstate *);
    TF_REAL(get_t, fmi2GetFMUstate)
    TF_REAL(free_t, fmi2FreeFMUstate)
    /* FMI 2.0: a non-NULL *state is a state of ours to overwrite */
    tf_state *existing = *state ? tf_find_state(*state) : NULL;
    fmi2FMUstate inner = NULL;
    fmi2Status status = tf_leave(I, tf_fmi2GetFMUstate(I->inner, &inner), "fmi2GetFMUstate");
    if (status > fmi2Warning) return status;
    if (existing) {
        fmi2FMUstate old = existing->inner;
        existing->inner = inner;
        existing->owner = I;
        tf_fmi2FreeFMUstate(I->inner, &old);
        return status;
    }
    tf_state *s = tf_new_state(I, inner);
    if (!s) {
        tf_fmi2FreeFMUstate(I->inner, &inner);
        tf_log(I, fmi2Error, "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    *state = s;
    return status;
}

TF_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    tf_instance *I = tf_enter(c, "fmi2SetFMUstate");
    if (!I) return fmi2Error;
    tf_state *s = tf_known_state(I, state, "fmi2SetFMUstate");
    if (!s) return fmi2Error;
    typedef fmi2Status (*set_t)(fmi2Component, fmi2FMUstate);
    TF_REAL(set_t, fmi2SetFMUstate)
    return tf_leave(I, tf_fmi2SetFMUstate(I->inner, s->inner), "fmi2SetFMUstate");
}

TF_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    tf_instance *I = tf_enter(c, "fmi2FreeFMUstate");
    if (!I) return fmi2Error;
    if (!state || !*state) { tf_current = NULL; return fmi2OK; }  /* FMI 2.0: nothing to free */
    tf_state *s = tf_known_state(I, *state, "fmi2FreeFMUstate");
    if (!s) return fmi2Error;
    typedef fmi2Status (*free_t)(fmi2Component, fmi2FMUstate *);
    TF_REAL(free_t, fmi2FreeFMUstate)
    fmi2Status status = tf_leave(I, tf_fmi2FreeFMUstate(I->inner, &s->inner), "fmi2FreeFMUstate");
    tf_forget_state(s);
    *state = NULL;
    return status;
}

TF_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size)
{
    tf_instance *I = tf_enter(c, "fmi2SerializedFMUstateSize");
    if (!I) return fmi2Error;
    tf_state *s = tf_known_state(I, state, "fmi2SerializedFMUstateSize");
    if (!s) return fmi2Error;
    typedef fmi2Status (*size_t_fn)(fmi2Component, fmi2FMUstate, size_t *);
    TF_REAL(size_t_fn, fmi2SerializedFMUstateSize)
    return tf_leave(I, tf_fmi2SerializedFMUstateSize(I->inner, s->inner, size), "fmi2SerializedFMUstateSize");
}

TF_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{
    tf_instance *I = tf_enter(c, "fmi2SerializeFMUstate");
    if (!I) return fmi2Error;
    tf_state *s = tf_known_state(I, state, "fmi2SerializeFMUstate");
    if (!s) return fmi2Error;
    typedef fmi2Status (*ser_t)(fmi2Component, fmi2FMUstate, fmi2Byte[], size_t);
    TF_REAL(ser_t, fmi2SerializeFMUstate)
    return tf_leave(I, tf_fmi2SerializeFMUstate(I->inner, s->inner, bytes, size), "fmi2SerializeFMUstate");
}

TF_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                             fmi2FMUstate *state)
{
    tf_instance *I = tf_enter(c, "fmi2DeSerializeFMUstate");
    if (!I) return fmi2Error;
    if (!state) {
        tf_current = NULL;
        tf_log(I, fmi2Error, "fmi2DeSerializeFMUstate: the FMUstate pointer is NULL");
        return fmi2Error;
    }
    typedef fmi2Status (*de_t)(fmi2Component, const fmi2Byte[], size_t, fmi2FMUstate *);
    typedef fmi2Status (*free_t)(fmi2Component, fmi2FMUstate *);
    TF_REAL(de_t, fmi2DeSerializeFMUstate)
    TF_REAL(free_t, fmi2FreeFMUstate)
    fmi2FMUstate inner = NULL;
    fmi2Status status = tf_leave(I, tf_fmi2DeSerializeFMUstate(I->inner, bytes, size, &inner),
                                 "fmi2DeSerializeFMUstate");
    if (status > fmi2Warning) return status;
    tf_state *s = tf_new_state(I, inner);
    if (!s) {
        tf_fmi2FreeFMUstate(I->inner, &inner);
        tf_log(I, fmi2Error, "fmi2DeSerializeFMUstate: out of memory");
        return fmi2Error;
    }
    *state = s;
    return status;
}
