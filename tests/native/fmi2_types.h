/* The FMI 2.0 types the test hosts use (a native tool takes them from fmi2FunctionTypes.h). */
#ifndef TRIBOFMU_TEST_FMI2_TYPES_H
#define TRIBOFMU_TEST_FMI2_TYPES_H
#include <stddef.h>

typedef void *fmi2Component;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef int fmi2Status;
typedef struct {
    void (*logger)(void *, const char *, fmi2Status, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, fmi2Status);
    void *componentEnvironment;
} fmi2CallbackFunctions;

#endif
