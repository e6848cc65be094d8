/* See integrator.h. */
#include "integrator.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

/* The FMU functions: the continuous-state ones have one signature in FMI 1.0, 2.0 and 3.0. FMI 1.0
 * has no event or continuous-time mode to enter (enter_event_mode and enter_continuous_time_mode
 * are NULL) and settles an event in one fmiEventUpdate. */
typedef int (*set_time_t)(void *, double);
typedef int (*set_vector_t)(void *, const double *, size_t);
typedef int (*get_vector_t)(void *, double *, size_t);
typedef int (*enter_mode_t)(void *);
typedef int (*fmi1_completed_t)(void *, char *);
typedef int (*fmi2_completed_t)(void *, int, int *, int *);
typedef int (*fmi3_completed_t)(void *, bool, bool *, bool *);
typedef struct {
    int new_discrete_states_needed, terminate_simulation, nominals_changed, values_changed, next_event_time_defined;
    double next_event_time;
} fmi2_event_info;
typedef int (*fmi2_new_discrete_states_t)(void *, fmi2_event_info *);
typedef struct {
    char iteration_converged, state_value_references_changed, state_values_changed, terminate_simulation,
        upcoming_time_event;
    double next_event_time;
} fmi1_event_info;
typedef int (*fmi1_event_update_t)(void *, char, fmi1_event_info *);
typedef int (*fmi3_update_discrete_states_t)(void *, bool *, bool *, bool *, bool *, bool *, double *);

/* SUNDIALS 7 (sunrealtype double, sunindextype int64_t; objects are opaque pointers). */
typedef void *N_Vector;
typedef int (*rhs_fn)(double, N_Vector, N_Vector, void *);
typedef int (*root_fn)(double, N_Vector, double *, void *);
typedef void (*err_handler_fn)(int, const char *, const char *, const char *, int, void *, void *);
typedef int (*SUNContext_Create_t)(int, void **);
typedef int (*SUNContext_Free_t)(void **);
typedef int (*SUNContext_ClearErrHandlers_t)(void *);
typedef int (*SUNContext_PushErrHandler_t)(void *, err_handler_fn, void *);
typedef N_Vector (*N_VNew_Serial_t)(int64_t, void *);
typedef void (*N_VDestroy_t)(N_Vector);
typedef double *(*N_VGetArrayPointer_t)(N_Vector);
typedef void *(*SUNDenseMatrix_t)(int64_t, int64_t, void *);
typedef void (*SUNMatDestroy_t)(void *);
typedef void *(*SUNLinSol_Dense_t)(N_Vector, void *, void *);
typedef int (*SUNLinSolFree_t)(void *);
typedef void *(*SUNNonlinSol_FixedPoint_t)(N_Vector, int, void *);
typedef int (*SUNNonlinSolFree_t)(void *);
typedef void *(*CVodeCreate_t)(int, void *);
typedef int (*CVodeInit_t)(void *, rhs_fn, double, N_Vector);
typedef int (*CVodeReInit_t)(void *, double, N_Vector);
typedef int (*CVodeSVtolerances_t)(void *, double, N_Vector);
typedef int (*CVodeRootInit_t)(void *, int, root_fn);
typedef int (*CVodeSetLinearSolver_t)(void *, void *, void *);
typedef int (*CVodeSetNonlinearSolver_t)(void *, void *);
typedef int (*CVodeGetNumNonlinSolvConvFails_t)(void *, long *);
typedef int (*CVodeSetMaxNumSteps_t)(void *, long);
typedef int (*CVodeSetNoInactiveRootWarn_t)(void *);
typedef int (*CVodeSetUserData_t)(void *, void *);
typedef int (*CVode_t)(void *, double, N_Vector, double *, int);
typedef int (*CVodeGetRootInfo_t)(void *, int *);
typedef void (*CVodeFree_t)(void **);

enum { CV_ADAMS = 1, CV_BDF = 2, CV_NORMAL = 1, CV_SUCCESS = 0 };
enum { WARNING = 1 };
#define MAX_NUM_STEPS 100000L /* the Python path's maxNumSteps */
/* MG_CVODE_AUTO: this many fixed-point convergence failures between two restarts mark the model
 * stiff, as STIFF_CONVERGENCE_FAILURES of fmu/model_exchange.py. */
#define STIFF_CONVERGENCE_FAILURES 10

