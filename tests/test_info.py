"""`modelicagym info` prints a config that works as pasted for every shape of FMU that can be an
environment, and one line instead of a config for one that cannot.

Each test runs the command as a user would (`cli.main`, its output captured), pastes the printed
config (``exec``), makes the env and runs Gymnasium's `check_env` and random actions on it. The
shapes are the test FMUs ``noinputs``, ``nooutputs``, ``structural``, ``unbounded`` (C sources in
``tests/fmus/``) and, for what needs no C, descriptions rewritten from built FMUs.
"""

from __future__ import annotations

import functools
import textwrap
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from fmu_family import rewrite
from gymnasium.utils.env_checker import check_env
from lxml import etree

from modelicagym import FMUEnv, cli
from modelicagym.errors import ConfigError
from modelicagym.fmu import FMUCallError, InvalidFMUError, open_fmu
from modelicagym.fmu.fmi3 import FMI3Binding
from modelicagym.info import infer_bounds
from modelicagym.vector import PoolVectorEnv

CONFIG_START = "    from modelicagym import FMUEnv"


def run_info(capsys: pytest.CaptureFixture[str], *args: Any) -> tuple[int, str, str]:
    """``modelicagym info ARGS``: exit status, stdout, stderr."""
    status = cli.main(["info", *map(str, args)])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def pasted(stdout: str, edit: Callable[[str], str] = lambda code: code) -> tuple[FMUEnv, dict[str, Any]]:
    """The env (and config) that the config printed in ``stdout`` makes, pasted as is (or ``edit``-ed)."""
    namespace: dict[str, Any] = {}
    exec(edit(textwrap.dedent(stdout[stdout.index(CONFIG_START):])), namespace)
    return namespace["env"], namespace["config"]


def random_episode(env: FMUEnv, steps: int = 60) -> list[dict[str, Any]]:
    """Gymnasium's checks (spaces, reproducible resets), then random actions; the infos of the steps."""
    check_env(env.unwrapped, skip_render_check=True)
    env.action_space.seed(0)
    observation, _ = env.reset(seed=0)
    infos = []
    for _ in range(steps):
        observation, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(observation)
        infos.append(info)
        if terminated or truncated:
            env.reset()
    return infos


def test_no_inputs_acts_on_tunable_parameters(capsys, family_fmu, fmi_version, fmu_mode):
    status, out, _ = run_info(capsys, family_fmu("noinputs", fmi_version))
    assert status == 0
    assert "no inputs: the actions are its tunable parameters (e)" in out
    env, config = pasted(out)
    assert config["inputs"] == ["e"] and "e" not in config["parameters"]
    env.close()
    env = FMUEnv(**{**config, "mode": fmu_mode})
    assert not any("fmu_error" in info for info in random_episode(env))
    heights = {}
    for e in (0.2, 0.9):  # the action really drives the restitution: the ball bounces higher
        env.reset(seed=0)
        for _ in range(30):  # past the first bounce (t = 0.45 s)
            observation, *_ = env.step(np.array([e]))
        heights[e] = observation["h"]
    assert heights[0.9] > heights[0.2] + 0.2
    env.close()


def test_no_outputs_observes_the_continuous_states(capsys, family_fmu, fmi_version, fmu_mode):
    status, out, _ = run_info(capsys, family_fmu("nooutputs", fmi_version))
    assert status == 0
    assert "no outputs: observing its continuous states (x, v)" in out
    env, config = pasted(out)
    assert config["outputs"] == ["x", "v"]
    env.close()
    env = FMUEnv(**{**config, "mode": fmu_mode})
    random_episode(env)
    observation, _ = env.reset(seed=0)
    assert observation.tolist() == [1.0, 0.0]  # x_0 = 1, at rest
    observation, *_ = env.step(np.array([0.0]))
    assert observation[0] < 1.0 and observation[1] < 0.0  # the spring pulls it back
    env.close()


def test_without_outputs_or_states_locals_are_observed(capsys, tmp_path, family_fmu):
    def drop_states(text: str) -> str:
        return "\n".join(line for line in text.splitlines() if "ContinuousStateDerivative" not in line)

    path = rewrite(family_fmu("nooutputs", 3), tmp_path / "Locals.fmu", edit_description=drop_states)
    status, out, _ = run_info(capsys, path)
    assert status == 0
    assert "no outputs and no continuous states declared: observing its local variables (x, der(x), v, der(v))" in out
    env, _ = pasted(out)
    random_episode(env, steps=20)
    env.close()


def test_structural_parameters_stay_out_of_the_config(capsys, family_fmu, fmu_mode):
    status, out, _ = run_info(capsys, family_fmu("structural", 3))
    assert status == 0
    assert "structural parameters (stages) stay at their start values" in out
    env, config = pasted(out)
    assert "stages" not in config["parameters"]
    random_episode(env)
    env.close()


