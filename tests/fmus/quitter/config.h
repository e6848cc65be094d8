/*
 * config.h -- "Quitter", a test FMU whose doStep ends the process the way
 * FMUs in the wild do (tests/fmu_family.py):
 *
 *   der(x) = u        x(0) = 0        (u: input, -1..1; x: output)
 *
 * Parameters (fixed): `quit` (Int32) and `quit_after` (Int32). The doStep
 * after `quit_after` completed ones calls exit(0) (quit = 1), abort()
 * (quit = 2) or writes through a null pointer (quit = 3, SIGSEGV); quit = 0
 * (the default) never quits. Only co-simulation's doStep quits; model exchange is
 * declared, as by every member of the family, and never quits.
 */
#ifndef QUITTER_CONFIG_H
#define QUITTER_CONFIG_H

#include <stdint.h>

#define NX 1 /* x */
#define NZ 0

enum { VR_X = 1, VR_DER_X = 2, VR_U = 3, VR_QUIT = 4, VR_QUIT_AFTER = 5 };

enum { QUIT_NEVER = 0, QUIT_EXIT = 1, QUIT_ABORT = 2, QUIT_SEGFAULT = 3 };

typedef struct {
    double x, der_x, u;
    int32_t quit, quit_after, steps;
} ModelData;

#endif /* QUITTER_CONFIG_H */
