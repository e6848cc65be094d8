"""Model exchange with the solver loop in C (`modelicagym.fmu.native_integrator`) against the Python
loop (``integrator="python"`` / ``step_path="python"``), on the family members made for it: the
bouncing ball (state and time events), the staircase (time events, two-pass event iteration, a
terminating event), the stiff model, and the cart-pole.

Every solver (``"cvode"``: Adams until the model proves stiff, then BDF; ``"cvode-bdf"``;
``"euler"``; ``"rk4"``) runs the same algorithm on both paths, calling the same SUNDIALS binaries
in the same order, and both let CVode go on across steps whose inputs did not change: an instance, an env and a
pool give the same numbers to the last bit, event times included.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
import pytest
from fmu_family import BALL_OUTPUTS, STAIRCASE_OUTPUTS, STIFF_OUTPUTS
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.fmu import FMUCallError, FMUError, FMUInstance
from modelicagym.vector import PoolVectorEnv

MODELS = {  # outputs, input, parameters, step size, steps
    "ball": (BALL_OUTPUTS, None, {"e": 0.9, "t_switch": 0.8}, 0.05, 40),
    "staircase": (STAIRCASE_OUTPUTS, "u", {"period": 0.25, "t_stop": 2.6}, 0.1, 30),
    "stiff": (STIFF_OUTPUTS, "u", {"lambda": 1e4}, 0.01, 60),
}
DISCRETE = {"bounces", "e_now", "level", "steps_taken", "iterations", "stopped"}
EVENT_TIMES = {"t_bounce", "t_switched", "t_last_event"}


def simulate(path, outputs, u_name, parameters, dt, n_steps, **options) -> tuple[list[dict[str, float]], FMUInstance]:
    """Outputs after each step of a model-exchange instance, the input (if any) switching every
    few steps; stops after the step that ends the simulation. Returns the rows and the (closed) instance."""
    rows = []
    with FMUInstance(path, mode="me", inputs=[u_name] if u_name else [], outputs=outputs, **options) as fmu:
        fmu.reset(parameters)
        for k in range(n_steps):
            if u_name:
                fmu.inputs.views[u_name][...] = (0.5, -0.5, 1.0)[(k // 4) % 3]
            ended = fmu.step(dt)
            rows.append({name: float(view) for name, view in fmu.outputs.views.items()})
            if ended:
                break
    return rows, fmu


def run_model(family_fmu, name: str, fmi_version: int, **options) -> tuple[list[dict[str, float]], FMUInstance]:
    outputs, u_name, parameters, dt, n_steps = MODELS[name]
    return simulate(family_fmu(name, fmi_version), outputs, u_name, parameters, dt, n_steps, **options)


SOLVERS = {"cvode": {}, "cvode-bdf": {}, "euler": {"solver_step": 1e-3}, "rk4": {"solver_step": 1e-3}}
#: the stiff model (eigenvalue -1e4) needs explicit steps inside their stability regions
STIFF_STEPS = {"euler": {"solver_step": 2e-5}, "rk4": {"solver_step": 1e-4}}


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.parametrize("solver", sorted(SOLVERS))
def test_every_solver_gives_the_python_paths_numbers_in_c(family_fmu, fmi_version, name, solver):
    options = STIFF_STEPS.get(solver, {}) if name == "stiff" else SOLVERS[solver]
    native, native_fmu = run_model(family_fmu, name, fmi_version, solver=solver, **options)
    python, python_fmu = run_model(family_fmu, name, fmi_version, solver=solver, integrator="python", **options)
    assert (native_fmu.integrator_path, python_fmu.integrator_path) == ("native", "python")
    assert native == python
    assert native_fmu.native_integrator is None  # closed with the instance


@pytest.mark.parametrize("integrator", ["auto", "python"])
def test_cvode_switches_to_bdf_on_a_stiff_model_only(family_fmu, integrator):
    methods = {}
    for name, parameters in (("stiff", {"lambda": 1e4}), ("stiff", {"lambda": 10.0}), ("ball", {})):
        outputs, u_name, _, dt, _ = MODELS[name]
        with FMUInstance(family_fmu(name, 2), mode="me", outputs=outputs, integrator=integrator) as fmu:
            fmu.reset(parameters)
            assert fmu.solver_method == "adams"
            for _ in range(5):
                fmu.step(dt)
            methods[name, parameters.get("lambda")] = fmu.solver_method
    assert methods == {("stiff", 1e4): "bdf", ("stiff", 10.0): "adams", ("ball", None): "adams"}


def test_the_solver_method_reads_as_configured(family_fmu):
    for mode, solver, method in (("me", "cvode-bdf", "bdf"), ("me", "euler", None), ("me", "rk4", None), ("cs", "cvode", None)):
        with FMUInstance(family_fmu("ball", 3), mode=mode, solver=solver, solver_step=1e-3) as fmu:
            assert fmu.solver_method == method


@pytest.mark.parametrize("solver", ["euler", "rk4"])
def test_a_fixed_step_solver_needs_its_step(family_fmu, solver):
    with pytest.raises(ConfigError, match=f"solver='{solver}' needs a step_size"):
        FMUInstance(family_fmu("ball", 2), mode="me", solver=solver)


def test_the_instance_says_which_integrator_runs_and_why(family_fmu):
    with FMUInstance(family_fmu("ball", 3), mode="me") as fmu:
        assert (fmu.integrator_path, fmu.integrator_path_reason) == ("native", "the solver loop runs in C")
    with FMUInstance(family_fmu("ball", 3), mode="me", integrator="python") as fmu:
        assert fmu.integrator_path == "python" and "integrator='python'" in fmu.integrator_path_reason
    with FMUInstance(family_fmu("ball", 2), mode="cs") as fmu:
        assert fmu.integrator_path is None  # co-simulation: the FMU integrates
    with pytest.raises(ConfigError, match="integrator must be"):
        FMUInstance(family_fmu("ball", 2), mode="me", integrator="fortran")


@pytest.mark.parametrize("solver", sorted(SOLVERS))
def test_an_fmu_call_failing_inside_the_solver_says_which_and_the_next_reset_recovers(family_fmu, fmi_version, solver):
    outputs, u_name, parameters, dt, _ = MODELS["stiff"]
    function = "fmi2GetDerivatives" if fmi_version == 2 else "fmi3GetContinuousStateDerivatives"
    messages = []
    for integrator in ("auto", "python"):
        with FMUInstance(family_fmu("stiff", fmi_version), mode="me", inputs=["u"], outputs=outputs,
                         integrator=integrator, solver=solver, **SOLVERS[solver]) as fmu:
            fmu.reset(parameters)
            fmu.inputs.views["u"][...] = np.nan  # the model's derivative is NaN: it returns Error
            with pytest.raises(FMUCallError, match=f"{function} returned Error") as raised:
                fmu.step(dt)
            messages.append(str(raised.value))
            assert fmu.broken
            fmu.reset(parameters)
            fmu.inputs.views["u"][...] = 1.0
            fmu.step(dt)
            assert np.isfinite(fmu.outputs.flat).all()
    assert messages[0] == messages[1]  # the same call, status and log on either path
    assert "the derivative of state 0 is nan at t=0" in messages[0]


def test_a_solver_failure_is_an_fmu_error_with_cvodes_message_and_nothing_on_stderr(family_fmu, capfd):
    outputs, _, parameters, dt, _ = MODELS["stiff"]
    for integrator in ("auto", "python"):
        with FMUInstance(family_fmu("stiff", 2), mode="me", outputs=outputs, integrator=integrator,
                         tolerance=1e-30) as fmu:
            fmu.reset(parameters)
            with pytest.raises(FMUError, match="cvode solver failed at t=0.0: .*too much accuracy requested"):
                fmu.step(dt)
    assert "too much accuracy" not in capfd.readouterr().err  # SUNDIALS' own printing is off


# -- the env and the pool -------------------------------------------------------------------------


def staircase_env(path, **config: Any) -> FMUEnv:
    return FMUEnv(fmu=path, mode="me", inputs=["u"], outputs=["x", "level", "t_last_event"],
                  parameters={"period": 0.25, "t_stop": 1.3}, time_step=0.1, **config)


def test_model_exchange_envs_take_the_native_step_path(family_fmu):
    env = staircase_env(family_fmu("staircase", 3))
    assert (env.step_path, env.step_path_reason) == ("native", "the config defines the whole step")
    cartpole = modelicagym.make("cartpole", mode="me")
    assert cartpole.unwrapped.step_path == "native"
    python = modelicagym.make("cartpole", mode="me", step_path="python")
    assert python.unwrapped.fmu.integrator_path == "python"


def test_the_native_env_agrees_with_the_python_env_and_ends_at_t_stop(family_fmu, fmi_version):
    envs = [staircase_env(family_fmu("staircase", fmi_version), **options) for options in ({}, {"step_path": "python"})]
    results = []
    for env in envs:
        env.reset(seed=0)
        episode = []
        for k in range(20):
            observation, reward, terminated, truncated, info = env.step(np.array([(0.5, -0.5)[(k // 3) % 2]]))
            episode.append((observation, terminated, info))
            if terminated:
                break
        results.append(episode)
    native, python = results
    assert len(native) == len(python) == 13  # t_stop = 1.3: the 13th step ends the episode
    assert native[-1][1] and native[-1][2] == {"fmu_terminated": True}
    for (a, _, _), (b, _, _) in zip(native, python):
        assert a.tolist() == b.tolist()


def test_the_balls_bounce_times_are_the_same_on_both_step_paths(family_fmu, fmi_version):
    """The input does not change: CVode runs on across the steps, on either path, to the same bounces."""
    bounces = []
    for step_path in ("auto", "python"):
        env = FMUEnv(fmu=family_fmu("ball", fmi_version), mode="me", inputs=["a"], outputs=["h", "v", "t_bounce"],
                     parameters={"e": 0.9, "t_switch": 0.8}, time_step=0.05, step_path=step_path)
        env.reset(seed=0)
        assert env.step_path == ("native" if step_path == "auto" else "python")
        bounces.append([env.step(np.zeros(1))[0].tolist() for _ in range(60)])
        env.close()
    native, python = bounces
    assert native == python
    assert len({t_bounce for _, _, t_bounce in native}) >= 5  # four bounces and the start: real event times


@pytest.mark.processes
@pytest.mark.parametrize("solver", ["cvode", "euler", "rk4"])
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_the_pool_steps_and_resets_model_exchange_natively_like_sync(family_fmu, mode, solver):
    """Every episode (native resets restore the snapshot and its pending time event) matches
    SyncVectorEnv over the Python path exactly."""
    path = family_fmu("staircase", 2)
    options = {"solver": solver, "solver_step": None if solver == "cvode" else 0.01}
    native = [partial(staircase_env, path, max_episode_steps=4 + i, **options) for i in range(3)]
    python = [partial(staircase_env, path, max_episode_steps=4 + i, step_path="python", **options) for i in range(3)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, caller_steps=True) as pool:
        assert [path for path, _ in pool.step_paths] == ["native"] * 3, pool.step_paths
        expected, actual = rollout(sync, 40), rollout(pool, 40)
    sync.close()
    assert_same(expected, actual)