def test_a_structural_parameter_is_set_in_configuration_mode(family_fmu, fmu_mode):
    """Asked for, a structural parameter is set where FMI 3.0 allows it, on every reset rung; the
    C code refuses it anywhere else, as the standard demands."""
    path = family_fmu("structural", 3)
    binding = FMI3Binding(open_fmu(path), fmu_mode)
    binding.instantiate()
    with pytest.raises(FMUCallError, match="cannot be set in instantiated"):
        binding.set_values({"stages": 3})
    binding.configure({"stages": 3})
    assert binding.get_values(["stages"]) == {"stages": 3}
    binding.close()

    def y_after_a_second(env: FMUEnv, stages: int) -> float:
        env.reset(options={"parameters": {"stages": stages}})
        for _ in range(20):
            observation, *_ = env.step(np.array([1.0]))
        return float(observation[0])

    expected = {1: 1 - np.exp(-2.0), 2: 1 - 3 * np.exp(-2.0), 4: 1 - 19 / 3 * np.exp(-2.0)}  # Erlang CDFs at t/tau = 2
    for rung in ("snapshot", "reset", "reinstantiate"):
        env = FMUEnv(fmu=path, inputs=["u"], outputs=["y"], mode=fmu_mode, reset_rung=rung)
        for stages in (1, 4, 2, 4):
            assert y_after_a_second(env, stages) == pytest.approx(expected[stages], rel=1e-6)
        env.close()


def test_unbounded_input_gets_inferred_bounds_that_keep_the_model_working(capsys, family_fmu, fmi_version):
    status, out, _ = run_info(capsys, family_fmu("unbounded", fmi_version))
    assert status == 0
    assert ("'p_amb': (50662.5, 151987.5),  # inferred from a pressure in Pa around its start 101325 Pa, +-50%: "
            "edit to the model's range") in out
    env, config = pasted(out)
    assert env.step_path == "native"  # bounds on a Float64 Box keep the native step
    assert not any("fmu_error" in info for info in random_episode(env, steps=200))
    actions = [env.action_space.sample() for _ in range(1000)]
    assert 5e4 <= min(actions)[0] and max(actions)[0] <= 1.52e5
    env.close()

    unbounded = FMUEnv(**{**config, "action_bounds": None})  # what `info` printed before: the model breaks
    unbounded.action_space.seed(0)
    unbounded.reset(seed=0)
    *_, truncated, info = unbounded.step(unbounded.action_space.sample())
    assert truncated and "ambient pressure" in info["fmu_error"] and "outside the range" in info["fmu_error"]
    unbounded.close()


def test_many_inputs_act_on_the_commands_and_hold_the_conditions(capsys, family_fmu, fmi_version):
    """The cooling consumer (six inputs, no declared range, in Pa, K, W or without a unit): the
    command is the action, the others are held; a temperature starting at 0 K is held at a
    typical one; the command's range, which nothing in the FMU says, is left for the user."""
    status, out, _ = run_info(capsys, family_fmu("consumer", fmi_version))
    assert status == 0
    assert ("6 inputs: acting on valve (no unit: commands, most likely); holding p_supply, p_return, T_supply, T_amb, "
            "Q_gain in 'fixed_inputs'") in out
    assert "'p_supply': 300000.0,  # its start; as an action: (150000.0, 450000.0)" in out
    assert ("'T_amb': 293.15,  # a typical temperature (its start 0 K cannot be one); as an action: "
            "(273.15, 313.15)") in out
    assert "'valve': None,  # TO FILL IN with (low, high): nothing in the FMU says its range" in out
    assert "action bounds to fill in for valve: nothing in the FMU says its range" in out
    with pytest.raises(ConfigError, match="action_bounds of 'valve' is still None"):
        pasted(out)
    env, config = pasted(out, lambda code: code.replace("'valve': None", "'valve': (0.0, 1.0)"))
    assert config["inputs"] == ["valve"] and set(config["fixed_inputs"]) == {"p_supply", "p_return", "T_supply",
                                                                             "T_amb", "Q_gain"}
    assert not any("fmu_error" in info for info in random_episode(env, steps=50))
    env.close()


