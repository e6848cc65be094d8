/*
 * abi.c -- the library's own account of its layout: the size of every struct Python mirrors, the
 * offset of every field, the value of every shared constant. modelicagym/native/abi.py compares
 * its ctypes mirrors with this table when the library is loaded, so a header changed without its
 * mirror is a clear error instead of C and Python reading each other's bytes wrongly.
 */
#include <stddef.h>
#include <stdint.h>

#include "actions.h"
#include "qlearning.h"
#include "slice.h"
#include "step.h"

typedef struct {
    const char *name; /* "mg_env" (its size), "mg_env.component" (an offset), "MG_TERMINATED" (a value) */
    int64_t value;
} mg_abi_entry;

#define STRUCT(type) {#type, (int64_t)sizeof(type)}
#define FIELD(type, field) {#type "." #field, (int64_t)offsetof(type, field)}
#define CONSTANT(name) {#name, (int64_t)(name)}

static const mg_abi_entry entries[] = {
    STRUCT(mg_recorder),
    FIELD(mg_recorder, dts), FIELD(mg_recorder, inputs), FIELD(mg_recorder, outputs),
    FIELD(mg_recorder, input_bytes), FIELD(mg_recorder, output_bytes), FIELD(mg_recorder, capacity),
    FIELD(mg_recorder, count),
    STRUCT(mg_clock),
    FIELD(mg_clock, time), FIELD(mg_clock, origin), FIELD(mg_clock, dt), FIELD(mg_clock, start_time),
    FIELD(mg_clock, steps), FIELD(mg_clock, fmu_time_ns), FIELD(mg_clock, terminated), FIELD(mg_clock, broken),
    FIELD(mg_clock, log_errors), FIELD(mg_clock, log_error_limit), FIELD(mg_clock, recorder),
    STRUCT(mg_sundials),
    FIELD(mg_sundials, SUNContext_Create), FIELD(mg_sundials, SUNContext_Free),
    FIELD(mg_sundials, SUNContext_ClearErrHandlers), FIELD(mg_sundials, SUNContext_PushErrHandler),
    FIELD(mg_sundials, N_VNew_Serial), FIELD(mg_sundials, N_VDestroy), FIELD(mg_sundials, N_VGetArrayPointer),
    FIELD(mg_sundials, SUNDenseMatrix), FIELD(mg_sundials, SUNMatDestroy), FIELD(mg_sundials, SUNLinSol_Dense),
    FIELD(mg_sundials, SUNLinSolFree), FIELD(mg_sundials, SUNNonlinSol_FixedPoint),
    FIELD(mg_sundials, SUNNonlinSolFree), FIELD(mg_sundials, CVodeCreate), FIELD(mg_sundials, CVodeInit),
    FIELD(mg_sundials, CVodeReInit), FIELD(mg_sundials, CVodeSVtolerances), FIELD(mg_sundials, CVodeRootInit),
    FIELD(mg_sundials, CVodeSetLinearSolver), FIELD(mg_sundials, CVodeSetNonlinearSolver),
    FIELD(mg_sundials, CVodeSetMaxNumSteps), FIELD(mg_sundials, CVodeSetNoInactiveRootWarn),
    FIELD(mg_sundials, CVodeSetUserData), FIELD(mg_sundials, CVode), FIELD(mg_sundials, CVodeGetRootInfo),
    FIELD(mg_sundials, CVodeGetNumNonlinSolvConvFails), FIELD(mg_sundials, CVodeFree),
    STRUCT(mg_integrator),
    FIELD(mg_integrator, fmi_version), FIELD(mg_integrator, solver), FIELD(mg_integrator, method),
    FIELD(mg_integrator, stiff), FIELD(mg_integrator, component), FIELD(mg_integrator, set_time),
    FIELD(mg_integrator, set_x), FIELD(mg_integrator, get_x), FIELD(mg_integrator, get_dx),
    FIELD(mg_integrator, get_z), FIELD(mg_integrator, get_nominals),
    FIELD(mg_integrator, completed_integrator_step), FIELD(mg_integrator, enter_event_mode),
    FIELD(mg_integrator, update_discrete_states), FIELD(mg_integrator, enter_continuous_time_mode),
    FIELD(mg_integrator, nx), FIELD(mg_integrator, nz), FIELD(mg_integrator, needs_completed_integrator_step),
    FIELD(mg_integrator, tolerance), FIELD(mg_integrator, step_size), FIELD(mg_integrator, continuous),
    FIELD(mg_integrator, has_next_event), FIELD(mg_integrator, next_event_time), FIELD(mg_integrator, x),
    FIELD(mg_integrator, dx), FIELD(mg_integrator, z), FIELD(mg_integrator, previous_z),
    FIELD(mg_integrator, roots), FIELD(mg_integrator, stages), FIELD(mg_integrator, sundials),
    FIELD(mg_integrator, context), FIELD(mg_integrator, cvode), FIELD(mg_integrator, y),
    FIELD(mg_integrator, abstol), FIELD(mg_integrator, matrix), FIELD(mg_integrator, linear_solver),
    FIELD(mg_integrator, nonlinear_solver), FIELD(mg_integrator, failed_call), FIELD(mg_integrator, fmi_status),
    FIELD(mg_integrator, failed_at), FIELD(mg_integrator, message),
    STRUCT(mg_call),
    FIELD(mg_call, function), FIELD(mg_call, refs), FIELD(mg_call, n_refs), FIELD(mg_call, values),
    FIELD(mg_call, n_values), FIELD(mg_call, n_bytes),
    STRUCT(mg_move),
    FIELD(mg_move, source), FIELD(mg_move, target), FIELD(mg_move, source_type), FIELD(mg_move, target_type),
    STRUCT(mg_env),
    FIELD(mg_env, fmi_version), FIELD(mg_env, discrete), FIELD(mg_env, python_inputs),
    FIELD(mg_env, python_observation), FIELD(mg_env, component), FIELD(mg_env, do_step),
    FIELD(mg_env, get_boolean_status), FIELD(mg_env, set_state), FIELD(mg_env, snapshot), FIELD(mg_env, integrator),
    FIELD(mg_env, event_mode_inputs), FIELD(mg_env, snapshot_has_next_event), FIELD(mg_env, snapshot_next_event_time),
    FIELD(mg_env, set_calls),
    FIELD(mg_env, n_set_calls), FIELD(mg_env, get_calls), FIELD(mg_env, n_get_calls), FIELD(mg_env, action_moves),
    FIELD(mg_env, n_inputs), FIELD(mg_env, input_starts), FIELD(mg_env, observation_moves),
    FIELD(mg_env, n_outputs), FIELD(mg_env, observation), FIELD(mg_env, observation_bytes),
    FIELD(mg_env, action_table), FIELD(mg_env, n_actions),
    FIELD(mg_env, action_low), FIELD(mg_env, action_high), FIELD(mg_env, bound_index), FIELD(mg_env, bound_low),
    FIELD(mg_env, bound_high), FIELD(mg_env, n_bounds), FIELD(mg_env, time_step),
    FIELD(mg_env, positive_reward), FIELD(mg_env, negative_reward), FIELD(mg_env, max_episode_steps),
    FIELD(mg_env, elapsed_steps), FIELD(mg_env, native_reset), FIELD(mg_env, fmi_status),
    FIELD(mg_env, failed_call), FIELD(mg_env, clock), FIELD(mg_env, system),
    STRUCT(mg_link),
    FIELD(mg_link, source), FIELD(mg_link, target), FIELD(mg_link, source_type), FIELD(mg_link, target_type),
    FIELD(mg_link, scale), FIELD(mg_link, shift),
    STRUCT(mg_table),
    FIELD(mg_table, times), FIELD(mg_table, n_times), FIELD(mg_table, values), FIELD(mg_table, outputs),
    FIELD(mg_table, n_outputs), FIELD(mg_table, offset), FIELD(mg_table, clock),
    STRUCT(mg_component),
    FIELD(mg_component, env), FIELD(mg_component, table), FIELD(mg_component, links), FIELD(mg_component, n_links),
    FIELD(mg_component, action_links), FIELD(mg_component, n_action_links), FIELD(mg_component, inputs_changed),
    STRUCT(mg_system),
    FIELD(mg_system, components), FIELD(mg_system, n_components), FIELD(mg_system, jacobi),
    FIELD(mg_system, substeps), FIELD(mg_system, output_links), FIELD(mg_system, n_output_links),
    FIELD(mg_system, failed_component), FIELD(mg_system, guards), FIELD(mg_system, n_guards),
    FIELD(mg_system, guard_bound), FIELD(mg_system, failed_guard),
    STRUCT(mg_batch),
    FIELD(mg_batch, envs), FIELD(mg_batch, n), FIELD(mg_batch, autoreset_mode), FIELD(mg_batch, actions),
    FIELD(mg_batch, action_stride), FIELD(mg_batch, observations), FIELD(mg_batch, obs_stride),
    FIELD(mg_batch, final_obs), FIELD(mg_batch, final_ready), FIELD(mg_batch, rewards),
    FIELD(mg_batch, terminations), FIELD(mg_batch, truncations), FIELD(mg_batch, needs_reset),
    FIELD(mg_batch, active), FIELD(mg_batch, in_caller), FIELD(mg_batch, caller), FIELD(mg_batch, flags),
    FIELD(mg_batch, current_env), FIELD(mg_batch, first_env), FIELD(mg_batch, timing_enabled),
    FIELD(mg_batch, timing), FIELD(mg_batch, action_parts), FIELD(mg_batch, n_action_parts),
    FIELD(mg_batch, obs_parts), FIELD(mg_batch, n_obs_parts), FIELD(mg_batch, scratch),
    STRUCT(mg_part),
    FIELD(mg_part, offset), FIELD(mg_part, bytes), FIELD(mg_part, base), FIELD(mg_part, final_base),
    FIELD(mg_part, stride),
    STRUCT(mg_range),
    FIELD(mg_range, values), FIELD(mg_range, n), FIELD(mg_range, width), FIELD(mg_range, is_float),
    FIELD(mg_range, low_int), FIELD(mg_range, high_int), FIELD(mg_range, low), FIELD(mg_range, high),
    STRUCT(mg_waiter),
    FIELD(mg_waiter, ready), FIELD(mg_waiter, spun), FIELD(mg_waiter, slept), FIELD(mg_waiter, blocked),
    FIELD(mg_waiter, long_waits),
    STRUCT(mg_barrier),
    FIELD(mg_barrier, bell), FIELD(mg_barrier, pad_bell), FIELD(mg_barrier, countdown),
    FIELD(mg_barrier, pad_countdown), FIELD(mg_barrier, all_done), FIELD(mg_barrier, pad_all_done),
    STRUCT(mg_server),
    FIELD(mg_server, batch), FIELD(mg_server, go), FIELD(mg_server, done), FIELD(mg_server, barrier),
    FIELD(mg_server, slot), FIELD(mg_server, command), FIELD(mg_server, reply), FIELD(mg_server, step_code),
    FIELD(mg_server, spin_ns), FIELD(mg_server, timeout_ns), FIELD(mg_server, waiter),
    STRUCT(mg_collector),
    FIELD(mg_collector, n_workers), FIELD(mg_collector, go), FIELD(mg_collector, done),
    FIELD(mg_collector, barrier), FIELD(mg_collector, replies), FIELD(mg_collector, stepping),
    FIELD(mg_collector, spin_ns), FIELD(mg_collector, timeout_ns), FIELD(mg_collector, waiter),
    FIELD(mg_collector, calls), FIELD(mg_collector, wait_ns),
    STRUCT(mg_qlearner),
    FIELD(mg_qlearner, n_envs), FIELD(mg_qlearner, n_states), FIELD(mg_qlearner, n_actions),
    FIELD(mg_qlearner, n_vars), FIELD(mg_qlearner, max_edges), FIELD(mg_qlearner, q),
    FIELD(mg_qlearner, epsilon), FIELD(mg_qlearner, edges), FIELD(mg_qlearner, strides),
    FIELD(mg_qlearner, learning_rate), FIELD(mg_qlearner, discount), FIELD(mg_qlearner, exploration_decay),
    FIELD(mg_qlearner, bootstrap_on_truncation),
    CONSTANT(MG_TERMINATED), CONSTANT(MG_TRUNCATED), CONSTANT(MG_MODEL_ENDED), CONSTANT(MG_FMU_ERROR),
    CONSTANT(MG_RESET_DONE), CONSTANT(MG_PYTHON_RESET), CONSTANT(MG_BAD_ACTION), CONSTANT(MG_CALL_SET_INPUTS),
    CONSTANT(MG_CALL_DO_STEP), CONSTANT(MG_CALL_GET_OUTPUTS), CONSTANT(MG_CALL_SET_STATE),
    CONSTANT(MG_CALL_INTEGRATE), CONSTANT(MG_CALL_LOG_ERRORS), CONSTANT(MG_CALL_LOOP_GUARD), CONSTANT(MG_AUTORESET_NEXT_STEP), CONSTANT(MG_AUTORESET_SAME_STEP),
    CONSTANT(MG_AUTORESET_DISABLED), CONSTANT(MG_NO_RESET), CONSTANT(MG_RESET_THEN_REPORT),
    CONSTANT(MG_RESET_THEN_STEP), CONSTANT(MG_SERVE_TIMEOUT), CONSTANT(MG_SERVE_PYTHON_STEP),
    CONSTANT(MG_COLLECT_DONE), CONSTANT(MG_COLLECT_SLOW),
    CONSTANT(MG_SOLVER_CVODE), CONSTANT(MG_SOLVER_EULER), CONSTANT(MG_SOLVER_RK4), CONSTANT(MG_CVODE_BDF),
    CONSTANT(MG_CVODE_ADAMS), CONSTANT(MG_CVODE_AUTO), CONSTANT(MG_INTEGRATOR_OK),
    CONSTANT(MG_INTEGRATOR_TERMINATE), CONSTANT(MG_INTEGRATOR_FAILED), CONSTANT(MG_FMU_CALL_SET_TIME),
    CONSTANT(MG_FMU_CALL_SET_X), CONSTANT(MG_FMU_CALL_GET_X), CONSTANT(MG_FMU_CALL_GET_DX),
    CONSTANT(MG_FMU_CALL_GET_Z), CONSTANT(MG_FMU_CALL_GET_NOMINALS), CONSTANT(MG_FMU_CALL_COMPLETED_STEP),
    CONSTANT(MG_FMU_CALL_ENTER_EVENT_MODE), CONSTANT(MG_FMU_CALL_UPDATE_DISCRETE_STATES),
    CONSTANT(MG_FMU_CALL_ENTER_CONTINUOUS_TIME_MODE), CONSTANT(MG_FMU_CALL_SOLVER), CONSTANT(MG_TYPE_F64),
    CONSTANT(MG_TYPE_F32), CONSTANT(MG_TYPE_I8), CONSTANT(MG_TYPE_U8), CONSTANT(MG_TYPE_I16), CONSTANT(MG_TYPE_U16),
    CONSTANT(MG_TYPE_I32), CONSTANT(MG_TYPE_U32), CONSTANT(MG_TYPE_I64), CONSTANT(MG_TYPE_U64), CONSTANT(MG_TYPE_BOOL),
};

/* The table above; returns its length. */
int64_t mg_abi(const mg_abi_entry **table) {
    *table = entries;
    return (int64_t)(sizeof entries / sizeof entries[0]);
}