#define SUN(name) ((name##_t)integrator->sundials->name)

static int32_t fail(mg_integrator *integrator, int32_t call, int status, double time) {
    integrator->failed_call = call;
    integrator->fmi_status = status;
    integrator->failed_at = time;
    return MG_INTEGRATOR_FAILED;
}

/* An FMU call: on a status above Warning, record it and return from the calling function. */
#define CALL(call_code, time, expression)                                                                              \
    do {                                                                                                               \
        int status_ = (expression);                                                                                    \
        if (status_ > WARNING)                                                                                         \
            return fail(integrator, (call_code), status_, (time));                                                     \
    } while (0)

static bool close_to(double a, double b) {
    double scale = fmax(fabs(a), fabs(b));
    return fabs(a - b) <= fmax(1e-12 * scale, 1e-12); /* math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12) */
}

/* -- FMU calls ------------------------------------------------------------------------------------ */

static int set_time(mg_integrator *integrator, double time) {
    return ((set_time_t)integrator->set_time)(integrator->component, time);
}

static int set_x(mg_integrator *integrator, const double *x) {
    return ((set_vector_t)integrator->set_x)(integrator->component, x, (size_t)integrator->nx);
}

static int get_x(mg_integrator *integrator, double *x) {
    return ((get_vector_t)integrator->get_x)(integrator->component, x, (size_t)integrator->nx);
}

static int get_dx(mg_integrator *integrator, double *dx) {
    return ((get_vector_t)integrator->get_dx)(integrator->component, dx, (size_t)integrator->nx);
}

static int get_z(mg_integrator *integrator, double *z) {
    return ((get_vector_t)integrator->get_z)(integrator->component, z, (size_t)integrator->nz);
}

static int completed_integrator_step(mg_integrator *integrator, bool *enter_event_mode, bool *terminate) {
    if (integrator->fmi_version == 1) { /* fmiCompletedIntegratorStep(callEventUpdate) */
        char call_event_update = 0;
        int status = ((fmi1_completed_t)integrator->completed_integrator_step)(integrator->component, &call_event_update);
        *enter_event_mode = call_event_update != 0, *terminate = false;
        return status;
    }
    if (integrator->fmi_version == 2) {
        int enter = 0, stop = 0;
        int status = ((fmi2_completed_t)integrator->completed_integrator_step)(integrator->component, 1, &enter, &stop);
        *enter_event_mode = enter, *terminate = stop;
        return status;
    }
    return ((fmi3_completed_t)integrator->completed_integrator_step)(integrator->component, true, enter_event_mode,
                                                                      terminate);
}

/* One pass of the event iteration: needs another pass, terminate, and the next time event. */
static int update_discrete_states(mg_integrator *integrator, bool *needs_update, bool *terminate) {
    int status;
    bool time_defined;
    double next_time;
    if (integrator->fmi_version == 1) { /* fmiEventUpdate iterates until converged (no intermediate results) */
        fmi1_event_info info = {0};
        status = ((fmi1_event_update_t)integrator->update_discrete_states)(integrator->component, 0, &info);
        *needs_update = !info.iteration_converged, *terminate = info.terminate_simulation != 0;
        time_defined = info.upcoming_time_event != 0, next_time = info.next_event_time;
    } else if (integrator->fmi_version == 2) {
        fmi2_event_info info = {0};
        status = ((fmi2_new_discrete_states_t)integrator->update_discrete_states)(integrator->component, &info);
        *needs_update = info.new_discrete_states_needed, *terminate = info.terminate_simulation;
        time_defined = info.next_event_time_defined, next_time = info.next_event_time;
    } else {
        bool nominals_changed, values_changed;
        next_time = 0.0;
        status = ((fmi3_update_discrete_states_t)integrator->update_discrete_states)(
            integrator->component, needs_update, terminate, &nominals_changed, &values_changed, &time_defined,
            &next_time);
    }
    integrator->has_next_event = time_defined;
    integrator->next_event_time = time_defined ? next_time : 0.0;
    return status;
}

/* FMI 2.0/3.0: enter event mode (FMI 1.0 has none: fmiEventUpdate handles the event). */
static int32_t enter_event_mode(mg_integrator *integrator, double time) {
    if (integrator->enter_event_mode)
        CALL(MG_FMU_CALL_ENTER_EVENT_MODE, time, ((enter_mode_t)integrator->enter_event_mode)(integrator->component));
    return MG_INTEGRATOR_OK;
}

