/*
 * config.h -- "Crashy", the test FMU for the load trial (modelicagym/fmu/trial.py):
 * a first-order lag that misbehaves while it is loaded, as FMUs in the wild do.
 *
 *   der(x) = (u - x) / tau,  y = x,  x(0) = x_0
 *   input u (Float64, -1..1), output y, parameters tau (> 0), x_0
 *
 * Build-time variants (preprocessor definitions; lifecycle hooks in model.c),
 * each logging a line through the importer's logger first:
 *   CRASH_IN_INSTANTIATE  "license file was not found", then SIGSEGV inside
 *                         fmiInstantiate (a licensed FMU without its licence)
 *   PRINT_TO_STDOUT       with CRASH_IN_INSTANTIATE: print the line to stdout
 *                         instead (as some exporters do), not to the logger
 *   EXIT_IN_INSTANTIATE   exit(0) inside fmiInstantiate
 *   ABORT_IN_INITIALIZE   abort() inside fmiExitInitializationMode (the
 *                         framework's initialize hook, which runs there when
 *                         nothing is read in initialization mode)
 *   HANG_IN_INSTANTIATE   fmiInstantiate never returns (until killed)
 *   TAU_REQUIRED          tau starts at 0, which initialization refuses (an
 *                         FMU that needs a parameter set): a clean error
 * Without any of them the FMU is well behaved.
 */
#ifndef CRASHY_CONFIG_H
#define CRASHY_CONFIG_H

#define NX 1 /* x */
#define NZ 0

enum { VR_Y = 1, VR_DER_X = 2, VR_U = 3, VR_TAU = 4, VR_X_0 = 5 };

typedef struct {
    double x, der_x;
    double u;
    double tau, x_0;
} ModelData;

#endif /* CRASHY_CONFIG_H */