def test_units_give_bounds_a_user_can_trust(family_fmu):
    """A pressure or an absolute temperature never goes below 0, and is explored around its start
    (a temperature +-20 K, not +-50% of 279 K); a start of 0 K is not taken for a temperature."""
    description = open_fmu(family_fmu("consumer", 3))
    bounds = {name: infer_bounds(description.variables[name], description)
              for name in ("p_supply", "T_supply", "T_amb", "Q_gain", "valve")}
    assert (bounds["p_supply"].low, bounds["p_supply"].high) == (1.5e5, 4.5e5)
    assert (bounds["T_supply"].low, bounds["T_supply"].high) == pytest.approx((259.15, 299.15))
    assert (bounds["T_amb"].low, bounds["T_amb"].high, bounds["T_amb"].center) == (273.15, 313.15, 293.15)
    assert "its start 0 K cannot be a temperature" in bounds["T_amb"].reason
    assert (bounds["Q_gain"].low, bounds["Q_gain"].high) == (1000.0, 3000.0)  # W says nothing: its start +-50%
    assert bounds["valve"].placeholder and bounds["valve"].reason == (
        "nothing in the FMU says its range (start 0.0, no nominal, no unit)")


@pytest.mark.processes
@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("n", [2, 8])
def test_a_pool_of_pasted_configs_steps_random_actions(capsys, family_fmu, n):
    """The pasted config in a pool: ``num_workers=2`` puts envs in worker processes."""
    _, out, _ = run_info(capsys, family_fmu("unbounded", 3))
    env, config = pasted(out)
    env.close()
    pool = PoolVectorEnv([functools.partial(FMUEnv, config)] * n, num_workers=2)
    try:
        pool.reset(seed=0)
        pool.action_space.seed(0)
        for _ in range(20):
            *_, truncations, infos = pool.step(pool.action_space.sample())
            assert "fmu_error" not in infos and not truncations.any()
    finally:
        pool.close()


def test_inferred_bounds_take_related_variables_declared_range(tmp_path, family_fmu):
    def declare_vessel_range(text: str) -> str:
        return text.replace('initial="calculated" unit="Pa"/>', 'initial="calculated" unit="Pa" min="3e4" max="4e5"/>')

    path = rewrite(family_fmu("unbounded", 3), tmp_path / "Tank.fmu", edit_description=declare_vessel_range)
    description = open_fmu(path)
    bounds = infer_bounds(description.variables["p_amb"], description)
    assert (bounds.low, bounds.high) == (3e4, 4e5)
    assert bounds.reason == "the declared range of p (same unit Pa)"

    def declare_min_only(text: str) -> str:
        return text.replace('unit="Pa" start="101325"', 'unit="Pa" min="1e5" start="101325"')

    path = rewrite(family_fmu("unbounded", 3), tmp_path / "TankMin.fmu", edit_description=declare_min_only)
    description = open_fmu(path)
    bounds = infer_bounds(description.variables["p_amb"], description)
    assert bounds.low == 1e5 and bounds.high == pytest.approx(101325 * 1.5)


def test_action_bounds_are_checked_like_the_other_keys(family_fmu):
    path = family_fmu("unbounded", 2)
    with pytest.raises(ConfigError, match=r"names 'p_am', which is not in 'inputs'. Did you mean 'p_amb'\?"):
        FMUEnv(fmu=path, inputs=["p_amb"], outputs=["p"], action_bounds={"p_am": (5e4, 2e5)})
    with pytest.raises(ConfigError, match=r"action_bounds on 'p_amb' has low > high"):
        FMUEnv(fmu=path, inputs=["p_amb"], outputs=["p"], action_bounds={"p_amb": (2e5, 5e4)})
    with pytest.raises(ConfigError, match=r"action_bounds on 'p_amb' must be finite"):
        FMUEnv(fmu=path, inputs=["p_amb"], outputs=["p"], action_bounds={"p_amb": (5e4, np.inf)})


def test_action_bounds_keep_the_native_step_on_the_cartpole(cartpole_fmu):
    env = FMUEnv(fmu=cartpole_fmu(2), inputs=["f"], outputs=["x", "theta"], action_bounds={"f": (-3.0, 4.0)})
    assert env.step_path == "native"
    assert (env.action_space.low.tolist(), env.action_space.high.tolist()) == ([-3.0], [4.0])
    env.close()


def _no_config(out: str) -> str:
    """The refusal line, checked to be the last line and to come with no config."""
    assert CONFIG_START not in out and "config = {" not in out
    last = out.strip().splitlines()[-1]
    assert last.startswith("no config: ")
    return last


def test_nothing_to_act_on_is_one_line(capsys, tmp_path, family_fmu, fmi_version):
    path = rewrite(family_fmu("noinputs", fmi_version), tmp_path / "Fixed.fmu",
                   edit_description=lambda text: text.replace('variability="tunable"', 'variability="fixed"'))
    status, out, _ = run_info(capsys, path)
    assert status == 0
    assert _no_config(out) == ("no config: Fixed.fmu has nothing to act on: no inputs and no tunable parameters, "
                               "which is what an FMUEnv's actions drive, so there is no config")


