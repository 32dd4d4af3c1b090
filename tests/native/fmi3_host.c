/* A minimal FMI 3.0 co-simulation host in plain C (the FMI 2.0 one is fmi2_host.c; the same
 * options): fixed steps t_k = k * STEP, Jacobi exchange, Float64 variables only.
 *
 * usage: fmi3_host -h STEP -n STEPS
 *                  -f UNZIPPED_DIR MODEL_IDENTIFIER INSTANTIATION_TOKEN   (repeat)
 *                  -s I VR VALUE   -c I VR J VR   -o I VR
 *                  -x               after the run, call fmi3GetFloat32 (not supported by these
 *                                   FMUs) on FMU 0 and print "fmi3GetFloat32 <status>"
 * Exit status: 0 success, 2 usage, 3 load/instantiate failure, 4 an FMI call failed.
 */
#include <dlfcn.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi3Instance;
typedef int fmi3Status;
typedef void (*log_t)(void *, fmi3Status, const char *, const char *);

static void logger(void *env, fmi3Status status, const char *category, const char *message)
{
    (void)env;
    fprintf(stderr, "[%d] %s: %s\n", status, category ? category : "", message);
}

#define MAX 8
typedef struct {
    void *lib;
    fmi3Instance c;
    fmi3Status (*set)(fmi3Instance, const uint32_t *, size_t, const double *, size_t);
    fmi3Status (*get)(fmi3Instance, const uint32_t *, size_t, double *, size_t);
    fmi3Status (*step)(fmi3Instance, double, double, bool, bool *, bool *, bool *, double *);
} fmu_t;

static int check(fmi3Status status, const char *call, int i)
{
    if (status > 1) { fprintf(stderr, "fmi3_host: %s of FMU %d returned %d\n", call, i, status); return 0; }
    return 1;
}

