/* Misuse a host can commit that used to crash it inside pythonfmu's binary. Each scenario
 * prints one line per call, "<call> <status>", and the process must end normally.
 *
 * usage: fmi2_misuse UNZIPPED_DIR MODEL_IDENTIFIER GUID SCENARIO
 *   after-fatal   getReal of an unknown value reference, then four more getReal, then free
 *   double-free   fmi2FreeInstance twice
 *   freed-state   get, free, then set / free / serialize the freed state
 *   foreign-state set a pointer that is no FMU state at all
 *   unknown-instance  calls on a pointer that is no instance
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_types.h"

static void logger(void *env, const char *name, fmi2Status status, const char *category,
                   const char *message, ...)
{
    (void)env; (void)name;
    fprintf(stderr, "log %d %s: %s\n", status, category ? category : "", message);
}

static void *lib;
#define FN(ret, args, name) ret (*name) args = (ret (*) args)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "missing %s\n", #name); return 3; }

int main(int argc, char **argv)
{
    if (argc != 5) return 2;
    char path[4096], uri[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", argv[1], argv[2]);
    snprintf(uri, sizeof uri, "file://%s/resources", argv[1]);
    lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 3; }
    FN(fmi2Component, (const char *, int, const char *, const char *, const fmi2CallbackFunctions *, int, int), fmi2Instantiate)
    FN(void, (fmi2Component), fmi2FreeInstance)
    FN(fmi2Status, (fmi2Component, int, double, double, int, double), fmi2SetupExperiment)
    FN(fmi2Status, (fmi2Component), fmi2EnterInitializationMode)
    FN(fmi2Status, (fmi2Component), fmi2ExitInitializationMode)
    FN(fmi2Status, (fmi2Component, const fmi2ValueReference *, size_t, double *), fmi2GetReal)
    FN(fmi2Status, (fmi2Component, double, double, int), fmi2DoStep)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate *), fmi2GetFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate), fmi2SetFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate *), fmi2FreeFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate, size_t *), fmi2SerializedFMUstateSize)

    fmi2CallbackFunctions callbacks = { logger, calloc, free, NULL, NULL };
    fmi2Component c = fmi2Instantiate("misuse", 1, argv[3], uri, &callbacks, 0, 0);
    if (!c) { fprintf(stderr, "instantiate failed\n"); return 3; }
    printf("fmi2SetupExperiment %d\n", fmi2SetupExperiment(c, 0, 0, 0, 0, 0));
    printf("fmi2EnterInitializationMode %d\n", fmi2EnterInitializationMode(c));
    printf("fmi2ExitInitializationMode %d\n", fmi2ExitInitializationMode(c));
    const char *scenario = argv[4];
    double value = 0;
    if (!strcmp(scenario, "after-fatal")) {
        fmi2ValueReference unknown = 99999;
        for (int i = 0; i < 5; ++i) printf("fmi2GetReal %d\n", fmi2GetReal(c, &unknown, 1, &value));
        fmi2ValueReference known = 0;
        printf("fmi2GetReal %d\n", fmi2GetReal(c, &known, 1, &value));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 1));
        fmi2FreeInstance(c);
        printf("fmi2FreeInstance done\n");
    } else if (!strcmp(scenario, "double-free")) {
        fmi2FreeInstance(c);
        printf("fmi2FreeInstance done\n");
        fmi2FreeInstance(c);
        printf("fmi2FreeInstance done\n");
    } else if (!strcmp(scenario, "freed-state")) {
        fmi2FMUstate state = NULL, copy;
        printf("fmi2GetFMUstate %d\n", fmi2GetFMUstate(c, &state));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 0));
        printf("fmi2SetFMUstate %d\n", fmi2SetFMUstate(c, state));
        copy = state;
        printf("fmi2FreeFMUstate %d\n", fmi2FreeFMUstate(c, &state));
        printf("fmi2SetFMUstate %d\n", fmi2SetFMUstate(c, copy));
        printf("fmi2FreeFMUstate %d\n", fmi2FreeFMUstate(c, &copy));
        size_t size = 0;
        printf("fmi2SerializedFMUstateSize %d\n", fmi2SerializedFMUstateSize(c, copy, &size));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 0));
        fmi2FreeInstance(c);
        printf("fmi2FreeInstance done\n");
    } else if (!strcmp(scenario, "foreign-state")) {
        double not_a_state[8] = { 0 };
        printf("fmi2SetFMUstate %d\n", fmi2SetFMUstate(c, (fmi2FMUstate)not_a_state));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 0));
        fmi2FreeInstance(c);
        printf("fmi2FreeInstance done\n");
    } else if (!strcmp(scenario, "unknown-instance")) {
        double not_an_instance[8] = { 0 };
        fmi2ValueReference known = 0;
        printf("fmi2GetReal %d\n", fmi2GetReal((fmi2Component)not_an_instance, &known, 1, &value));
        printf("fmi2DoStep %d\n", fmi2DoStep((fmi2Component)not_an_instance, 0.0, 1e-4, 0));
        fmi2FreeInstance(c);
        printf("fmi2GetReal %d\n", fmi2GetReal(c, &known, 1, &value));
        printf("fmi2FreeInstance done\n");
    } else {
        return 2;
    }
    return 0;
}