/* In event mode: update discrete states until they settle, return to continuous-time mode. */
int32_t mg_integrator_settle_event(mg_integrator *integrator, double time) {
    bool needs_update = true, terminate = false;
    while (needs_update) {
        CALL(MG_FMU_CALL_UPDATE_DISCRETE_STATES, time, update_discrete_states(integrator, &needs_update, &terminate));
        if (terminate)
            return MG_INTEGRATOR_TERMINATE;
    }
    if (integrator->enter_continuous_time_mode)
        CALL(MG_FMU_CALL_ENTER_CONTINUOUS_TIME_MODE, time,
             ((enter_mode_t)integrator->enter_continuous_time_mode)(integrator->component));
    return MG_INTEGRATOR_OK;
}

/* Enter event mode, update discrete states until they settle, return to continuous-time mode. */
static int32_t handle_event(mg_integrator *integrator, double time) {
    int32_t outcome = enter_event_mode(integrator, time);
    return outcome ? outcome : mg_integrator_settle_event(integrator, time);
}

int32_t mg_integrator_enter_event(mg_integrator *integrator, double time) {
    integrator->continuous = 0;
    CALL(MG_FMU_CALL_SET_TIME, time, set_time(integrator, time));
    return enter_event_mode(integrator, time);
}

/* -- CVode ------------------------------------------------------------------------------------------ */

/* Put CVode's (t, y) into the FMU (no states: time only); -1 and the failure recorded if a call fails. */
static int set_time_and_states(mg_integrator *integrator, double t, N_Vector y) {
    int status = set_time(integrator, t);
    if (status > WARNING)
        return fail(integrator, MG_FMU_CALL_SET_TIME, status, t), -1;
    if (integrator->nx > 0) {
        status = set_x(integrator, SUN(N_VGetArrayPointer)(y));
        if (status > WARNING)
            return fail(integrator, MG_FMU_CALL_SET_X, status, t), -1;
    }
    return 0;
}

/* The right-hand side: the FMU's derivatives at (t, y). A failing FMU call stops CVode (-1). */
static int cvode_rhs(double t, N_Vector y, N_Vector ydot, void *user_data) {
    mg_integrator *integrator = user_data;
    double *dx = SUN(N_VGetArrayPointer)(ydot);
    if (set_time_and_states(integrator, t, y))
        return -1;
    if (integrator->nx == 0) { /* a model without states: CVode integrates one dummy state */
        dx[0] = 0.0;
        return 0;
    }
    int status = get_dx(integrator, dx);
    if (status > WARNING)
        return fail(integrator, MG_FMU_CALL_GET_DX, status, t), -1;
    return 0;
}

/* The root function: the FMU's event indicators at (t, y). */
static int cvode_roots(double t, N_Vector y, double *z, void *user_data) {
    mg_integrator *integrator = user_data;
    if (set_time_and_states(integrator, t, y))
        return -1;
    int status = get_z(integrator, z);
    if (status > WARNING)
        return fail(integrator, MG_FMU_CALL_GET_Z, status, t), -1;
    return 0;
}

static void cvode_error(int line, const char *function, const char *file, const char *message, int code,
                        void *user_data, void *context) {
    (void)line, (void)file, (void)context;
    mg_integrator *integrator = user_data;
    snprintf(integrator->message, sizeof integrator->message, "CVode error (code %d) in %s: %s", code,
             function ? function : "?", message ? message : "");
}

static int32_t solver_failed(mg_integrator *integrator, double time, const char *what) {
    snprintf(integrator->message, sizeof integrator->message, "%s failed", what);
    return fail(integrator, MG_FMU_CALL_SOLVER, 0, time);
}

/* The states CVode starts from (the FMU's, or the dummy state of a stateless model). */
static int32_t read_states(mg_integrator *integrator, double *y, double time) {
    if (integrator->nx == 0)
        y[0] = 1.0;
    else
        CALL(MG_FMU_CALL_GET_X, time, get_x(integrator, y));
    return MG_INTEGRATOR_OK;
}

static bool uses_adams(const mg_integrator *integrator) {
    return integrator->method == MG_CVODE_ADAMS || (integrator->method == MG_CVODE_AUTO && !integrator->stiff);
}

