/* Model exchange in C: advance an FMI 2.0/3.0 model-exchange instance from t to t + dt.
 *
 * The loop is the one of modelicagym/fmu/model_exchange.py (which follows fmpy's simulateME),
 * statement for statement, so both paths give the same answers: integrate with CVode (BDF,
 * dense linear solver, root finding on the event indicators) or forward Euler at a fixed step;
 * stop at time events (nextEventTime), state events (roots) and step events
 * (completedIntegratorStep); run the event iteration; carry on. The solver is re-initialised at
 * the start of every advance (inputs are piecewise constant: a multistep method must not carry
 * history across an input jump) and after every event. A caller that knows the inputs did not
 * change (the native step path compares them) keeps `continuous` set: CVode then goes on with
 * its step size and order instead of restarting at order 1, which at tight tolerances is most of
 * the cost of a step; the answers stay within the solver's tolerance of the restarted ones.
 *
 * CVode runs Adams-Moulton with fixed-point iteration, or BDF with Newton iteration and a dense
 * linear solver (what fmpy and the Python path use). MG_CVODE_AUTO starts with Adams, which takes
 * far fewer and cheaper steps on non-stiff models at tight tolerances, and switches the instance
 * to BDF for good once the fixed-point iteration keeps failing to converge (the sign of a stiff
 * model, as in LSODA); the advance that showed it completes with Adams, correct but slow.
 *
 * CVode is the SUNDIALS 7 build that fmpy ships (the very binaries the Python path calls), reached
 * through function pointers Python resolves from fmpy's loaded libraries (mg_sundials): no
 * SUNDIALS headers or link step here, and the same numerics as the Python path.
 *
 * The right-hand side and root functions call the FMU's own getDerivatives / setContinuousStates
 * / getEventIndicators directly: no Python between the solver and the model.
 */
#ifndef MG_INTEGRATOR_H
#define MG_INTEGRATOR_H

#include <stdint.h>

/* The SUNDIALS 7 functions the integrator calls (addresses in fmpy's shared libraries). */
typedef struct {
    void *SUNContext_Create, *SUNContext_Free, *SUNContext_ClearErrHandlers, *SUNContext_PushErrHandler;
    void *N_VNew_Serial, *N_VDestroy, *N_VGetArrayPointer;
    void *SUNDenseMatrix, *SUNMatDestroy, *SUNLinSol_Dense, *SUNLinSolFree, *SUNNonlinSol_FixedPoint, *SUNNonlinSolFree;
    void *CVodeCreate, *CVodeInit, *CVodeReInit, *CVodeSVtolerances, *CVodeRootInit;
    void *CVodeSetLinearSolver, *CVodeSetNonlinearSolver, *CVodeSetMaxNumSteps, *CVodeSetNoInactiveRootWarn;
    void *CVodeSetUserData, *CVode, *CVodeGetRootInfo, *CVodeGetNumNonlinSolvConvFails, *CVodeFree;
} mg_sundials;

enum { MG_SOLVER_CVODE = 0, MG_SOLVER_EULER = 1, MG_SOLVER_RK4 = 2 };
enum { MG_CVODE_BDF = 0, MG_CVODE_ADAMS = 1, MG_CVODE_AUTO = 2 };

typedef struct {
    int32_t fmi_version; /* 1, 2 or 3 */
    int32_t solver;      /* MG_SOLVER_* */
    int32_t method;      /* CVode: MG_CVODE_BDF, MG_CVODE_ADAMS, or MG_CVODE_AUTO (Adams until stiff, then BDF) */
    int32_t stiff;       /* CVode, MG_CVODE_AUTO: the model proved stiff; the instance now uses BDF */
    void *component;
    /* the FMU's functions (fmi2... or fmi3...) */
    void *set_time, *set_x, *get_x, *get_dx, *get_z, *get_nominals;
    void *completed_integrator_step, *enter_event_mode, *update_discrete_states, *enter_continuous_time_mode;
    int64_t nx, nz;
    int32_t needs_completed_integrator_step;
    double tolerance; /* CVode's relative tolerance */
    double step_size; /* > 0: no solver step longer than this (Euler's fixed step) */
    int32_t continuous; /* CVode may go on from where the last advance left it: nothing changed the
                           model since (no input, event, reset); else the advance re-initialises */
    int32_t has_next_event;
    double next_event_time; /* the pending time event, when has_next_event */
    /* buffers of at least max(nx, 1) / nz doubles, owned by Python */
    double *x, *dx, *z, *previous_z;
    int32_t *roots;
    double *stages; /* RK4: 4 * max(nx, 1) doubles (k2, k3, k4 and the stage's states) */
    const mg_sundials *sundials;
    /* CVode's objects (NULL: not created) */
    void *context, *cvode, *y, *abstol, *matrix, *linear_solver, *nonlinear_solver;
    /* what failed, when a call returns MG_INTEGRATOR_FAILED */
    int32_t failed_call; /* MG_FMU_CALL_* */
    int32_t fmi_status;  /* the FMU's status, for a failing FMU call */
    double failed_at;    /* the time of the failure */
    char message[256];   /* CVode's error message, for MG_FMU_CALL_SOLVER */
} mg_integrator;

/* Outcomes of mg_integrator_open / mg_integrator_advance. */
enum { MG_INTEGRATOR_OK = 0, MG_INTEGRATOR_TERMINATE = 1, MG_INTEGRATOR_FAILED = 2 };

/* What failed: an FMU call (by name, in Python: integrator.py) or the solver itself. */
enum {
    MG_FMU_CALL_SET_TIME = 1,
    MG_FMU_CALL_SET_X,
    MG_FMU_CALL_GET_X,
    MG_FMU_CALL_GET_DX,
    MG_FMU_CALL_GET_Z,
    MG_FMU_CALL_GET_NOMINALS,
    MG_FMU_CALL_COMPLETED_STEP,
    MG_FMU_CALL_ENTER_EVENT_MODE,
    MG_FMU_CALL_UPDATE_DISCRETE_STATES,
    MG_FMU_CALL_ENTER_CONTINUOUS_TIME_MODE,
    MG_FMU_CALL_SOLVER,
};

/* Set up the solver at `time`, in continuous-time mode, as the Python path's _make_solver does
 * (CVode: its objects, created once per integrator, re-initialised here; Euler: the event
 * indicators the first step compares with). */
int32_t mg_integrator_open(mg_integrator *integrator, double time);

/* Free CVode's objects (safe to call twice). */
void mg_integrator_close(mg_integrator *integrator);

/* Integrate from `time` to `stop`, events included. MG_INTEGRATOR_TERMINATE: the model asked to
 * terminate the simulation. */
int32_t mg_integrator_advance(mg_integrator *integrator, double time, double stop);

/* An event of the caller's at `time`, as ModelExchangeIntegrator.event: mg_integrator_enter_event
 * sets the time and enters event mode (the next advance restarts CVode), the caller then sets what
 * FMI lets it set there only (discrete inputs), and mg_integrator_settle_event runs the event
 * iteration and returns to continuous-time mode. MG_INTEGRATOR_TERMINATE: the model asked to
 * terminate the simulation (it stays in event mode). */
int32_t mg_integrator_enter_event(mg_integrator *integrator, double time);
int32_t mg_integrator_settle_event(mg_integrator *integrator, double time);

#endif
