/*
 * dahlquist.c -- a stand-alone FMI 1.0 co-simulation slave written the way FMU SDK-era exporters
 * wrote them (no modelicagym framework): one file, fmiFullName() function names, a fixed
 * variable array indexed by value reference.
 *
 *   der(x) = -k * x + u      (exact solution over each communication step)
 *
 * value references: 0 x (output), 1 k (parameter), 2 u (input), 3 x0 (parameter),
 *                   4 steps (Integer output), 5 positive (Boolean output)
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi1Functions.h"

#define MODEL_IDENTIFIER Dahlquist
#define MODEL_GUID "{5b0d9c3e-1f4a-4c6e-9a71-3d2b8e0f6a11}"

#define PASTE(a, b) a##_##b
#define EXPAND(a, b) PASTE(a, b)
#define fmiFullName(name) EXPAND(MODEL_IDENTIFIER, name)

#if defined(_WIN32)
#define DllExport __declspec(dllexport)
#else
#define DllExport __attribute__((visibility("default")))
#endif

#define NREALS 4

typedef struct {
    double r[NREALS];
    int steps;
    double time;
    int initialized;
    fmi1CallbackFunctions functions;
    char name[64];
} Slave;

static void fail(Slave *s, const char *message) {
    if (s->functions.logger) {
        s->functions.logger((fmi1Component)s, s->name, fmi1Error, "error", message);
    }
}

DllExport const char *fmiFullName(fmiGetTypesPlatform)(void) { return "standard32"; }
DllExport const char *fmiFullName(fmiGetVersion)(void) { return "1.0"; }

DllExport fmi1Component fmiFullName(fmiInstantiateSlave)(fmi1String instanceName, fmi1String fmuGUID,
                                                         fmi1String fmuLocation, fmi1String mimeType,
                                                         fmi1Real timeout, fmi1Boolean visible,
                                                         fmi1Boolean interactive,
                                                         fmi1CallbackFunctions functions,
                                                         fmi1Boolean loggingOn) {
    Slave *s;
    (void)fmuLocation; (void)mimeType; (void)timeout; (void)visible; (void)interactive; (void)loggingOn;
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions.logger) {
            functions.logger(NULL, instanceName, fmi1Error, "error", "wrong GUID");
        }
        return NULL;
    }
    s = (Slave *)calloc(1, sizeof(Slave));
    if (!s) {
        return NULL;
    }
    s->functions = functions;
    strncpy(s->name, instanceName ? instanceName : "", sizeof s->name - 1);
    s->r[1] = 1.0; /* k */
    s->r[3] = 1.0; /* x0 */
    return s;
}

DllExport fmi1Status fmiFullName(fmiInitializeSlave)(fmi1Component c, fmi1Real tStart,
                                                     fmi1Boolean StopTimeDefined, fmi1Real tStop) {
    Slave *s = (Slave *)c;
    (void)StopTimeDefined; (void)tStop;
    if (!(s->r[1] > 0.0)) {
        fail(s, "k must be > 0");
        return fmi1Error;
    }
    s->r[0] = s->r[3];
    s->time = tStart;
    s->steps = 0;
    s->initialized = 1;
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiDoStep)(fmi1Component c, fmi1Real t, fmi1Real h, fmi1Boolean newStep) {
    Slave *s = (Slave *)c;
    double k = s->r[1], u = s->r[2], x_inf = u / k;
    (void)newStep;
    if (fabs(t - s->time) > 1e-9) {
        fail(s, "wrong communication point");
        return fmi1Error;
    }
    s->r[0] = x_inf + (s->r[0] - x_inf) * exp(-k * h);
    s->time = t + h;
    s->steps++;
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiTerminateSlave)(fmi1Component c) { (void)c; return fmi1OK; }

DllExport fmi1Status fmiFullName(fmiResetSlave)(fmi1Component c) {
    Slave *s = (Slave *)c;
    s->r[0] = 0.0; s->r[1] = 1.0; s->r[2] = 0.0; s->r[3] = 1.0;
    s->steps = 0; s->time = 0.0; s->initialized = 0;
    return fmi1OK;
}

DllExport void fmiFullName(fmiFreeSlaveInstance)(fmi1Component c) { free(c); }

DllExport fmi1Status fmiFullName(fmiSetDebugLogging)(fmi1Component c, fmi1Boolean loggingOn) {
    (void)c; (void)loggingOn;
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiSetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                             const fmi1Real value[]) {
    Slave *s = (Slave *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == 0 || vr[i] >= NREALS || (s->initialized && vr[i] != 2)) {
            fail(s, "variable cannot be set");
            return fmi1Error;
        }
        s->r[vr[i]] = value[i];
    }
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiGetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                             fmi1Real value[]) {
    Slave *s = (Slave *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= NREALS) {
            fail(s, "unknown Real");
            return fmi1Error;
        }
        value[i] = s->r[vr[i]];
    }
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiGetInteger)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                                fmi1Integer value[]) {
    Slave *s = (Slave *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != 4) {
            fail(s, "unknown Integer");
            return fmi1Error;
        }
        value[i] = s->steps;
    }
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiGetBoolean)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                                fmi1Boolean value[]) {
    Slave *s = (Slave *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != 5) {
            fail(s, "unknown Boolean");
            return fmi1Error;
        }
        value[i] = s->r[0] > 0.0 ? fmi1True : fmi1False;
    }
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiGetString)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                               fmi1String value[]) {
    (void)c; (void)vr; (void)value;
    return nvr == 0 ? fmi1OK : fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiSetInteger)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                                const fmi1Integer value[]) {
    (void)c; (void)vr; (void)value;
    return nvr == 0 ? fmi1OK : fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiSetBoolean)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                                const fmi1Boolean value[]) {
    (void)c; (void)vr; (void)value;
    return nvr == 0 ? fmi1OK : fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiSetString)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                               const fmi1String value[]) {
    (void)c; (void)vr; (void)value;
    return nvr == 0 ? fmi1OK : fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiSetRealInputDerivatives)(fmi1Component c, const fmi1ValueReference vr[],
                                                             size_t nvr, const fmi1Integer order[],
                                                             const fmi1Real value[]) {
    (void)c; (void)vr; (void)nvr; (void)order; (void)value;
    return fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiGetRealOutputDerivatives)(fmi1Component c, const fmi1ValueReference vr[],
                                                              size_t nvr, const fmi1Integer order[],
                                                              fmi1Real value[]) {
    (void)c; (void)vr; (void)nvr; (void)order; (void)value;
    return fmi1Error;
}

DllExport fmi1Status fmiFullName(fmiCancelStep)(fmi1Component c) { (void)c; return fmi1Error; }

DllExport fmi1Status fmiFullName(fmiGetStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Status *value) {
    (void)c; (void)s; (void)value;
    return fmi1Discard;
}

DllExport fmi1Status fmiFullName(fmiGetRealStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Real *value) {
    if (s != fmi1LastSuccessfulTime) {
        return fmi1Discard;
    }
    *value = ((Slave *)c)->time;
    return fmi1OK;
}

DllExport fmi1Status fmiFullName(fmiGetIntegerStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Integer *value) {
    (void)c; (void)s; (void)value;
    return fmi1Discard;
}

DllExport fmi1Status fmiFullName(fmiGetBooleanStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Boolean *value) {
    (void)c; (void)s; (void)value;
    return fmi1Discard;
}

DllExport fmi1Status fmiFullName(fmiGetStringStatus)(fmi1Component c, const fmi1StatusKind s, fmi1String *value) {
    (void)c; (void)s; (void)value;
    return fmi1Discard;
}