/* Adams: a fixed-point nonlinear solver; BDF: Newton with a dense linear solver. */
static int attach_solvers(mg_integrator *integrator, int64_t n) {
    if (uses_adams(integrator)) {
        integrator->nonlinear_solver = SUN(SUNNonlinSol_FixedPoint)(integrator->y, 0, integrator->context);
        return !integrator->nonlinear_solver ||
               SUN(CVodeSetNonlinearSolver)(integrator->cvode, integrator->nonlinear_solver);
    }
    integrator->matrix = SUN(SUNDenseMatrix)(n, n, integrator->context);
    if (!integrator->matrix)
        return 1;
    integrator->linear_solver = SUN(SUNLinSol_Dense)(integrator->y, integrator->matrix, integrator->context);
    return !integrator->linear_solver ||
           SUN(CVodeSetLinearSolver)(integrator->cvode, integrator->linear_solver, integrator->matrix);
}

static int32_t cvode_create(mg_integrator *integrator, double time) {
    int64_t n = integrator->nx > 0 ? integrator->nx : 1;
    if (SUN(SUNContext_Create)(0, &integrator->context) != CV_SUCCESS)
        return solver_failed(integrator, time, "SUNContext_Create");
    SUN(SUNContext_ClearErrHandlers)(integrator->context); /* no printing to stderr: the message goes into the error */
    SUN(SUNContext_PushErrHandler)(integrator->context, cvode_error, integrator);
    integrator->y = SUN(N_VNew_Serial)(n, integrator->context);
    integrator->abstol = SUN(N_VNew_Serial)(n, integrator->context);
    integrator->cvode = SUN(CVodeCreate)(uses_adams(integrator) ? CV_ADAMS : CV_BDF, integrator->context);
    if (!integrator->y || !integrator->abstol || !integrator->cvode)
        return solver_failed(integrator, time, "allocating CVode");
    double *y = SUN(N_VGetArrayPointer)(integrator->y);
    int32_t outcome = read_states(integrator, y, time);
    if (outcome)
        return outcome;
    if (SUN(CVodeInit)(integrator->cvode, cvode_rhs, time, integrator->y) ||
        SUN(CVodeSetUserData)(integrator->cvode, integrator) ||
        SUN(CVodeRootInit)(integrator->cvode, (int)integrator->nz, cvode_roots) || attach_solvers(integrator, n) ||
        SUN(CVodeSetMaxNumSteps)(integrator->cvode, MAX_NUM_STEPS) ||
        SUN(CVodeSetNoInactiveRootWarn)(integrator->cvode))
        return solver_failed(integrator, time, "setting up CVode");
    return MG_INTEGRATOR_OK;
}

/* Absolute tolerances: the states' nominal values times the relative tolerance. */
static int32_t set_tolerances(mg_integrator *integrator, double time) {
    double *abstol = SUN(N_VGetArrayPointer)(integrator->abstol);
    if (integrator->nx == 0)
        abstol[0] = 1.0;
    else
        CALL(MG_FMU_CALL_GET_NOMINALS, time,
             ((get_vector_t)integrator->get_nominals)(integrator->component, abstol, (size_t)integrator->nx));
    for (int64_t k = 0; k < (integrator->nx > 0 ? integrator->nx : 1); k++)
        abstol[k] *= integrator->tolerance;
    if (SUN(CVodeSVtolerances)(integrator->cvode, integrator->tolerance, integrator->abstol))
        return solver_failed(integrator, time, "CVodeSVtolerances");
    return MG_INTEGRATOR_OK;
}

/* Restart CVode at `time` from the FMU's states. */
static int32_t cvode_reset(mg_integrator *integrator, double time) {
    double *y = SUN(N_VGetArrayPointer)(integrator->y);
    int32_t outcome = read_states(integrator, y, time);
    if (outcome)
        return outcome;
    SUN(CVodeReInit)(integrator->cvode, time, integrator->y);
    return MG_INTEGRATOR_OK;
}

/* One CVode call towards `target`, writing the states it reached back to the FMU. (`y` is only
 * CVode's output here: it copied the initial states at its last (re)initialisation.) */
