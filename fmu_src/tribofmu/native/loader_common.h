/* The part of the tribofmu loader that does not depend on the FMI version: finding a Python
 * interpreter for the pythonfmu binary, loading that binary, and the registry of live
 * instances and FMU states.
 *
 * Why a loader: pythonfmu's binary leaves the Python C API undefined (no DT_NEEDED on
 * libpython) and so loads only into a process that already has Python. This file is compiled
 * into binaries/<platform>/<model>.so at build time; on the first instantiation it makes sure
 * a Python is in the process (the host's own, or one it loads with RTLD_GLOBAL), then opens
 * the pythonfmu binary that sits beside it and forwards every call.
 *
 * Build-time definitions (tribofmu/build.py passes them with -D):
 *   TRIBOFMU_LIBPYTHON         absolute path of the building interpreter's libpython
 *   TRIBOFMU_LIBPYTHON_SONAME  its soname, tried through the dynamic loader's search path
 *   TRIBOFMU_PYTHON_EXECUTABLE the building interpreter (its venv, site-packages follow)
 *   TRIBOFMU_REQUIRED_MODULES  comma-separated modules the FMU imports (checked once loaded)
 * Environment: TRIBOFMU_LIBPYTHON names another libpython to load instead.
 */
#ifndef TRIBOFMU_LOADER_COMMON_H
#define TRIBOFMU_LOADER_COMMON_H

#define _GNU_SOURCE
#include <dlfcn.h>
#include <link.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <wchar.h>

#ifndef TRIBOFMU_LIBPYTHON
#define TRIBOFMU_LIBPYTHON ""
#endif
#ifndef TRIBOFMU_LIBPYTHON_SONAME
#define TRIBOFMU_LIBPYTHON_SONAME ""
#endif
#ifndef TRIBOFMU_PYTHON_EXECUTABLE
#define TRIBOFMU_PYTHON_EXECUTABLE ""
#endif
#ifndef TRIBOFMU_REQUIRED_MODULES
#define TRIBOFMU_REQUIRED_MODULES ""
#endif
#define TRIBOFMU_WRAPPER_FILE "libpythonfmu-export.so"
/* In resources/: the FMU's GUID (FMI 3.0: instantiation token), written by tribofmu/build.py,
 * for hosts that extract only binaries/ and resources/ (fmpy's simulate_fmu) */
#define TRIBOFMU_TOKEN_FILE "tribofmu-guid.txt"
#define TRIBOFMU_LIBPYTHON_ENV "TRIBOFMU_LIBPYTHON"
/* A message the Python side logs with this category sets the status of the call it was
 * logged in to at least the message's status (pythonfmu can only report OK, Discard from
 * doStep, or Fatal for an exception, which destroys the instance). */
#define TRIBOFMU_STATUS_CATEGORY "tribofmuCallStatus"

#define TF_EXPORT __attribute__((visibility("default")))
#define TF_MSG 4096

static pthread_mutex_t tf_lock = PTHREAD_MUTEX_INITIALIZER;

/* ---- text helpers --------------------------------------------------------------------- */

static void tf_append(char *buf, size_t size, const char *fmt, ...)
{
    size_t used = strlen(buf);
    if (used + 1 >= size) return;
    va_list args;
    va_start(args, fmt);
    vsnprintf(buf + used, size - used, fmt, args);
    va_end(args);
}

/* FMI 2.0 hands the message to the host as a printf format: double every '%'. */
__attribute__((unused)) static void tf_escape_percent(const char *in, char *out, size_t size)
{
    size_t j = 0;
    for (size_t i = 0; in[i] && j + 2 < size; ++i) {
        if (in[i] == '%') out[j++] = '%';
        out[j++] = in[i];
    }
    out[j] = '\0';
}

/* ---- the Python interpreter ----------------------------------------------------------- */

