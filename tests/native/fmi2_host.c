/* A minimal FMI 2.0 co-simulation host in plain C: what a native tool does with an FMU.
 * No Python anywhere in this process; the FMU has to find one itself.
 *
 * usage: fmi2_host -h STEP -n STEPS
 *                  -f UNZIPPED_DIR MODEL_IDENTIFIER GUID   (repeat: FMU 0, 1, ...)
 *                  -s I VR VALUE      set real parameter/start VR of FMU I before initialization
 *                  -i I VR VALUE      the same for an integer variable
 *                  -c I VR J VR       before every step, output VR of I -> input VR of J
 *                  -u I VR FILE       before step k, input VR of I = line k of FILE
 *                  -o I VR            print output VR of I at every communication point
 * Fixed steps t_k = k * STEP (integer step count, no accumulated time), Jacobi coupling: all
 * connections are read at t_k, then every FMU steps. Prints "t,out..." lines from t_0 on.
 * Exit status: 0 success, 2 usage, 3 load/instantiate failure, 4 an FMI call failed.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_types.h"

static const char *status_names[] = { "OK", "Warning", "Discard", "Error", "Fatal", "Pending" };

static void logger(void *env, const char *name, fmi2Status status, const char *category,
                   const char *message, ...)
{
    (void)env;
    char text[4096];
    va_list args;
    va_start(args, message);
    vsnprintf(text, sizeof text, message, args);
    va_end(args);
    fprintf(stderr, "[%s] %s %s: %s\n", status >= 0 && status <= 5 ? status_names[status] : "?",
            name ? name : "", category ? category : "", text);
}

#define MAX 16
typedef struct {
    void *lib;
    fmi2Component c;
    fmi2Component (*instantiate)(const char *, int, const char *, const char *,
                                 const fmi2CallbackFunctions *, int, int);
    fmi2Status (*setup)(fmi2Component, int, double, double, int, double);
    fmi2Status (*enter_init)(fmi2Component);
    fmi2Status (*exit_init)(fmi2Component);
    fmi2Status (*set_real)(fmi2Component, const fmi2ValueReference *, size_t, const double *);
    fmi2Status (*set_integer)(fmi2Component, const fmi2ValueReference *, size_t, const int *);
    fmi2Status (*get_real)(fmi2Component, const fmi2ValueReference *, size_t, double *);
    fmi2Status (*do_step)(fmi2Component, double, double, int);
    fmi2Status (*terminate)(fmi2Component);
    void (*free_instance)(fmi2Component);
} fmu_t;

static int check(fmi2Status status, const char *call, int i)
{
    if (status > 1) {
        fprintf(stderr, "fmi2_host: %s of FMU %d returned fmi2%s\n", call, i,
                status <= 5 ? status_names[status] : "?");
        return 0;
    }
    return 1;
}

static void *sym(void *lib, const char *name)
{
    void *p = dlsym(lib, name);
    if (!p) fprintf(stderr, "fmi2_host: %s missing: %s\n", name, dlerror());
    return p;
}

int main(int argc, char **argv)
{
    double h = 0;
    long steps = -1;
    fmu_t fmus[MAX];
    int n_fmus = 0;
    struct { int i; unsigned vr; double value; int integer; } sets[256];
    int n_sets = 0;
    struct { int i; unsigned vr; int j; unsigned vr_to; } conns[64];
    int n_conns = 0;
    struct { int i; unsigned vr; double *values; } inputs[8];
    int n_inputs = 0;
    struct { int i; unsigned vr; } outs[64];
    int n_outs = 0;
    const char *dirs[MAX], *ids[MAX], *guids[MAX];
    memset(fmus, 0, sizeof fmus);

    for (int a = 1; a < argc; ++a) {
        if (!strcmp(argv[a], "-h") && a + 1 < argc) h = atof(argv[++a]);
        else if (!strcmp(argv[a], "-n") && a + 1 < argc) steps = atol(argv[++a]);
        else if (!strcmp(argv[a], "-f") && a + 3 < argc && n_fmus < MAX) {
            dirs[n_fmus] = argv[++a]; ids[n_fmus] = argv[++a]; guids[n_fmus] = argv[++a]; ++n_fmus;
        } else if ((!strcmp(argv[a], "-s") || !strcmp(argv[a], "-i")) && a + 3 < argc && n_sets < 256) {
            sets[n_sets].integer = argv[a][1] == 'i';
            sets[n_sets].i = atoi(argv[++a]); sets[n_sets].vr = (unsigned)atol(argv[++a]);
            sets[n_sets].value = strtod(argv[++a], NULL); ++n_sets;
        } else if (!strcmp(argv[a], "-c") && a + 4 < argc && n_conns < 64) {
            conns[n_conns].i = atoi(argv[++a]); conns[n_conns].vr = (unsigned)atol(argv[++a]);
            conns[n_conns].j = atoi(argv[++a]); conns[n_conns].vr_to = (unsigned)atol(argv[++a]);
            ++n_conns;
        } else if (!strcmp(argv[a], "-u") && a + 3 < argc && n_inputs < 8) {
            inputs[n_inputs].i = atoi(argv[++a]); inputs[n_inputs].vr = (unsigned)atol(argv[++a]);
            const char *file = argv[++a];
            FILE *in = fopen(file, "r");
            if (!in || steps < 0) { fprintf(stderr, "fmi2_host: cannot read %s (give -n first)\n", file); return 2; }
            inputs[n_inputs].values = (double *)calloc((size_t)steps, sizeof(double));
            for (long k = 0; k < steps; ++k)
                if (fscanf(in, "%lf", &inputs[n_inputs].values[k]) != 1) {
                    fprintf(stderr, "fmi2_host: %s has fewer than %ld values\n", file, steps);
                    return 2;
                }
            fclose(in);
            ++n_inputs;
        } else if (!strcmp(argv[a], "-o") && a + 2 < argc && n_outs < 64) {
            outs[n_outs].i = atoi(argv[++a]); outs[n_outs].vr = (unsigned)atol(argv[++a]); ++n_outs;
        } else {
            fprintf(stderr, "fmi2_host: bad argument %s\n", argv[a]);
            return 2;
        }
    }
    if (h <= 0 || steps < 0 || n_fmus == 0) { fprintf(stderr, "fmi2_host: need -h, -n and -f\n"); return 2; }

    fmi2CallbackFunctions callbacks = { logger, calloc, free, NULL, NULL };
    for (int i = 0; i < n_fmus; ++i) {
        char path[4096], uri[4096];
        snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dirs[i], ids[i]);
        snprintf(uri, sizeof uri, "file://%s/resources", dirs[i]);
        fmu_t *f = &fmus[i];
        f->lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (!f->lib) { fprintf(stderr, "fmi2_host: cannot load %s: %s\n", path, dlerror()); return 3; }
        if (!(f->instantiate = sym(f->lib, "fmi2Instantiate")) || !(f->setup = sym(f->lib, "fmi2SetupExperiment"))
            || !(f->enter_init = sym(f->lib, "fmi2EnterInitializationMode"))
            || !(f->exit_init = sym(f->lib, "fmi2ExitInitializationMode"))
            || !(f->set_real = sym(f->lib, "fmi2SetReal")) || !(f->set_integer = sym(f->lib, "fmi2SetInteger")) || !(f->get_real = sym(f->lib, "fmi2GetReal"))
            || !(f->do_step = sym(f->lib, "fmi2DoStep")) || !(f->terminate = sym(f->lib, "fmi2Terminate"))
            || !(f->free_instance = sym(f->lib, "fmi2FreeInstance")))
            return 3;
        char name[32];
        snprintf(name, sizeof name, "fmu%d", i);
        f->c = f->instantiate(name, 1 /* fmi2CoSimulation */, guids[i], uri, &callbacks, 0, 0);
        if (!f->c) { fprintf(stderr, "fmi2_host: fmi2Instantiate of %s returned NULL\n", ids[i]); return 3; }
        if (!check(f->setup(f->c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment", i)) return 4;
        if (!check(f->enter_init(f->c), "fmi2EnterInitializationMode", i)) return 4;
    }
    for (int s = 0; s < n_sets; ++s) {
        fmu_t *f = &fmus[sets[s].i];
        int integer = (int)sets[s].value;
        fmi2Status status = sets[s].integer ? f->set_integer(f->c, &sets[s].vr, 1, &integer)
                                            : f->set_real(f->c, &sets[s].vr, 1, &sets[s].value);
        if (!check(status, sets[s].integer ? "fmi2SetInteger" : "fmi2SetReal", sets[s].i)) return 4;
    }
    for (int i = 0; i < n_fmus; ++i)
        if (!check(fmus[i].exit_init(fmus[i].c), "fmi2ExitInitializationMode", i)) return 4;

    for (long k = 0; k <= steps; ++k) {
        double t = (double)k * h;
        printf("%.17g", t);
        for (int o = 0; o < n_outs; ++o) {
            double value;
            if (!check(fmus[outs[o].i].get_real(fmus[outs[o].i].c, &outs[o].vr, 1, &value), "fmi2GetReal", outs[o].i))
                return 4;
            printf(",%.17g", value);
        }
        printf("\n");
        if (k == steps) break;
        for (int q = 0; q < n_conns; ++q) {
            double value;
            if (!check(fmus[conns[q].i].get_real(fmus[conns[q].i].c, &conns[q].vr, 1, &value), "fmi2GetReal", conns[q].i))
                return 4;
            if (!check(fmus[conns[q].j].set_real(fmus[conns[q].j].c, &conns[q].vr_to, 1, &value), "fmi2SetReal", conns[q].j))
                return 4;
        }
        for (int u = 0; u < n_inputs; ++u)
            if (!check(fmus[inputs[u].i].set_real(fmus[inputs[u].i].c, &inputs[u].vr, 1, &inputs[u].values[k]), "fmi2SetReal", inputs[u].i))
                return 4;
        for (int i = 0; i < n_fmus; ++i)
            if (!check(fmus[i].do_step(fmus[i].c, t, h, 1), "fmi2DoStep", i)) return 4;
    }
    for (int i = 0; i < n_fmus; ++i) {
        fmus[i].terminate(fmus[i].c);
        fmus[i].free_instance(fmus[i].c);
    }
    return 0;
}