static int32_t cvode_step(mg_integrator *integrator, double time, double target, bool *state_event, double *reached) {
    double *y = SUN(N_VGetArrayPointer)(integrator->y);
    integrator->failed_call = 0;
    int flag = SUN(CVode)(integrator->cvode, target, integrator->y, reached, CV_NORMAL);
    if (flag < 0) {
        if (integrator->failed_call) /* an FMU call inside the right-hand side or root function */
            return MG_INTEGRATOR_FAILED;
        return fail(integrator, MG_FMU_CALL_SOLVER, flag, time);
    }
    if (integrator->nx > 0)
        CALL(MG_FMU_CALL_SET_X, *reached, set_x(integrator, y));
    *state_event = flag > 0;
    if (flag > 0 && integrator->nz > 0)
        SUN(CVodeGetRootInfo)(integrator->cvode, integrator->roots);
    if (integrator->method == MG_CVODE_AUTO && !integrator->stiff) {
        long failures = 0;
        SUN(CVodeGetNumNonlinSolvConvFails)(integrator->cvode, &failures);
        integrator->stiff = failures >= STIFF_CONVERGENCE_FAILURES;
    }
    return MG_INTEGRATOR_OK;
}

/* -- fixed-step schemes (as fmpy's ForwardEuler: an event happens at the end of the step that crossed) -- */

/* The event indicators at the end of a step against those at its start. */
static int32_t detect_crossings(mg_integrator *integrator, double target, bool *state_event) {
    int64_t nz = integrator->nz;
    double *z = integrator->z, *previous = integrator->previous_z;
    memcpy(previous, z, sizeof(double) * (size_t)nz);
    CALL(MG_FMU_CALL_GET_Z, target, get_z(integrator, z));
    *state_event = false;
    for (int64_t k = 0; k < nz; k++) {
        integrator->roots[k] = previous[k] < 0 && z[k] >= 0 ? -1 : previous[k] > 0 && z[k] <= 0 ? 1 : 0;
        *state_event |= integrator->roots[k] != 0;
    }
    return MG_INTEGRATOR_OK;
}

static int32_t euler_step(mg_integrator *integrator, double time, double target, bool *state_event, double *reached) {
    int64_t nx = integrator->nx;
    double *x = integrator->x, *dx = integrator->dx;
    CALL(MG_FMU_CALL_GET_X, time, get_x(integrator, x));
    CALL(MG_FMU_CALL_GET_DX, time, get_dx(integrator, dx));
    double h = target - time;
    for (int64_t k = 0; k < nx; k++)
        x[k] += h * dx[k];
    CALL(MG_FMU_CALL_SET_X, target, set_x(integrator, x));
    *reached = target;
    return detect_crossings(integrator, target, state_event);
}

/* k = f(t, x): the FMU's derivatives at time t for the states x. */
static int32_t derivatives_at(mg_integrator *integrator, double t, const double *x, double *k) {
    CALL(MG_FMU_CALL_SET_TIME, t, set_time(integrator, t));
    CALL(MG_FMU_CALL_SET_X, t, set_x(integrator, x));
    CALL(MG_FMU_CALL_GET_DX, t, get_dx(integrator, k));
    return MG_INTEGRATOR_OK;
}

/* The classical Runge-Kutta step, written as the FMU framework's own (models/csrc/fmu_solver.c). */
static int32_t rk4_step(mg_integrator *integrator, double time, double target, bool *state_event, double *reached) {
    int64_t nx = integrator->nx;
    double *x0 = integrator->x, *k1 = integrator->dx;
    double *k2 = integrator->stages, *k3 = k2 + nx, *k4 = k3 + nx, *xt = k4 + nx;
    double h = target - time, middle = time + 0.5 * h;
    int32_t outcome;
    CALL(MG_FMU_CALL_GET_X, time, get_x(integrator, x0));
    CALL(MG_FMU_CALL_GET_DX, time, get_dx(integrator, k1));
    for (int64_t k = 0; k < nx; k++)
        xt[k] = x0[k] + 0.5 * h * k1[k];
    if ((outcome = derivatives_at(integrator, middle, xt, k2)))
        return outcome;
    for (int64_t k = 0; k < nx; k++)
        xt[k] = x0[k] + 0.5 * h * k2[k];
    if ((outcome = derivatives_at(integrator, middle, xt, k3)))
        return outcome;
    for (int64_t k = 0; k < nx; k++)
        xt[k] = x0[k] + h * k3[k];
    if ((outcome = derivatives_at(integrator, target, xt, k4)))
        return outcome;
    for (int64_t k = 0; k < nx; k++)
        xt[k] = x0[k] + h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
    CALL(MG_FMU_CALL_SET_X, target, set_x(integrator, xt));
    *reached = target;
    return detect_crossings(integrator, target, state_event);
}