typedef int (*tf_is_initialized_t)(void);
typedef void (*tf_initialize_ex_t)(int);
typedef void (*tf_set_wstring_t)(const wchar_t *);
typedef wchar_t *(*tf_decode_locale_t)(const char *, size_t *);
typedef void *(*tf_save_thread_t)(void);
typedef int (*tf_run_string_t)(const char *);
typedef void *(*tf_add_module_t)(const char *);
typedef void *(*tf_get_attr_t)(void *, const char *);
typedef const char *(*tf_as_utf8_t)(void *);

static int tf_python_ready = 0;          /* 1: a usable interpreter is in the process */
static char tf_python_problem[TF_MSG];   /* why not, once tried and failed */

static int tf_same_file(const char *a, const char *b)
{
    char ra[PATH_MAX], rb[PATH_MAX];
    if (!a[0] || !b[0] || !realpath(a, ra) || !realpath(b, rb)) return 0;
    return strcmp(ra, rb) == 0;
}

struct tf_found_lib { char path[PATH_MAX]; };

static int tf_find_loaded_libpython(struct dl_phdr_info *info, size_t size, void *data)
{
    (void)size;
    const char *name = info->dlpi_name;
    const char *base = name ? strrchr(name, '/') : NULL;
    base = base ? base + 1 : name;
    if (base && strncmp(base, "libpython3", 10) == 0) {
        snprintf(((struct tf_found_lib *)data)->path, PATH_MAX, "%s", name);
        return 1;
    }
    return 0;
}

/* Python was loaded by us into a process without one: start it, say where its packages are,
 * check the FMU's imports, and release the GIL so any host thread can take it
 * (pythonfmu's calls use PyGILState_Ensure). Never finalized: it lives as long as the process. */
static int tf_start_interpreter(void *lib, const char *lib_path)
{
    tf_initialize_ex_t initialize = (tf_initialize_ex_t)dlsym(lib, "Py_InitializeEx");
    tf_save_thread_t save_thread = (tf_save_thread_t)dlsym(lib, "PyEval_SaveThread");
    tf_run_string_t run = (tf_run_string_t)dlsym(lib, "PyRun_SimpleString");
    tf_add_module_t add_module = (tf_add_module_t)dlsym(lib, "PyImport_AddModule");
    tf_get_attr_t get_attr = (tf_get_attr_t)dlsym(lib, "PyObject_GetAttrString");
    tf_as_utf8_t as_utf8 = (tf_as_utf8_t)dlsym(lib, "PyUnicode_AsUTF8");
    if (!initialize || !save_thread || !run || !add_module || !get_attr || !as_utf8) {
        snprintf(tf_python_problem, TF_MSG, "%s does not export the Python C API functions the "
                 "loader needs (Py_InitializeEx, PyEval_SaveThread, PyRun_SimpleString)", lib_path);
        return 0;
    }
    /* The building interpreter, when it is this library's: Python then computes its prefix,
     * virtual environment and site-packages exactly as when that interpreter runs.
     * (Py_SetProgramName: deprecated since 3.11 but exported through the 3.x ABI.) */
    const char *exe = TRIBOFMU_PYTHON_EXECUTABLE;
    tf_set_wstring_t set_program = (tf_set_wstring_t)dlsym(lib, "Py_SetProgramName");
    tf_decode_locale_t decode = (tf_decode_locale_t)dlsym(lib, "Py_DecodeLocale");
    char started_as[PATH_MAX + 32] = "";
    if (exe[0] && access(exe, X_OK) == 0 && tf_same_file(lib_path, TRIBOFMU_LIBPYTHON)
        && set_program && decode) {
        wchar_t *wide = decode(exe, NULL);  /* kept: Python reads it at initialization */
        if (wide) {
            set_program(wide);
            snprintf(started_as, sizeof started_as, " (started as %s)", exe);
        }
    }
    initialize(0);  /* 0: leave the host's signal handlers alone */
    char code[1024];
    snprintf(code, sizeof code,
             "import importlib.util as _u\n"
             "_tribofmu_missing = ', '.join(m for m in '%s'.split(',') if m and _u.find_spec(m) is None)\n"
             "del _u\n", TRIBOFMU_REQUIRED_MODULES);
    const char *missing = NULL;
    if (run(code) == 0) {
        void *main_module = add_module("__main__");
        void *value = main_module ? get_attr(main_module, "_tribofmu_missing") : NULL;
        missing = value ? as_utf8(value) : NULL;  /* the reference stays in __main__ */
    }
    int ok = missing && !missing[0];
    if (!ok) {
        snprintf(tf_python_problem, TF_MSG,
                 "the Python loaded from %s%s cannot import %s (needed by this FMU). Install them "
                 "into that Python with pip, or point %s at the libpython of a Python that has "
                 "them (an embedded Python finds packages in its own site-packages and PYTHONPATH)",
                 lib_path, started_as, missing ? missing : "its standard library", TRIBOFMU_LIBPYTHON_ENV);
    }
    save_thread();
    return ok;
}

