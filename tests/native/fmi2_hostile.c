/* Hostile arguments and call sequences from a C host (issue 30). Each scenario prints one line
 * per call, "<call> <result>", and the process must end normally; the FMU's log messages go
 * to stderr as "log <status> <category>: <message>".
 *
 * usage: fmi2_hostile UNZIPPED_DIR MODEL_IDENTIFIER GUID SCENARIO [ARGS]
 *   instantiate LOCATION NAME GUID  fmi2Instantiate with these arguments: "NULL" is a NULL
 *                                   pointer, "OWN" the right value, anything else is passed
 *   no-callbacks                    fmi2Instantiate with a NULL callback-functions pointer
 *   cycles N INIT                   N instantiate/free cycles (INIT 1: through initialization
 *                                   and one step) after 200 to warm up; prints the resident
 *                                   set size before and after in bytes
 *   type-misuse VR                  getString/setString on the Real VR, then getReal, doStep,
 *                                   reset and a new run
 *   corrupt-state OLD NEW           serialize a state after one step, replace the first OLD in
 *                                   it by NEW, deserialize and set it; then a good state
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_types.h"

typedef char fmi2Byte;

static void logger(void *env, const char *name, fmi2Status status, const char *category,
                   const char *message, ...)
{
    (void)env; (void)name;
    fprintf(stderr, "log %d %s: %s\n", status, category ? category : "", message);
}

static long rss_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    long pages = 0, resident = 0;
    if (f) {
        if (fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
        fclose(f);
    }
    return resident * 4096L;
}

static void *lib;
#define FN(ret, args, name) ret (*name) args = (ret (*) args)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "missing %s\n", #name); return 3; }

static const char *pick(const char *arg, const char *own)
{
    if (!strcmp(arg, "NULL")) return NULL;
    if (!strcmp(arg, "OWN")) return own;
    return arg;
}

int main(int argc, char **argv)
{
    if (argc < 5) return 2;
    char path[4096], uri[4096];
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", argv[1], argv[2]);
    snprintf(uri, sizeof uri, "file://%s/resources", argv[1]);
    const char *guid = argv[3], *scenario = argv[4];
    lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 3; }
    FN(fmi2Component, (const char *, int, const char *, const char *, const fmi2CallbackFunctions *, int, int), fmi2Instantiate)
    FN(void, (fmi2Component), fmi2FreeInstance)
    FN(fmi2Status, (fmi2Component, int, double, double, int, double), fmi2SetupExperiment)
    FN(fmi2Status, (fmi2Component), fmi2EnterInitializationMode)
    FN(fmi2Status, (fmi2Component), fmi2ExitInitializationMode)
    FN(fmi2Status, (fmi2Component), fmi2Reset)
    FN(fmi2Status, (fmi2Component, const fmi2ValueReference *, size_t, double *), fmi2GetReal)
    FN(fmi2Status, (fmi2Component, const fmi2ValueReference *, size_t, const char **), fmi2GetString)
    FN(fmi2Status, (fmi2Component, const fmi2ValueReference *, size_t, const char *const *), fmi2SetString)
    FN(fmi2Status, (fmi2Component, double, double, int), fmi2DoStep)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate *), fmi2GetFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate), fmi2SetFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate *), fmi2FreeFMUstate)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate, size_t *), fmi2SerializedFMUstateSize)
    FN(fmi2Status, (fmi2Component, fmi2FMUstate, fmi2Byte *, size_t), fmi2SerializeFMUstate)
    FN(fmi2Status, (fmi2Component, const fmi2Byte *, size_t, fmi2FMUstate *), fmi2DeSerializeFMUstate)

    fmi2CallbackFunctions callbacks = { logger, calloc, free, NULL, NULL };

    if (!strcmp(scenario, "instantiate") && argc == 8) {
        fmi2Component c = fmi2Instantiate(pick(argv[6], "hostile"), 1, pick(argv[7], guid),
                                          pick(argv[5], uri), &callbacks, 0, 0);
        printf("fmi2Instantiate %s\n", c ? "instance" : "NULL");
        if (c) fmi2FreeInstance(c);
        printf("done\n");
        return 0;
    }
    if (!strcmp(scenario, "no-callbacks")) {
        fmi2Component c = fmi2Instantiate("hostile", 1, guid, uri, NULL, 0, 0);
        printf("fmi2Instantiate %s\n", c ? "instance" : "NULL");
        if (c) fmi2FreeInstance(c);
        printf("done\n");
        return 0;
    }
    if (!strcmp(scenario, "cycles") && argc == 7) {
        long n = atol(argv[5]);
        int init = atoi(argv[6]);
        long before = 0;
        for (long i = -200; i < n; ++i) {
            if (i == 0) before = rss_bytes();
            fmi2Component c = fmi2Instantiate("cycle", 1, guid, uri, &callbacks, 0, 0);
            if (!c) { fprintf(stderr, "instantiate failed in cycle %ld\n", i); return 3; }
            if (init) {
                fmi2SetupExperiment(c, 0, 0, 0, 0, 0);
                fmi2EnterInitializationMode(c);
                fmi2ExitInitializationMode(c);
                fmi2DoStep(c, 0.0, 1e-4, 1);
            }
            fmi2FreeInstance(c);
        }
        printf("rss %ld %ld\n", before, rss_bytes());
        return 0;
    }

    fmi2Component c = fmi2Instantiate("hostile", 1, guid, uri, &callbacks, 0, 0);
    if (!c) { fprintf(stderr, "instantiate failed\n"); return 3; }
    printf("fmi2SetupExperiment %d\n", fmi2SetupExperiment(c, 0, 0, 0, 0, 0));
    printf("fmi2EnterInitializationMode %d\n", fmi2EnterInitializationMode(c));
    printf("fmi2ExitInitializationMode %d\n", fmi2ExitInitializationMode(c));
    if (!strcmp(scenario, "type-misuse") && argc == 6) {
        fmi2ValueReference vr = (fmi2ValueReference)atoi(argv[5]);
        const char *text = NULL, *word = "hello";
        double value = 0;
        printf("fmi2GetString %d\n", fmi2GetString(c, &vr, 1, &text));
        printf("fmi2GetReal %d\n", fmi2GetReal(c, &vr, 1, &value));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 1));
        printf("fmi2SetString %d\n", fmi2SetString(c, &vr, 1, &word));
        printf("fmi2GetReal %d\n", fmi2GetReal(c, &vr, 1, &value));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 1e-4, 1e-4, 1));
        printf("fmi2Reset %d\n", fmi2Reset(c));
        printf("fmi2SetupExperiment %d\n", fmi2SetupExperiment(c, 0, 0, 0, 0, 0));
        printf("fmi2EnterInitializationMode %d\n", fmi2EnterInitializationMode(c));
        printf("fmi2ExitInitializationMode %d\n", fmi2ExitInitializationMode(c));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 1));
    } else if (!strcmp(scenario, "corrupt-state") && argc == 7) {
        fmi2FMUstate good = NULL, bad = NULL;
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 0.0, 1e-4, 1));
        printf("fmi2GetFMUstate %d\n", fmi2GetFMUstate(c, &good));
        size_t size = 0;
        printf("fmi2SerializedFMUstateSize %d\n", fmi2SerializedFMUstateSize(c, good, &size));
        size_t extra = strlen(argv[6]) + 1;
        char *bytes = (char *)calloc(size + extra, 1), *edited = (char *)calloc(size + extra, 1);
        printf("fmi2SerializeFMUstate %d\n", fmi2SerializeFMUstate(c, good, bytes, size));
        char *at = strstr(bytes, argv[5]);  /* the serialized state is text (JSON) */
        if (!at) { fprintf(stderr, "%s is not in the state\n", argv[5]); return 3; }
        size_t head = (size_t)(at - bytes), old = strlen(argv[5]);
        memcpy(edited, bytes, head);
        strcpy(edited + head, argv[6]);
        memcpy(edited + head + strlen(argv[6]), at + old, size - head - old);
        size_t edited_size = size - old + strlen(argv[6]);
        printf("fmi2DeSerializeFMUstate %d\n", fmi2DeSerializeFMUstate(c, edited, edited_size, &bad));
        printf("fmi2SetFMUstate %d\n", fmi2SetFMUstate(c, bad));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 1e-4, 1e-4, 1));
        printf("fmi2SetFMUstate %d\n", fmi2SetFMUstate(c, good));
        printf("fmi2DoStep %d\n", fmi2DoStep(c, 1e-4, 1e-4, 1));
        printf("fmi2FreeFMUstate %d\n", fmi2FreeFMUstate(c, &bad));
        printf("fmi2FreeFMUstate %d\n", fmi2FreeFMUstate(c, &good));
        free(bytes);
        free(edited);
    } else {
        return 2;
    }
    fmi2FreeInstance(c);
    printf("done\n");
    return 0;
}
