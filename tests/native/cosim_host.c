/* Run an SSP archive through libcosim's C API (libcosimc), from a plain C program: a native
 * co-simulation engine with no Python in the process. libcosimc ships no header in the
 * libcosimpy wheel, so the few declarations used are written out here (libcosimc's cosim.h).
 *
 * usage: cosim_host ARCHIVE STEP_NS STEPS INSTANCE.VARIABLE...
 * Prints "t,value..." for steps 1..STEPS (time in seconds, values after each step).
 * Exit status: 0 success, 2 usage, 3 libcosim error (its message on stderr).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SLAVE_NAME_MAX_SIZE 1024
typedef struct cosim_execution_s cosim_execution;
typedef struct cosim_observer_s cosim_observer;
typedef struct { char name[SLAVE_NAME_MAX_SIZE]; int index; } cosim_slave_info;
typedef struct {
    char name[SLAVE_NAME_MAX_SIZE];
    uint32_t reference;
    int type, causality, variability;
} cosim_variable_description;
enum { COSIM_VARIABLE_TYPE_REAL = 0 };
enum { COSIM_LOG_SEVERITY_WARNING = 3 };

cosim_execution *cosim_ssp_fixed_step_execution_create(const char *, int, int64_t, int64_t);
int cosim_execution_destroy(cosim_execution *);
size_t cosim_execution_get_num_slaves(cosim_execution *);
int cosim_execution_get_slave_infos(cosim_execution *, cosim_slave_info[], size_t);
int cosim_slave_get_num_variables(cosim_execution *, int);
int cosim_slave_get_variables(cosim_execution *, int, cosim_variable_description[], size_t);
cosim_observer *cosim_buffered_time_series_observer_create(size_t);
int cosim_observer_destroy(cosim_observer *);
int cosim_execution_add_observer(cosim_execution *, cosim_observer *);
int cosim_observer_start_observing(cosim_observer *, int, int, uint32_t);
int cosim_execution_simulate_until(cosim_execution *, int64_t);
int64_t cosim_observer_slave_get_real_samples(cosim_observer *, int, uint32_t, int64_t, size_t, /* values, step numbers, time points */
                                              double[], int64_t[], int64_t[]);
int cosim_last_error_code(void);
const char *cosim_last_error_message(void);
int cosim_log_setup_simple_console_logging(void);
void cosim_log_set_output_level(int);

static int fail(const char *what)
{
    fprintf(stderr, "cosim_host: %s: %s\n", what, cosim_last_error_message());
    return 3;
}

int main(int argc, char **argv)
{
    if (argc < 5) { fprintf(stderr, "usage: cosim_host ARCHIVE STEP_NS STEPS INSTANCE.VARIABLE...\n"); return 2; }
    int64_t h = atoll(argv[2]);
    long n = atol(argv[3]);
    int n_vars = argc - 4;
    cosim_log_setup_simple_console_logging();
    cosim_log_set_output_level(COSIM_LOG_SEVERITY_WARNING);

    cosim_execution *execution = cosim_ssp_fixed_step_execution_create(argv[1], 0, 0, h);
    if (!execution) return fail("cosim_ssp_fixed_step_execution_create");
    cosim_observer *observer = cosim_buffered_time_series_observer_create((size_t)n + 1);
    if (!observer || cosim_execution_add_observer(execution, observer) < 0) return fail("observer");

    size_t n_slaves = cosim_execution_get_num_slaves(execution);
    cosim_slave_info *slaves = calloc(n_slaves, sizeof *slaves);
    if (cosim_execution_get_slave_infos(execution, slaves, n_slaves) < 0) return fail("slave infos");
    int *slave_of = calloc((size_t)n_vars, sizeof(int));
    uint32_t *ref_of = calloc((size_t)n_vars, sizeof(uint32_t));
    for (int k = 0; k < n_vars; ++k) {
        const char *dot = strchr(argv[4 + k], '.');
        if (!dot) { fprintf(stderr, "cosim_host: %s is not INSTANCE.VARIABLE\n", argv[4 + k]); return 2; }
        size_t len = (size_t)(dot - argv[4 + k]);
        int found = 0;
        for (size_t s = 0; s < n_slaves && !found; ++s) {
            if (strlen(slaves[s].name) != len || strncmp(slaves[s].name, argv[4 + k], len)) continue;
            int nv = cosim_slave_get_num_variables(execution, slaves[s].index);
            cosim_variable_description *vars = calloc((size_t)nv, sizeof *vars);
            cosim_slave_get_variables(execution, slaves[s].index, vars, (size_t)nv);
            for (int v = 0; v < nv && !found; ++v)
                if (!strcmp(vars[v].name, dot + 1) && vars[v].type == COSIM_VARIABLE_TYPE_REAL) {
                    slave_of[k] = slaves[s].index;
                    ref_of[k] = vars[v].reference;
                    found = 1;
                }
            free(vars);
        }
        if (!found) { fprintf(stderr, "cosim_host: no real variable %s\n", argv[4 + k]); return 2; }
        if (cosim_observer_start_observing(observer, slave_of[k], COSIM_VARIABLE_TYPE_REAL, ref_of[k]) < 0)
            return fail("start observing");
    }
    if (cosim_execution_simulate_until(execution, (int64_t)n * h) < 0) return fail("simulate_until");

    double **values = calloc((size_t)n_vars, sizeof(double *));
    int64_t *times = calloc((size_t)n, sizeof(int64_t)), *step_numbers = calloc((size_t)n, sizeof(int64_t));
    int64_t got = n;
    for (int k = 0; k < n_vars; ++k) {
        values[k] = calloc((size_t)n, sizeof(double));
        int64_t count = cosim_observer_slave_get_real_samples(observer, slave_of[k], ref_of[k], 1, (size_t)n,
                                                              values[k], step_numbers, times);
        if (count < 0) return fail("get samples");
        if (count < got) got = count;
    }
    for (int64_t i = 0; i < got; ++i) {
        printf("%.17g", (double)times[i] * 1e-9);
        for (int k = 0; k < n_vars; ++k) printf(",%.17g", values[k][i]);
        printf("\n");
    }
    cosim_execution_destroy(execution);
    cosim_observer_destroy(observer);
    return 0;
}