static int tf_use_library(void *lib, const char *lib_path)
{
    tf_is_initialized_t is_initialized = (tf_is_initialized_t)dlsym(lib, "Py_IsInitialized");
    if (!is_initialized) {
        snprintf(tf_python_problem, TF_MSG, "%s is not a libpython (no Py_IsInitialized)", lib_path);
        return 0;
    }
    if (is_initialized()) return 1;  /* someone else started it: theirs to configure */
    return tf_start_interpreter(lib, lib_path);
}

/* Make sure a Python interpreter is in the process; 1 on success, else tf_python_problem says
 * what was looked for. Called under tf_lock. */
static int tf_ensure_python(void)
{
    if (tf_python_ready) return 1;
    if (tf_python_problem[0]) return 0;  /* tried and failed: the same answer every time */

    /* 1. The host is a Python process (fmpy, libcosimpy, ecospy...) or embeds one globally. */
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        struct tf_found_lib found = { "" };
        dl_iterate_phdr(tf_find_loaded_libpython, &found);
        tf_python_ready = tf_use_library(RTLD_DEFAULT, found.path[0] ? found.path : "the host process");
        return tf_python_ready;
    }
    /* 2. A libpython is loaded, but privately (RTLD_LOCAL): make its symbols global rather
     *    than load a second interpreter. */
    struct tf_found_lib found = { "" };
    if (dl_iterate_phdr(tf_find_loaded_libpython, &found)) {
        void *lib = dlopen(found.path, RTLD_NOW | RTLD_NOLOAD | RTLD_GLOBAL);
        if (lib) {
            tf_python_ready = tf_use_library(lib, found.path);
            return tf_python_ready;
        }
    }
    /* 3. Load one: the user's choice, else the building interpreter's, else its soname
     *    through the dynamic loader's search path (LD_LIBRARY_PATH, ld.so.cache). */
    const char *chosen = getenv(TRIBOFMU_LIBPYTHON_ENV);
    const char *candidates[3];
    int n = 0;
    if (chosen && chosen[0]) {
        candidates[n++] = chosen;
    } else {
        if (TRIBOFMU_LIBPYTHON[0]) candidates[n++] = TRIBOFMU_LIBPYTHON;
        if (TRIBOFMU_LIBPYTHON_SONAME[0]) candidates[n++] = TRIBOFMU_LIBPYTHON_SONAME;
    }
    char tried[TF_MSG] = "";
    for (int i = 0; i < n; ++i) {
        void *lib = dlopen(candidates[i], RTLD_NOW | RTLD_GLOBAL);
        if (lib) {
            tf_python_ready = tf_use_library(lib, candidates[i]);
            return tf_python_ready;
        }
        const char *err = dlerror();
        tf_append(tried, sizeof tried, "%s%s (%s)", i ? "; " : "", candidates[i], err ? err : "not loadable");
    }
    if (chosen && chosen[0]) {
        snprintf(tf_python_problem, TF_MSG,
                 "no Python interpreter for this FMU: the host process has none, and %s=%s "
                 "could not be loaded: %s. Set %s to the full path of a shared libpython3.X.so "
                 "(python3 -c \"import sysconfig as s; print(s.get_config_var('LIBDIR') + '/' + "
                 "s.get_config_var('INSTSONAME'))\")", TRIBOFMU_LIBPYTHON_ENV, chosen, tried,
                 TRIBOFMU_LIBPYTHON_ENV);
    } else {
        snprintf(tf_python_problem, TF_MSG,
                 "no Python interpreter for this FMU: the host process has none, and the Python "
                 "the FMU was built with could not be loaded: tried %s. Install that Python with "
                 "its shared library (and the packages %s), or set %s to the full path of the "
                 "shared libpython3.X.so of a Python that has those packages",
                 n ? tried : "nothing (no libpython was recorded at build time)",
                 TRIBOFMU_REQUIRED_MODULES, TRIBOFMU_LIBPYTHON_ENV);
    }
    return 0;
}