int main(int argc, char **argv)
{
    double h = 0;
    long steps = -1;
    int n_fmus = 0, n_sets = 0, n_conns = 0, n_outs = 0, extra = 0;
    const char *dirs[MAX], *ids[MAX], *tokens[MAX];
    struct { int i; uint32_t vr; double value; } sets[128];
    struct { int i; uint32_t vr; int j; uint32_t to; } conns[32];
    struct { int i; uint32_t vr; } outs[32];
    fmu_t fmus[MAX];
    memset(fmus, 0, sizeof fmus);
    for (int a = 1; a < argc; ++a) {
        if (!strcmp(argv[a], "-h") && a + 1 < argc) h = atof(argv[++a]);
        else if (!strcmp(argv[a], "-n") && a + 1 < argc) steps = atol(argv[++a]);
        else if (!strcmp(argv[a], "-x")) extra = 1;
        else if (!strcmp(argv[a], "-f") && a + 3 < argc && n_fmus < MAX) {
            dirs[n_fmus] = argv[++a]; ids[n_fmus] = argv[++a]; tokens[n_fmus] = argv[++a]; ++n_fmus;
        } else if (!strcmp(argv[a], "-s") && a + 3 < argc && n_sets < 128) {
            sets[n_sets].i = atoi(argv[++a]); sets[n_sets].vr = (uint32_t)atol(argv[++a]);
            sets[n_sets].value = strtod(argv[++a], NULL); ++n_sets;
        } else if (!strcmp(argv[a], "-c") && a + 4 < argc && n_conns < 32) {
            conns[n_conns].i = atoi(argv[++a]); conns[n_conns].vr = (uint32_t)atol(argv[++a]);
            conns[n_conns].j = atoi(argv[++a]); conns[n_conns].to = (uint32_t)atol(argv[++a]); ++n_conns;
        } else if (!strcmp(argv[a], "-o") && a + 2 < argc && n_outs < 32) {
            outs[n_outs].i = atoi(argv[++a]); outs[n_outs].vr = (uint32_t)atol(argv[++a]); ++n_outs;
        } else { fprintf(stderr, "fmi3_host: bad argument %s\n", argv[a]); return 2; }
    }
    if (h <= 0 || steps < 0 || !n_fmus) return 2;

    for (int i = 0; i < n_fmus; ++i) {
        char path[4096], resources[4096];
        snprintf(path, sizeof path, "%s/binaries/x86_64-linux/%s.so", dirs[i], ids[i]);
        snprintf(resources, sizeof resources, "%s/resources/", dirs[i]);
        fmu_t *f = &fmus[i];
        f->lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (!f->lib) { fprintf(stderr, "fmi3_host: %s\n", dlerror()); return 3; }
        fmi3Instance (*instantiate)(const char *, const char *, const char *, bool, bool, bool, bool,
                                    const uint32_t *, size_t, void *, log_t, void *) =
            (fmi3Instance (*)(const char *, const char *, const char *, bool, bool, bool, bool,
                              const uint32_t *, size_t, void *, log_t, void *))dlsym(f->lib, "fmi3InstantiateCoSimulation");
        f->set = (fmi3Status (*)(fmi3Instance, const uint32_t *, size_t, const double *, size_t))dlsym(f->lib, "fmi3SetFloat64");
        f->get = (fmi3Status (*)(fmi3Instance, const uint32_t *, size_t, double *, size_t))dlsym(f->lib, "fmi3GetFloat64");
        f->step = (fmi3Status (*)(fmi3Instance, double, double, bool, bool *, bool *, bool *, double *))dlsym(f->lib, "fmi3DoStep");
        if (!instantiate || !f->set || !f->get || !f->step) { fprintf(stderr, "fmi3_host: missing functions\n"); return 3; }
        char name[32];
        snprintf(name, sizeof name, "fmu%d", i);
        f->c = instantiate(name, tokens[i], resources, false, false, false, false, NULL, 0, NULL, logger, NULL);
        if (!f->c) { fprintf(stderr, "fmi3_host: fmi3InstantiateCoSimulation of %s returned NULL\n", ids[i]); return 3; }
        fmi3Status (*enter)(fmi3Instance, bool, double, double, bool, double) =
            (fmi3Status (*)(fmi3Instance, bool, double, double, bool, double))dlsym(f->lib, "fmi3EnterInitializationMode");
        if (!check(enter(f->c, false, 0.0, 0.0, false, 0.0), "fmi3EnterInitializationMode", i)) return 4;
    }
    for (int s = 0; s < n_sets; ++s)
        if (!check(fmus[sets[s].i].set(fmus[sets[s].i].c, &sets[s].vr, 1, &sets[s].value, 1), "fmi3SetFloat64", sets[s].i))
            return 4;
    for (int i = 0; i < n_fmus; ++i) {
        fmi3Status (*exit_init)(fmi3Instance) = (fmi3Status (*)(fmi3Instance))dlsym(fmus[i].lib, "fmi3ExitInitializationMode");
        if (!check(exit_init(fmus[i].c), "fmi3ExitInitializationMode", i)) return 4;
    }
    for (long k = 0; k <= steps; ++k) {
        double t = (double)k * h;
        printf("%.17g", t);
        for (int o = 0; o < n_outs; ++o) {
            double value;
            if (!check(fmus[outs[o].i].get(fmus[outs[o].i].c, &outs[o].vr, 1, &value, 1), "fmi3GetFloat64", outs[o].i)) return 4;
            printf(",%.17g", value);
        }
        printf("\n");
        if (k == steps) break;
        for (int q = 0; q < n_conns; ++q) {
            double value;
            if (!check(fmus[conns[q].i].get(fmus[conns[q].i].c, &conns[q].vr, 1, &value, 1), "fmi3GetFloat64", conns[q].i)) return 4;
            if (!check(fmus[conns[q].j].set(fmus[conns[q].j].c, &conns[q].to, 1, &value, 1), "fmi3SetFloat64", conns[q].j)) return 4;
        }
        for (int i = 0; i < n_fmus; ++i) {
            bool event = false, terminate = false, early = false;
            double last = 0.0;
            if (!check(fmus[i].step(fmus[i].c, t, h, true, &event, &terminate, &early, &last), "fmi3DoStep", i)) return 4;
        }
    }
    if (extra) {
        fmi3Status (*get32)(fmi3Instance, const uint32_t *, size_t, float *, size_t) =
            (fmi3Status (*)(fmi3Instance, const uint32_t *, size_t, float *, size_t))dlsym(fmus[0].lib, "fmi3GetFloat32");
        uint32_t vr = 0;
        float value = 0;
        printf("fmi3GetFloat32 %d\n", get32(fmus[0].c, &vr, 1, &value, 1));
    }
    for (int i = 0; i < n_fmus; ++i) {
        fmi3Status (*terminate)(fmi3Instance) = (fmi3Status (*)(fmi3Instance))dlsym(fmus[i].lib, "fmi3Terminate");
        void (*free_instance)(fmi3Instance) = (void (*)(fmi3Instance))dlsym(fmus[i].lib, "fmi3FreeInstance");
        terminate(fmus[i].c);
        free_instance(fmus[i].c);
    }
    return 0;
}