def test_nothing_to_observe_is_one_line(capsys, tmp_path, family_fmu):
    def keep_no_observable(text: str) -> str:
        root = etree.fromstring(text.encode())
        variables, structure = root.find("ModelVariables"), root.find("ModelStructure")
        for variable in list(variables):
            if variable.get("causality") == "local":
                variables.remove(variable)
        for unknown in list(structure):
            structure.remove(unknown)
        return etree.tostring(root, encoding="unicode")

    path = rewrite(family_fmu("nooutputs", 3), tmp_path / "Blind.fmu", edit_description=keep_no_observable)
    status, out, _ = run_info(capsys, path)
    assert status == 0
    assert _no_config(out).startswith("no config: Blind.fmu has nothing to observe: no outputs, no continuous states")


def test_neither_co_simulation_nor_model_exchange_is_one_line(capsys, tmp_path, family_fmu):
    def scheduled_only(text: str) -> str:
        root = etree.fromstring(text.encode())
        for interface in ("ModelExchange", "CoSimulation"):
            root.remove(root.find(interface))
        root.insert(0, etree.fromstring('<ScheduledExecution modelIdentifier="NoOutputs"/>'))
        return etree.tostring(root, encoding="unicode")

    path = rewrite(family_fmu("nooutputs", 3), tmp_path / "Scheduled.fmu", edit_description=scheduled_only)
    status, out, _ = run_info(capsys, path)
    assert status == 0
    assert _no_config(out) == ("no config: Scheduled.fmu supports neither co-simulation nor model exchange (it offers "
                               "scheduled execution only): modelicagym cannot run it, so there is no config")
    assert "'mode': None" not in out


def test_a_validation_failure_names_the_rule_and_how_to_go_on(capsys, tmp_path, family_fmu):
    variable = '<ScalarVariable name="moving" valueReference="15"'
    path = rewrite(family_fmu("probe", 2), tmp_path / "Probe.fmu",
                   edit_description=lambda text: text.replace(variable, variable + ' bogus="1"'))
    status, out, err = run_info(capsys, path)
    assert status == 1 and out == ""
    [line] = err.strip().splitlines()
    assert "fails validation (variables concerned: moving)" in line and "bogus" in line
    assert f"to go on anyway: modelicagym info {path} --no-validate" in line
    assert line.endswith("(the config it prints then has validate=False)")

    status, out, _ = run_info(capsys, path, "--no-validate")
    assert status == 0
    env, config = pasted(out)
    assert config["validate"] is False
    random_episode(env, steps=20)
    env.close()

    with pytest.raises(InvalidFMUError, match="bogus"):  # --debug after the subcommand: the traceback
        cli.main(["info", str(path), "--debug"])
    with pytest.raises(InvalidFMUError, match="bogus"):
        cli.main(["--debug", "info", str(path)])


def test_a_truncated_description_does_not_suggest_skipping_validation(capsys, tmp_path, family_fmu):
    path = rewrite(family_fmu("probe", 2), tmp_path / "Cut.fmu", edit_description=lambda text: text[: len(text) // 2])
    for args in ((path,), (path, "--no-validate")):
        status, out, err = run_info(capsys, *args)
        assert status == 1 and out == ""
        [line] = err.strip().splitlines()
        assert "cannot read modelDescription.xml" in line
        assert "validate" not in line
    with pytest.raises(InvalidFMUError) as raised:
        open_fmu(path)
    assert "validate=False" not in str(raised.value)


def test_every_bundled_shape_is_described(capsys, family_fmu):
    """The FMUs that already worked keep working from the pasted config (the probe: eight inputs
    of five types, arrays, twelve outputs)."""
    status, out, _ = run_info(capsys, family_fmu("probe", 3))
    assert status == 0
    env, _ = pasted(out)
    random_episode(env, steps=20)
    env.close()


def test_printed_config_is_valid_python_with_its_comments(capsys, family_fmu):
    _, out, _ = run_info(capsys, family_fmu("unbounded", 2))
    code = textwrap.dedent(out[out.index(CONFIG_START):])
    compile(code, "<info>", "exec")
    assert "# inferred from" in code



@pytest.mark.parametrize("name, fmi_version, line", [
    ("probe", 2, "saved states (env.unwrapped.get_state() / set_state): yes"),
    ("probe", 3, "saved states (env.unwrapped.get_state() / set_state): yes"),
    ("probe_late", 2, "saved states: no (canGetAndSetFMUstate is false)"),
])
def test_info_says_in_one_line_whether_states_can_be_saved(capsys, family_fmu, name, fmi_version, line):
    status, out, _ = run_info(capsys, family_fmu(name, fmi_version))
    assert status == 0 and out.count("saved states") == 1 and f"  {line}\n" in out