/* ---- the pythonfmu binary beside this file -------------------------------------------- */

static void *tf_wrapper = NULL;
static char tf_wrapper_problem[TF_MSG];

/* pythonfmu's binary (0.7.0, and pythonfmu3's) keeps its interpreter guard in a namespace-scope
 * std::shared_ptr<PyState> (the PyState owns a thread) and resets it from an
 * __attribute__((destructor)) function, finalizePythonInterpreter (exported). On a dlclose that
 * order would be right (destructor functions run before __cxa_finalize destroys the static),
 * but glibc never unloads that binary: it defines STB_GNU_UNIQUE symbols (libstdc++ template
 * statics), which make it undeletable. So every copy ever loaded is still there at exit, where
 * the order is wrong: exit() runs every __cxa_atexit handler first (the static's destructor
 * frees the shared_ptr's control block and leaves the pointer), then _dl_fini calls
 * finalizePythonInterpreter, which releases the freed control block again: it decrements a
 * word of a free heap chunk (a tcache key, or the back link of a chunk in an unsorted or small
 * bin), and a later free at exit may abort with "corrupted double-linked list" (SIGABRT, exit
 * 134), depending on the heap layout.
 *
 * So the loader releases the guard itself while the static is alive: at exit from an exit
 * handler registered after the binary was opened (handlers run last-in first-out, so before
 * the binary's static destructor), and when the host unloads this loader, from its destructor
 * function, which then also closes its handle on the binary. Releasing the guard is safe at
 * any time: with Python already running (always, by tf_ensure_python) the guard's thread has
 * finished at once, and the next instantiation makes a new guard. */
typedef void (*tf_finalize_t)(void);
static int tf_exiting = 0;

static void tf_release_wrapper_state(void)
{
    tf_finalize_t release = tf_wrapper ? (tf_finalize_t)dlsym(tf_wrapper, "finalizePythonInterpreter") : NULL;
    if (release) release();
}

static void tf_at_exit(void)
{
    pthread_mutex_lock(&tf_lock);
    tf_exiting = 1;  /* the process ends: leave the binary mapped, only release its guard */
    tf_release_wrapper_state();
    pthread_mutex_unlock(&tf_lock);
}

/* Runs when the host dlcloses this loader (before the loader's own exit handlers, so
 * tf_at_exit then finds nothing to do), and at exit after tf_at_exit (then it does nothing). */
__attribute__((destructor)) static void tf_at_unload(void)
{
    pthread_mutex_lock(&tf_lock);
    if (tf_wrapper && !tf_exiting) {
        tf_release_wrapper_state();
        dlclose(tf_wrapper);
        tf_wrapper = NULL;
    }
    pthread_mutex_unlock(&tf_lock);
}

static void *tf_open_wrapper(void)
{
    if (tf_wrapper) return tf_wrapper;
    Dl_info info;
    char path[PATH_MAX];
    if (!dladdr((void *)&tf_open_wrapper, &info) || !info.dli_fname) {
        snprintf(tf_wrapper_problem, TF_MSG, "cannot locate the FMU's own binary (dladdr failed)");
        return NULL;
    }
    snprintf(path, sizeof path, "%s", info.dli_fname);
    char *slash = strrchr(path, '/');
    if (slash) slash[1] = '\0'; else path[0] = '\0';
    tf_append(path, sizeof path, "%s", TRIBOFMU_WRAPPER_FILE);
    /* RTLD_LOCAL: its fmi* symbols must not interpose ours for other FMUs. */
    tf_wrapper = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!tf_wrapper) {
        const char *err = dlerror();
        snprintf(tf_wrapper_problem, TF_MSG, "cannot load the pythonfmu binary %s: %s", path,
                 err ? err : "unknown error");
        return NULL;
    }
    /* after the dlopen, so that at exit it runs before the binary's static destructors */
    static int registered = 0;
    if (!registered && atexit(tf_at_exit) == 0) registered = 1;
    return tf_wrapper;
}

