"""A system's connections are checked once, each failure one line naming the connection
(modelicagym/system/graph.py, units.py): type and unit mismatches, unknown
components and variables with close matches, inputs fed twice or driven by an action too."""

from __future__ import annotations

import pytest
from system_cases import system_config

from modelicagym import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import VariableError
from modelicagym.system import open_system
from modelicagym.system.units import Unit, conversion


@pytest.fixture
def fmus(family_fmu):
    return {"motor": str(family_fmu("motor", 2)), "plant": str(family_fmu("inertia", 3))}


def refusal(fmus, *connections) -> str:
    with pytest.raises((ConfigError, VariableError)) as caught:
        open_system(fmus=fmus, connections=connections)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_an_algebraic_loop_is_found_and_broken_by_the_stepping_order(fmus):
    # tau_set depends on u directly, a on tau directly: a loop with no state in it
    system = open_system(fmus=fmus, connections=[("motor.tau_set", "plant.tau"), ("plant.a", "motor.u")])
    assert system.loop_lines("gauss-seidel") == [
        ("loop motor.tau_set -> plant.tau, plant.a -> motor.u: gauss-seidel reads plant.a -> motor.u from the "
        "previous step (motor steps first in the loop)")]
    assert system.loop_lines("jacobi") == [
        ("loop motor.tau_set -> plant.tau, plant.a -> motor.u: jacobi reads every connection of it from the previous "
        "step")]


def test_a_loop_through_a_state_is_no_algebraic_loop(fmus):
    system = open_system(fmus=fmus, connections=[("motor.tau_set", "plant.tau"), ("plant.w", "motor.w")])
    assert system.order == ["motor", "plant"]
    assert system.loops == []
    assert [v.name for v in system.inputs] == ["motor.u", "plant.tau_load"]


def test_sources_step_first(fmus):
    system = open_system(fmus={"plant": fmus["plant"], "motor": fmus["motor"]},
                         connections=[("motor.tau", "plant.tau")])
    assert system.order == ["motor", "plant"]


def test_a_type_mismatch_is_refused(fmus):
    message = refusal(fmus, ("motor.saturated", "plant.tau_load"))
    assert message.endswith("connection motor.saturated -> plant.tau_load: type mismatch: a Boolean output into a "
                            "Float64 input")


def test_units_of_different_dimensions_are_refused(fmus):
    message = refusal(fmus, ("plant.a", "motor.w"))
    assert "plant.a -> motor.w: units do not match: 'rad/s2' is s-2.rad, 'rpm' is s-1.rad" in message


@pytest.mark.parametrize("connection, hint", [
    (("moter.tau", "plant.tau"), "no component named 'moter'. Did you mean 'motor'?"),
    (("motor.taux", "plant.tau"), "no output named 'taux'. Did you mean 'tau'"),
    (("motor.tau", "plant.tao"), "no input named 'tao'. Did you mean 'tau'"),
    (("motor.u", "plant.tau"), "'motor.u' is not an output"),
    (("motor.tau", "plant.w"), "'plant.w' is not an input"),
    (("motor.tau", "plant"), "'plant' is not 'component.variable'"),
])
def test_unknown_or_misused_ends_are_named_with_close_matches(fmus, connection, hint):
    message = refusal(fmus, connection)
    assert f"connection {connection[0]} -> {connection[1]}" in message and hint in message


def test_an_input_has_one_source(fmus):
    message = refusal(fmus, ("motor.tau", "plant.tau"), ("motor.tau_set", "plant.tau"))
    assert "'plant.tau' is already fed by 'motor.tau'" in message


def test_a_connected_input_is_no_action(fmus):
    config = {"fmus": fmus, "connections": [("motor.tau", "plant.tau")], "inputs": ["plant.tau"],
              "outputs": ["plant.w"]}
    with pytest.raises(VariableError, match="'plant.tau' cannot be an action: the connection motor.tau -> plant.tau"):
        FMUEnv(config)


def test_a_connected_input_is_not_held_either(fmus):
    config = {"fmus": fmus, "connections": [("motor.tau", "plant.tau")], "inputs": ["motor.u"],
              "outputs": ["plant.w"], "fixed_inputs": {"plant.tau": 1.0}}
    with pytest.raises(VariableError, match="'plant.tau' cannot be set: the connection motor.tau -> plant.tau feeds it"):
        FMUEnv(config)


def test_config_names_are_checked_with_close_matches(family_fmu):
    config = system_config(family_fmu("motor", 2), family_fmu("inertia", 3))
    with pytest.raises(VariableError, match="no output named 'ww'. Did you mean 'w'"):
        FMUEnv({**config, "outputs": ["plant.ww"]})
    with pytest.raises(ConfigError, match="no component named 'plnt'. Did you mean 'plant'"):
        FMUEnv({**config, "parameters": {"plnt.J": 1.0}})


def test_a_single_fmu_refuses_a_systems_options(family_fmu):
    with pytest.raises(ConfigError, match="'master' and 'substeps' are a system's options"):
        FMUEnv(fmu=family_fmu("motor", 2), inputs=["u"], outputs=["tau"], master="jacobi")


def test_unit_conversion_by_base_units_factor_and_offset():
    kelvin = Unit("K", (0, 0, 0, 0, 1, 0, 0, 0))
    celsius = Unit("degC", kelvin.exponents, offset=273.15)
    fahrenheit = Unit("degF", kelvin.exponents, factor=5 / 9, offset=273.15 - 32 * 5 / 9)
    to_kelvin = conversion(celsius, kelvin, "c")
    assert to_kelvin.scale * 20.0 + to_kelvin.shift == pytest.approx(293.15, rel=1e-15)
    to_fahrenheit = conversion(celsius, fahrenheit, "c")
    assert to_fahrenheit.scale * 100.0 + to_fahrenheit.shift == pytest.approx(212.0, rel=1e-12)
    assert conversion(None, kelvin, "c").identity and conversion(kelvin, kelvin, "c").identity
    with pytest.raises(ConfigError, match="units 'K' and 'deg' differ, and 'deg' has no definition"):
        conversion(kelvin, Unit("deg", None), "c")
