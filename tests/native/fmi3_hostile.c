/* Hostile arguments of fmi3InstantiateCoSimulation from a C host (issue 30).
 *
 * usage: fmi3_hostile UNZIPPED_DIR MODEL_IDENTIFIER TOKEN RESOURCE_PATH NAME TOKEN_ARG [CYCLES]
 *   "NULL" is a NULL pointer, "OWN" the right value (RESOURCE_PATH: <dir>/resources/),
 *   anything else is passed as is. Prints "fmi3InstantiateCoSimulation instance|NULL", then
 *   "done"; the FMU's messages go to stderr as "log <status> <category>: <message>".
 *   CYCLES: instantiate/free that many times after 200 to warm up; prints "rss BEFORE AFTER".
 */
#include <dlfcn.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi3Instance;

static void logger(void *env, int status, const char *category, const char *message)
{
    (void)env;
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

static const char *pick(const char *arg, const char *own)
{
    if (!strcmp(arg, "NULL")) return NULL;
    if (!strcmp(arg, "OWN")) return own;
    return arg;
}

int main(int argc, char **argv)
{
    if (argc != 7 && argc != 8) return 2;
    char path[4096], resources[4096];
    snprintf(path, sizeof path, "%s/binaries/x86_64-linux/%s.so", argv[1], argv[2]);
    snprintf(resources, sizeof resources, "%s/resources/", argv[1]);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 3; }
    typedef fmi3Instance (*inst_t)(const char *, const char *, const char *, bool, bool, bool, bool,
                                   const uint32_t *, size_t, void *,
                                   void (*)(void *, int, const char *, const char *), void *);
    inst_t instantiate = (inst_t)dlsym(lib, "fmi3InstantiateCoSimulation");
    void (*free_instance)(fmi3Instance) = (void (*)(fmi3Instance))dlsym(lib, "fmi3FreeInstance");
    if (!instantiate || !free_instance) return 3;
    if (argc == 8) {
        long n = atol(argv[7]), before = 0;
        for (long i = -200; i < n; ++i) {
            if (i == 0) before = rss_bytes();
            fmi3Instance c = instantiate(pick(argv[5], "hostile"), pick(argv[6], argv[3]), pick(argv[4], resources),
                                         false, false, false, false, NULL, 0, NULL, logger, NULL);
            if (!c) { fprintf(stderr, "instantiate failed in cycle %ld\n", i); return 3; }
            free_instance(c);
        }
        printf("rss %ld %ld\n", before, rss_bytes());
        return 0;
    }
    fmi3Instance c = instantiate(pick(argv[5], "hostile"), pick(argv[6], argv[3]),
                                 pick(argv[4], resources), false, false, false, false, NULL, 0,
                                 NULL, logger, NULL);
    printf("fmi3InstantiateCoSimulation %s\n", c ? "instance" : "NULL");
    if (c) free_instance(c);
    printf("done\n");
    return 0;
}