static void *tf_sym(const char *name)
{
    return tf_wrapper ? dlsym(tf_wrapper, name) : NULL;
}

/* ---- instantiate's arguments: what pythonfmu's binary would crash on ------------------ */
/* pythonfmu (and pythonfmu3) build a std::string from the resource location and the instance
 * name (NULL: std::logic_error out of extern "C", the host aborts), cut "file://" out of the
 * location wherever it occurs, and then read <resources>/slavemodule.txt and the model's .py
 * without checking either (a missing folder or file: a crash in its Python calls). So the
 * loader checks them first; each problem is one message and a NULL instance. */

#include <sys/stat.h>
#include <ctype.h>

static int tf_hex(int c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static int tf_is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static int tf_is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Quote a host-given text for a message: at most 200 bytes, unprintable bytes as '?'. */
static void tf_quote(const char *text, char *out, size_t size)
{
    size_t j = 0;
    if (size < 8) { if (size) out[0] = '\0'; return; }
    out[j++] = '"';
    for (size_t i = 0; text[i] && j + 5 < size; ++i) {
        if (i >= 200) { out[j++] = '.'; out[j++] = '.'; out[j++] = '.'; break; }
        unsigned char ch = (unsigned char)text[i];
        out[j++] = (ch >= 32 && ch < 127) ? (char)ch : '?';
    }
    out[j++] = '"';
    out[j] = '\0';
}

/* The resources folder the host names, as an absolute, existing path in folder (no trailing
 * '/'), holding slavemodule.txt and the model's .py; NULL, or what is wrong (in problem).
 * Accepted: a file: URI of this machine (file:///abs, file://localhost/abs, file:/abs,
 * %-escapes decoded) and, as pythonfmu accepts it, an absolute path. */
static const char *tf_check_resources(const char *arg, const char *location, char *folder,
                                      size_t size, char *problem, size_t psize)
{
    char quoted[256];
    if (!location) {
        snprintf(problem, psize, "%s is NULL: it must name the FMU's resources folder "
                 "(file:///<unzipped FMU>/resources)", arg);
        return problem;
    }
    tf_quote(location, quoted, sizeof quoted);
    if (!location[0]) {
        snprintf(problem, psize, "%s is empty: it must name the FMU's resources folder "
                 "(file:///<unzipped FMU>/resources)", arg);
        return problem;
    }
    const char *path = location;
    if (strncmp(location, "file:", 5) == 0) {
        path = location + 5;
        if (strncmp(path, "//", 2) == 0) {  /* an authority: empty or localhost */
            path += 2;
            const char *slash = strchr(path, '/');
            size_t host = slash ? (size_t)(slash - path) : strlen(path);
            if (!(host == 0 || (host == 9 && strncmp(path, "localhost", 9) == 0))) {
                snprintf(problem, psize, "%s %s names another host: only a folder on this "
                         "machine can be used (file:///<unzipped FMU>/resources)", arg, quoted);
                return problem;
            }
            path += host;
        }
    } else {
        const char *colon = strchr(location, ':');
        const char *slash = strchr(location, '/');
        if (colon && (!slash || colon < slash)) {
            snprintf(problem, psize, "%s %s is not a file: URI: the FMU's resources must be a "
                     "folder on this machine (file:///<unzipped FMU>/resources)", arg, quoted);
            return problem;
        }
    }
    char decoded[PATH_MAX];
    size_t j = 0;
    for (size_t i = 0; path[i]; ++i) {
        int ch = (unsigned char)path[i];
        if (ch == '%') {
            int hi = tf_hex(path[i + 1]), lo = hi < 0 ? -1 : tf_hex(path[i + 2]);
            if (hi < 0 || lo < 0 || (hi == 0 && lo == 0)) {
                snprintf(problem, psize, "%s %s has a bad %%-escape", arg, quoted);
                return problem;
            }
            ch = 16 * hi + lo;
            i += 2;
        }
        if (j + 1 >= sizeof decoded) {
            snprintf(problem, psize, "%s %s is longer than a path can be", arg, quoted);
            return problem;
        }
        decoded[j++] = (char)ch;
    }
    decoded[j] = '\0';
    if (decoded[0] != '/') {
        snprintf(problem, psize, "%s %s is not an absolute file: URI or path (a relative "
                 "location has no defined meaning; use file:///<unzipped FMU>/resources)",
                 arg, quoted);
        return problem;
    }
    char real[PATH_MAX];
    if (!realpath(decoded, real) || !tf_is_dir(real)) {
        snprintf(problem, psize, "%s %s: the folder %s does not exist (is the FMU unzipped "
                 "there, with its resources folder?)", arg, quoted, decoded);
        return problem;
    }
    /* pythonfmu would rewrite these inside the path it is given */
    if (strstr(real, "%20") || strstr(real, "file://")) {
        snprintf(problem, psize, "%s %s: the path %s contains \"%%20\" or \"file://\", which "
                 "pythonfmu's binary would rewrite: unzip the FMU elsewhere", arg, quoted, real);
        return problem;
    }
    char file[PATH_MAX + 64];
    snprintf(file, sizeof file, "%s/slavemodule.txt", real);
    FILE *f = tf_is_file(file) ? fopen(file, "r") : NULL;
    char module[256] = "";
    if (f) {
        if (!fgets(module, sizeof module, f)) module[0] = '\0';
        fclose(f);
    }
    module[strcspn(module, "\r\n")] = '\0';
    int name_ok = module[0] != '\0';
    for (size_t i = 0; module[i]; ++i)
        if (!(isalnum((unsigned char)module[i]) || module[i] == '_')) name_ok = 0;
    if (!f || !name_ok) {
        snprintf(problem, psize, "the FMU's resources folder %s has no readable slavemodule.txt "
                 "naming the model's module: the FMU is damaged or %s is not its resources "
                 "folder", real, arg);
        return problem;
    }
    snprintf(file, sizeof file, "%s/%s.py", real, module);
    if (!tf_is_file(file) || access(file, R_OK) != 0) {
        snprintf(problem, psize, "the FMU's resources folder %s lacks the model's file %s.py: "
                 "the FMU is damaged", real, module);
        return problem;
    }
    snprintf(folder, size, "%s", real);
    return NULL;
}

/* The value of attribute (guid, instantiationToken) in the modelDescription.xml at path; 1 if
 * found. Under tf_lock (one static buffer). */
static int tf_token_in_description(const char *path, const char *attribute, char *value, size_t size)
{
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    static char text[1 << 16];  /* the root element's attributes come first */
    size_t got = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[got] = '\0';
    char *root = strstr(text, "<fmiModelDescription");
    char *end = root ? strchr(root, '>') : NULL;
    if (!root || !end) return 0;
    *end = '\0';
    char key[64];
    snprintf(key, sizeof key, "%s=\"", attribute);
    char *at = root;
    while ((at = strstr(at, key)) != NULL && !isspace((unsigned char)at[-1])) at += 1;
    if (!at) return 0;
    at += strlen(key);
    char *close = strchr(at, '"');
    if (!close || (size_t)(close - at) >= size) return 0;
    memcpy(value, at, (size_t)(close - at));
    value[close - at] = '\0';
    return 1;
}

/* The FMU's GUID (instantiation token): from the modelDescription.xml of the FMU this binary
 * belongs to (<FMU>/binaries/<platform>/<model>.so), else from resources/TRIBOFMU_TOKEN_FILE
 * (written from it at build time), else from resources/../modelDescription.xml; 1 if found. */
static int tf_read_token(const char *attribute, const char *resources, char *value, size_t size)
{
    char path[PATH_MAX + 64];
    Dl_info info;
    if (dladdr((void *)&tf_read_token, &info) && info.dli_fname) {
        char real[PATH_MAX];
        if (realpath(info.dli_fname, real)) {
            for (int up = 0; up < 3; ++up) {
                char *slash = strrchr(real, '/');
                if (slash) *slash = '\0';
            }
            snprintf(path, sizeof path, "%s/modelDescription.xml", real);
            if (tf_token_in_description(path, attribute, value, size)) return 1;
        }
    }
    snprintf(path, sizeof path, "%s/" TRIBOFMU_TOKEN_FILE, resources);
    FILE *f = fopen(path, "r");
    if (f) {
        int ok = fgets(value, (int)size, f) != NULL;
        fclose(f);
        value[ok ? strcspn(value, "\r\n") : 0] = '\0';
        if (ok && value[0]) return 1;
    }
    snprintf(path, sizeof path, "%s/../modelDescription.xml", resources);
    return tf_token_in_description(path, attribute, value, size);
}

/* The host's GUID (FMI 3.0: instantiation token) against the FMU's own; NULL if they agree. */
static const char *tf_check_token(const char *arg, const char *attribute, const char *given,
                                  const char *resources, char *problem, size_t psize)
{
    char own[512], quoted[256];
    if (!given) {
        snprintf(problem, psize, "%s is NULL: it must be the %s of the FMU's modelDescription.xml",
                 arg, attribute);
        return problem;
    }
    pthread_mutex_lock(&tf_lock);
    int found = tf_read_token(attribute, resources, own, sizeof own);
    pthread_mutex_unlock(&tf_lock);
    if (!found) {
        snprintf(problem, psize, "cannot check %s: the FMU's modelDescription.xml (beside its "
                 "binaries folder) and resources/" TRIBOFMU_TOKEN_FILE " are missing or name no "
                 "%s: the FMU is damaged", arg, attribute);
        return problem;
    }
    if (strcmp(given, own) != 0) {
        tf_quote(given, quoted, sizeof quoted);
        snprintf(problem, psize, "%s %s is not this FMU's (%s, from its modelDescription.xml): "
                 "the host read another FMU's description", arg, quoted, own);
        return problem;
    }
    return NULL;
}

/* ---- live instances and FMU states ---------------------------------------------------- */

typedef struct tf_state {
    struct tf_state *next;
    struct tf_instance *owner;
    void *inner;  /* pythonfmu's state (a Python object reference) */
} tf_state;

struct tf_instance;
static struct tf_instance *tf_instances = NULL;  /* under tf_lock */
static tf_state *tf_states = NULL;                /* under tf_lock */
static __thread struct tf_instance *tf_current = NULL;  /* instance whose call is running */

static tf_state *tf_find_state(void *p)
{
    pthread_mutex_lock(&tf_lock);
    tf_state *s = tf_states;
    while (s && (void *)s != p) s = s->next;
    pthread_mutex_unlock(&tf_lock);
    return s;
}

static tf_state *tf_new_state(struct tf_instance *owner, void *inner)
{
    tf_state *s = (tf_state *)calloc(1, sizeof *s);
    if (!s) return NULL;
    s->owner = owner;
    s->inner = inner;
    pthread_mutex_lock(&tf_lock);
    s->next = tf_states;
    tf_states = s;
    pthread_mutex_unlock(&tf_lock);
    return s;
}

static void tf_forget_state(tf_state *s)
{
    pthread_mutex_lock(&tf_lock);
    tf_state **p = &tf_states;
    while (*p && *p != s) p = &(*p)->next;
    if (*p) *p = s->next;
    pthread_mutex_unlock(&tf_lock);
    free(s);
}

/* Unlink the first state owned by owner (NULL when none is left). */
static tf_state *tf_take_state_of(struct tf_instance *owner)
{
    pthread_mutex_lock(&tf_lock);
    tf_state **p = &tf_states;
    while (*p && (*p)->owner != owner) p = &(*p)->next;
    tf_state *s = *p;
    if (s) *p = s->next;
    pthread_mutex_unlock(&tf_lock);
    return s;
}

#endif