/* -- the loop -------------------------------------------------------------------------------------- */

/* One solver step from `time` towards `target`: whether it ended on a state event, and where. */
typedef int32_t (*step_fn)(mg_integrator *, double, double, bool *, double *);

/* CVode's objects are missing, or they run Adams on a model that proved stiff (BDF from now on). */
static bool needs_new_cvode(const mg_integrator *integrator) {
    return !integrator->cvode || (integrator->nonlinear_solver && !uses_adams(integrator));
}

int32_t mg_integrator_open(mg_integrator *integrator, double time) {
    if (integrator->solver != MG_SOLVER_CVODE) { /* a fixed step compares with the indicators now */
        CALL(MG_FMU_CALL_GET_Z, time, get_z(integrator, integrator->z));
        return MG_INTEGRATOR_OK;
    }
    int32_t outcome = MG_INTEGRATOR_OK;
    if (needs_new_cvode(integrator)) {
        mg_integrator_close(integrator);
        outcome = cvode_create(integrator, time);
    }
    if (!outcome)
        outcome = set_tolerances(integrator, time);
    if (!outcome)
        outcome = cvode_reset(integrator, time);
    integrator->continuous = outcome == MG_INTEGRATOR_OK;
    return outcome;
}

void mg_integrator_close(mg_integrator *integrator) {
    if (integrator->cvode)
        SUN(CVodeFree)(&integrator->cvode);
    if (integrator->linear_solver)
        SUN(SUNLinSolFree)(integrator->linear_solver);
    if (integrator->nonlinear_solver)
        SUN(SUNNonlinSolFree)(integrator->nonlinear_solver);
    if (integrator->matrix)
        SUN(SUNMatDestroy)(integrator->matrix);
    if (integrator->y)
        SUN(N_VDestroy)(integrator->y);
    if (integrator->abstol)
        SUN(N_VDestroy)(integrator->abstol);
    if (integrator->context)
        SUN(SUNContext_Free)(&integrator->context);
    integrator->cvode = integrator->linear_solver = integrator->nonlinear_solver = integrator->matrix = NULL;
    integrator->y = integrator->abstol = integrator->context = NULL;
}

int32_t mg_integrator_advance(mg_integrator *integrator, double time, double stop) {
    bool cvode = integrator->solver == MG_SOLVER_CVODE;
    int32_t outcome = MG_INTEGRATOR_OK;
    if (cvode && needs_new_cvode(integrator))
        outcome = mg_integrator_open(integrator, time); /* the model proved stiff */
    else if (cvode && !integrator->continuous)
        outcome = cvode_reset(integrator, time);
    integrator->continuous = 0;
    while (!outcome && time < stop && !close_to(time, stop)) {
        double target = stop;
        if (integrator->has_next_event && time < integrator->next_event_time && integrator->next_event_time < target)
            target = integrator->next_event_time;
        double step_end = time + integrator->step_size; /* one that lands within rounding of the target takes it */
        if (integrator->step_size > 0 && step_end < target && !close_to(step_end, target))
            target = step_end;
        bool state_event = false;
        double reached = time;
        step_fn step = cvode ? cvode_step : integrator->solver == MG_SOLVER_RK4 ? rk4_step : euler_step;
        outcome = step(integrator, time, target, &state_event, &reached);
        if (outcome)
            break;
        time = reached;
        CALL(MG_FMU_CALL_SET_TIME, time, set_time(integrator, time));
        bool step_event = false, terminate = false;
        if (integrator->needs_completed_integrator_step) {
            CALL(MG_FMU_CALL_COMPLETED_STEP, time, completed_integrator_step(integrator, &step_event, &terminate));
            if (terminate)
                return MG_INTEGRATOR_TERMINATE;
        }
        bool time_event = integrator->has_next_event && close_to(time, integrator->next_event_time);
        if (state_event || step_event || time_event) {
            outcome = handle_event(integrator, time);
            if (!outcome && cvode)
                outcome = cvode_reset(integrator, time);
        }
    }
    integrator->continuous = cvode && outcome == MG_INTEGRATOR_OK;
    return outcome;
}
