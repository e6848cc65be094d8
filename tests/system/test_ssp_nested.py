"""SSP systems as other tools export them (modelicagym/system/ssp.py): systems nested two and three
deep load as one flat system (``sub.component.variable``), connections through sub-systems'
connectors reach the components behind them with their transformations composed, the higher
level's parameter binding wins, the top-level system's connectors are the env's inputs and
outputs. The Gain FMU (``y = k u + b``) makes every value computable by hand."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from ssp_cases import bindings, component, connect, connectors, mapping, parameter_set, system, write_ssp_folder

from modelicagym import FMUEnv
from modelicagym.errors import ConfigError, DataError
from modelicagym.info import describe_fmu, suggest
from modelicagym.simulation import simulate
from modelicagym.system import open_system
from modelicagym.system.ssp import read_ssp


@pytest.fixture
def gain(family_fmu):
    return family_fmu("gain", 2)


def stage(name: str, parameters: str = "", gain_parameters: str = "") -> str:
    """A sub-system: its input ``u`` doubled into a gain, the gain's ``y`` its output ``y``."""
    return system(name, [component("g", "gain", gain_parameters)],
                  [connect(".u", "g.u", factor=2.0), connect("g.y", ".y")], connectors(u="input", y="output"),
                  parameters)


def test_a_sub_system_is_flattened_and_its_connectors_are_the_envs_inputs_and_outputs(gain, tmp_path):
    # the sub-system's binding (k = 3) wins over the component's own (k = 10); the top's sets b
    top = system("top", [stage("stage", bindings({"g.k": 3.0}), bindings({"k": 10.0}))],
                 [connect(".u", "stage.u"), connect("stage.y", ".y")], connectors(u="input", y="output"),
                 bindings({"stage.g.b": 0.5}))
    folder = write_ssp_folder(tmp_path / "nested", top, {"gain": gain})
    described = open_system(folder)
    assert list(described.components) == ["stage.g"]
    assert described.parameter_values == {"stage.g.k": 3.0, "stage.g.b": 0.5}
    assert [v.name for v in described.inputs] == ["u"] and "y" in [v.name for v in described.outputs]
    env = FMUEnv(fmu=folder, inputs=["u"], outputs=["y", "stage.g.u"], time_step=0.1)
    env.reset(seed=0)
    for action in (1.0, -0.25, 4.0):
        observation = env.step(np.array([action]))[0]
        np.testing.assert_allclose(observation, [3.0 * 2.0 * action + 0.5, 2.0 * action])
    with pytest.raises(Exception, match="'stage.g.u' cannot be an action: the system's input 'u' feeds it"):
        FMUEnv(fmu=folder, inputs=["stage.g.u"], outputs=["y"], time_step=0.1)
    env.close()


def test_three_levels_deep_the_transformations_compose_and_the_top_binding_wins(gain, tmp_path):
    inner = system("s2", [component("g", "gain", bindings({"k": 10.0, "b": 1.0}))],
                   [connect(".u", "g.u"), connect("g.y", ".y", factor=2.0)], connectors(u="input", y="output"),
                   bindings({"g.k": 20.0, "g.b": 2.0}))
    middle = system("s1", [inner], [connect(".u", "s2.u"), connect("s2.y", ".y", offset=1.0)],
                    connectors(u="input", y="output"), bindings({"s2.g.k": 30.0}))
    top = system("top", [middle, component("g2", "gain")],
                 [connect(".u", "s1.u"), connect("s1.y", "g2.u", factor=3.0), connect("g2.y", ".y")],
                 connectors(u="input", y="output"), bindings({"s1.s2.g.k": 40.0}))
    folder = write_ssp_folder(tmp_path / "deep", top, {"gain": gain})
    described = open_system(folder)
    assert list(described.components) == ["s1.s2.g", "g2"]
    assert described.parameter_values == {"s1.s2.g.k": 40.0, "s1.s2.g.b": 2.0}
    (link,) = described.links
    assert link.label == "s1.s2.g.y -> g2.u"
    assert (link.conversion.scale, link.conversion.shift) == (6.0, 3.0)  # 3 (2 y + 1)
    env = FMUEnv(fmu=folder, inputs=["u"], outputs=["y", "s1.s2.g.y"], time_step=0.1)
    env.reset(seed=0)
    observation = env.step(np.array([0.5]))[0]
    deep = 40.0 * 0.5 + 2.0
    np.testing.assert_allclose(observation, [3.0 * (2.0 * deep + 1.0), deep])
    env.close()


def test_a_value_bound_to_a_connector_goes_through_each_transformation_in_turn(gain, tmp_path):
    # outside in: x 3 at the top, then + 1 inside (not (x + 1) 3)
    inner = system("sub", [component("g", "gain"), component("h", "gain")],
                   [connect(".p", "g.k", offset=1.0), connect(".p", "g.b"), connect(".u", "h.u", offset=1.0)],
                   connectors(p="parameter", u="input"))
    top = system("top", [inner], [connect(".p", "sub.p", factor=3.0), connect(".u", "sub.u", factor=3.0)],
                 connectors(p="parameter", u="input"), bindings({"p": 2.0}))
    described = open_system(write_ssp_folder(tmp_path / "chain", top, {"gain": gain}))
    assert described.parameter_values == {"sub.g.k": 3.0 * 2.0 + 1.0, "sub.g.b": 3.0 * 2.0}
    assert [(target, (c.scale, c.shift)) for target, c in described.feeds("u")] == [("sub.h.u", (3.0, 1.0))]


def test_a_system_parameter_wins_over_the_components_own_binding(gain, tmp_path):
    # OMSimulator's toplevelparameter1: the system's parameter connectors feed the components' k
    top = system("top", [component("a", "gain", bindings({"k": 10.0})), component("b", "gain", bindings({"k": 10.0}))],
                 [connect(".k1", "a.k"), connect(".k2", "b.k")], connectors(k1="parameter", k2="parameter"),
                 bindings({"k1": -200.0}, {"k1": -100.0, "k2": -300.0}))  # the later binding of a level wins
    described = open_system(write_ssp_folder(tmp_path / "top", top, {"gain": gain}))
    assert described.parameter_values == {"a.k": -100.0, "b.k": -300.0}


def test_a_parameter_that_feeds_nothing_is_reported_not_fatal(gain, tmp_path, caplog):
    top = system("top", [component("g", "gain")], [], connectors(Input_cref="parameter"),
                 bindings({"Input_cref": 7.0}))
    with caplog.at_level(logging.WARNING, logger="modelicagym.system.ssp"):
        described = open_system(write_ssp_folder(tmp_path / "loose", top, {"gain": gain}))
    assert described.parameter_values == {}
    assert len(described.notes) == 1 and "parameter 'Input_cref'" in described.notes[0]
    assert "feeds no component" in described.notes[0] and "feeds no component" in caplog.text


def test_a_mapping_with_one_source_and_several_targets_sets_every_target(gain, tmp_path):
    top = system("top", [component("a", "gain"), component("b", "gain")],
                 parameters=bindings(source="resources/k.ssv", ssm="resources/k.ssm"))
    folder = write_ssp_folder(tmp_path / "mapped", top, {"gain": gain}, {
        "resources/k.ssv": parameter_set({"k_all": 4.0, "a.b": 1.5}),
        "resources/k.ssm": mapping(("k_all", "a.k"), ("k_all", "b.k"))})
    assert open_system(folder).parameter_values == {"a.k": 4.0, "b.k": 4.0, "a.b": 1.5}


def test_an_input_bound_by_the_ssp_starts_every_episode_at_that_value(gain, tmp_path):
    # LinearTransformation3: the component input g.u is bound to 14 and driven by the agent
    top = system("top", [component("g", "gain", bindings({"k": 13.0}))], parameters=bindings({"g.u": 14.0}))
    folder = write_ssp_folder(tmp_path / "bound", top, {"gain": gain})
    env = FMUEnv(fmu=folder, inputs=["g.u"], outputs=["g.y"], time_step=0.1)
    assert env.description.input_variable("g.u").start == 14.0
    for seed in (0, 1):
        observation, _ = env.reset(seed=seed)
        assert observation[0] == 13.0 * 14.0
        assert env.fmu.inputs.views["g.u"] == 14.0
        env.step(np.array([1.0]))
    env.close()


@pytest.mark.parametrize("step_path, taken", [("auto", "native"), ("python", "python")])
def test_a_bound_input_connector_starts_at_its_value_and_feeds_its_targets(gain, tmp_path, step_path, taken):
    top = system("top", [component("a", "gain"), component("b", "gain")],
                 [connect(".u", "a.u"), connect(".u", "b.u", factor=-1.0, offset=0.5),
                  connect("b.y", ".y", factor=2.0, offset=-1.0)],
                 connectors(u="input", y="output"), bindings({"u": 2.5}))
    folder = write_ssp_folder(tmp_path / "fan", top, {"gain": gain})
    env = FMUEnv(fmu=folder, inputs=["u"], outputs=["a.y", "b.y", "y"], time_step=0.1, step_path=step_path)
    assert env.step_path == taken and env.description.variables["u"].start == 2.5
    for _ in range(2):  # every episode
        np.testing.assert_array_equal(env.reset(seed=0)[0], [2.5, -2.0, -5.0])
        for action in (1.0, -3.0):
            np.testing.assert_array_equal(env.step(np.array([action]))[0],
                                          [action, 0.5 - action, 2.0 * (0.5 - action) - 1.0])
    env.close()


def test_connections_through_sub_systems_are_checked_as_any_other(gain, tmp_path):
    inner = system("sub", [component("g", "gain")], [connect("g.y", ".y")], connectors(y="output"))
    top = system("top", [inner, component("h", "gain")], [connect("sub.y", "h.y")])
    with pytest.raises(ConfigError, match=r"connection sub\.g\.y -> h\.y: 'h\.y' is not an input"):
        open_system(write_ssp_folder(tmp_path / "wrong", top, {"gain": gain}))


def test_an_integer_output_feeds_an_enumeration_input(family_fmu):
    probe = family_fmu("probe", 2)
    env = FMUEnv(fmus={"counter": str(probe), "follower": str(probe)},
                 connections=["counter.steps -> follower.mode", "follower.mode_out -> counter.gear"],
                 inputs=["counter.boost"], outputs=["follower.mode_out", "counter.steps"], time_step=0.1)
    env.reset(seed=0)
    for k in (1, 2, 3):  # Gauss-Seidel: the counter steps first, the follower takes its new count
        observation = env.step(0)[0]
        assert (observation["follower.mode_out"], observation["counter.steps"]) == (k, k)
    env.close()
    with pytest.raises(ConfigError, match="type mismatch: a Real output into a Integer input"):
        open_system(fmus={"a": str(family_fmu("gain", 2)), "b": str(probe)}, connections=["a.y -> b.gear"])


#: defects of the kinds OMSimulator's invalidSSD, invalidSSV and invalidSSM hold, each in a runnable
#: system: the file, where, and the message
DEFECTS = {
    "a mapping entry without a target": (
        "resources/k.ssm", '<ssm:MappingEntry source="k_all"/>',
        r"resources/k\.ssm, line 1: MappingEntry: has no 'target'"),
    "a parameter without a value": (
        "resources/k.ssv", '<ssv:Parameter name="a.b"/>',
        r"resources/k\.ssv, line 1: Parameter 'a\.b': has no Real, Integer, Boolean or String value"),
    "a Real that is no number": (
        "resources/k.ssv", '<ssv:Parameter name="a.b"><ssv:Real value="fast"/></ssv:Parameter>',
        r"resources/k\.ssv, line 1: Parameter 'a\.b': 'fast' is not a Real"),
    "a connection to an unknown element": (
        "SystemStructure.ssd", '<ssd:Connection startElement="aa" startConnector="y" endElement="b" endConnector="u"/>',
        (r"SystemStructure\.ssd, line \d+: Connection: startElement 'aa' is no element of the system\. "
         r"Did you mean 'a'\?")),
    "a connector of an unknown kind": (
        "SystemStructure.ssd", '<ssd:Connector name="w" kind="sideways"><ssc:Real/></ssd:Connector>',
        r"SystemStructure\.ssd, line \d+: Connector 'w': kind 'sideways' is none of input, output"),
    "a mapping of the wrong document": (
        "resources/k.ssm", None, r"resources/k\.ssm: its root element is .*ParameterSet', not ssm:ParameterMapping"),
    # invalidSSM: 'destination' for 'target'
    "a mapping entry with an attribute the standard does not have": (
        "resources/k.ssm", '<ssm:MappingEntry source="k_all" destination="b.k"/>',
        (r"resources/k\.ssm, line 1: MappingEntry: unknown attribute 'destination' \(the standard gives it source, "
         r"target, suppressUnitConversion, id and description\)")),
    # invalidSSD: a connector with a 'type'
    "a connector with an attribute the standard does not have": (
        "SystemStructure.ssd", '<ssd:Connector name="w" type="Real" kind="input"><ssc:Real/></ssd:Connector>',
        r"SystemStructure\.ssd, line \d+: Connector 'w': unknown attribute 'type'"),
    "a parameter set that is not XML": (
        "resources/k.ssv", "<ssv:ParameterSet", r"resources/k\.ssv is not well-formed XML"),
}


@pytest.mark.parametrize("defect", DEFECTS)
def test_a_malformed_file_is_refused_naming_the_file_and_the_element(gain, tmp_path, defect):
    file, bad, message = DEFECTS[defect]
    ssv = parameter_set({"k_all": 4.0, "a.b": 1.5})
    ssm = mapping(("k_all", "a.k"), ("k_all", "b.k"))
    top = system("top", [component("a", "gain"), component("b", "gain")], [connect("a.y", "b.u")],
                 connectors(u="input"), bindings(source="resources/k.ssv", ssm="resources/k.ssm"))
    files = {"resources/k.ssv": ssv, "resources/k.ssm": ssm}
    folder = write_ssp_folder(tmp_path / "good", top, {"gain": gain}, files)
    assert open_system(folder).parameter_values == {"a.k": 4.0, "b.k": 4.0, "a.b": 1.5}  # runnable as written
    if file == "resources/k.ssm":
        files[file] = ssm.replace('<ssm:MappingEntry source="k_all" target="b.k"/>', bad) if bad else ssv
    elif file == "resources/k.ssv" and bad.startswith("<ssv:Parameter "):
        files[file] = ssv.replace('<ssv:Parameter name="a.b"><ssv:Real value="1.5"/></ssv:Parameter>', bad)
    elif file == "resources/k.ssv":
        files[file] = bad
    elif "<ssd:Connection " in bad:
        top = top.replace('<ssd:Connection startElement="a"', bad + '<ssd:Connection startElement="a"')
    else:
        top = top.replace("<ssd:Connectors>", "<ssd:Connectors>" + bad)
    broken = write_ssp_folder(tmp_path / "broken", top, {"gain": gain}, files)
    with pytest.raises(DataError, match=message) as refusal:
        open_system(broken)
    assert str(refusal.value).startswith(f"{broken}: ")


def test_info_offers_the_systems_own_inputs_at_the_ssps_values(gain, tmp_path):
    top = system("top", [component("a", "gain", bindings({"k": 10.0})), component("b", "gain")],
                 [connect(".u", "a.u"), connect("a.y", "b.u"), connect("b.y", ".y")],
                 connectors(u="input", y="output", p="parameter"), bindings({"u": 2.0, "p": 1.0, "b.k": 0.5}))
    folder = write_ssp_folder(tmp_path / "sys", top, {"gain": gain})
    report = describe_fmu(folder)
    assert "read without effect:\n  parameter 'p' (SystemStructure.ssd, line 3) feeds no component" in report
    config = suggest(open_system(folder)).config
    assert config["inputs"] == ["u"]  # not the gains' tunable k and b
    assert config["action_bounds"] == {"u": (1.0, 3.0)}  # around the SSP's 2, not the FMU's start 0
    assert config["parameters"] == {"a.k": 10.0, "a.b": 0.0, "b.k": 0.5, "b.b": 0.0}
    assert config["outputs"] == ["y"]  # the system's own output, not its gains' too
    env = FMUEnv(**config)
    np.testing.assert_array_equal(env.reset(seed=0)[0], [10.0])
    np.testing.assert_array_equal(env.step(np.array([3.0]))[0], [15.0])
    env.close()


def test_connector_values_at_two_levels_reach_their_gains(gain, tmp_path):
    # OMSimulator's NestedSystemSimulation2: the top's input1 = 3 and the sub-system's own input1 = 10,
    # each connected to a gain of its level; its script prints Gain1.u = 3 and sub-system1.Gain1.u = 10
    inner = system("sub-system1", [component("Add1", "gain"), component("Gain1", "gain")],
                   [connect(".input1", "Gain1.u"), connect("Gain1.y", "Add1.u")],
                   connectors(input1="input", param1="parameter"), bindings({"input1": 10.0}))
    top = system("default", [inner, component("Add1", "gain"), component("Gain1", "gain")],
                 [connect(".input1", "Gain1.u"), connect("Gain1.y", "Add1.u")],
                 connectors(input1="input", param1="parameter"), bindings({"input1": 3.0}))
    folder = write_ssp_folder(tmp_path / "NestedSystemSimulation2", top, {"gain": gain})
    names = ["Gain1.u", "Gain1.y", "Add1.u", "sub-system1.Gain1.u", "sub-system1.Gain1.y", "sub-system1.Add1.u"]
    run = simulate(folder, 1.0, outputs=names, time_step=0.1)
    assert [run[name][-1] for name in names] == [3.0, 3.0, 3.0, 10.0, 10.0, 10.0]


def test_a_connector_fed_twice_is_refused(gain, tmp_path):
    inner = system("sub", [component("g", "gain")], [connect(".u", "g.u")], connectors(u="input"))
    top = system("top", [inner, component("a", "gain"), component("b", "gain")],
                 [connect("a.y", "sub.u"), connect("b.y", "sub.u")])
    with pytest.raises(DataError, match=r"SystemStructure\.ssd, line \d+: the connector 'sub\.u' is already fed by "
                                        r"'a\.y' \(SystemStructure\.ssd, line \d+\): a connector has one source"):
        open_system(write_ssp_folder(tmp_path / "twice", top, {"gain": gain}))


def test_a_parameter_set_missing_from_the_archive_is_named_with_its_binding(gain, tmp_path):
    # invalidSSV: the system binds resources/System1.ssv, which the SSP does not hold
    top = system("top", [component("a", "gain")], parameters=bindings(source="resources/System1.ssv"))
    with pytest.raises(FileNotFoundError, match=r"SystemStructure\.ssd, line \d+: ParameterBinding: its source "
                                                r"'resources/System1\.ssv' is not in the SSP"):
        open_system(write_ssp_folder(tmp_path / "missing", top, {"gain": gain}))


def test_an_input_connector_can_be_held_as_a_fixed_input(gain, tmp_path):
    top = system("top", [component("a", "gain"), component("b", "gain")],
                 [connect(".u", "a.u", factor=2.0), connect(".v", "b.u")], connectors(u="input", v="input"))
    folder = write_ssp_folder(tmp_path / "held", top, {"gain": gain})
    env = FMUEnv(fmu=folder, inputs=["v"], outputs=["a.y", "b.y"], fixed_inputs={"u": 1.5}, time_step=0.1)
    np.testing.assert_array_equal(env.reset(seed=0)[0], [3.0, 0.0])
    np.testing.assert_array_equal(env.step(np.array([4.0]))[0], [3.0, 4.0])
    env.close()


def test_connections_written_end_to_start_flow_as_the_connectors_kinds_say(gain, tmp_path):
    # OMSimulator's acvs_compositeModel: inside the sub-system 'valve', 'valve_model.pA -> .p1' and
    # 'valve_model.pB -> .p1' into its input connector p1, and outside 'valve.p1 -> fuel.valve_p1'
    # from an output: p1 takes fuel's output to both inputs, it is not fed twice
    valve = system("valve", [component("a", "gain"), component("b", "gain")],
                   [connect("a.u", ".p1"), connect("b.u", ".p1", factor=2.0), connect(".q", "a.y")],
                   connectors(p1="input", q="output"))
    top = system("top", [valve, component("fuel", "gain")],
                 [connect("valve.p1", "fuel.y"), connect("fuel.u", ".u"), connect(".y", "valve.q")],
                 connectors(u="input", y="output"), bindings({"fuel.k": 3.0, "valve.a.k": 5.0}))
    folder = write_ssp_folder(tmp_path / "reversed", top, {"gain": gain})
    described = open_system(folder)
    assert sorted(link.label for link in described.links) == ["fuel.y -> valve.a.u", "fuel.y -> valve.b.u"]
    env = FMUEnv(fmu=folder, inputs=["u"], outputs=["valve.a.u", "valve.b.u", "y"], time_step=0.1)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.step(np.array([2.0]))[0], [6.0, 12.0, 30.0])
    env.close()


def test_a_mapping_templates_rows_without_a_source_map_nothing(gain, tmp_path):
    # OMSimulator's embrace: ECS_HW.ssm lists every parameter as '<MappingEntry source="" target="...">'
    # beside the set's own names, which bind as they are
    top = system("top", [component("a", "gain"), component("b", "gain")],
                 parameters=bindings(source="resources/k.ssv", ssm="resources/k.ssm"))
    folder = write_ssp_folder(tmp_path / "template", top, {"gain": gain}, {
        "resources/k.ssv": parameter_set({"a.k": 4.0, "k_b": 1.5}),
        "resources/k.ssm": mapping(("", "a.k"), ("", "b.b"), ("k_b", "b.k"))})
    assert open_system(folder).parameter_values == {"a.k": 4.0, "b.k": 1.5}


def test_a_value_through_a_parameter_connectors_connection_wins_over_the_variables_own_binding(gain, tmp_path):
    # OMSimulator's import_export_parameters1: one set binds k_cref = 30 (connected to addP.k1) and,
    # later, addP.k1 = 10; its script prints addP.k1 = 30 after initialization. So also when the
    # variable's own binding is at a higher level than the connector's
    inner = system("sub", [component("g", "gain")], [connect(".p", "g.k")], connectors(p="parameter"),
                   bindings({"p": 3.0}))
    top = system("top", [inner, component("a", "gain")], [connect(".k_cref", "a.k")],
                 connectors(k_cref="parameter"), bindings({"k_cref": 30.0, "a.k": 10.0, "sub.g.k": 7.0}))
    described = open_system(write_ssp_folder(tmp_path / "wins", top, {"gain": gain}))
    assert described.parameter_values == {"a.k": 30.0, "sub.g.k": 3.0}


def test_the_ssps_default_experiment_gives_the_systems_start_and_stop_time(gain, tmp_path):
    # OMSimulator's import_export_parameters: stopTime="4.0" in the SSD, the FMUs' own 1.0
    top = system("top", [component("g", "gain")])
    folder = write_ssp_folder(tmp_path / "experiment", top, {"gain": gain})
    ssd = folder / "SystemStructure.ssd"
    ssd.write_text(ssd.read_text().replace(
        "</ssd:SystemStructureDescription>",
        '<ssd:DefaultExperiment startTime="0.5" stopTime="2.5"/></ssd:SystemStructureDescription>'))
    experiment = open_system(folder).default_experiment
    assert (experiment.start_time, experiment.stop_time) == (0.5, 2.5)
    run = simulate(folder, outputs=["g.y"], time_step=0.5)
    assert list(run["time"]) == [0.5, 1.0, 1.5, 2.0, 2.5]


def test_a_connection_between_components_written_end_to_start_flows_from_the_output(gain, tmp_path):
    # OMSimulator's acvs_compositeModel: 'valve_model.pLmax -> interface_model.pLmax.in.y', an input to an output
    top = system("top", [component("a", "gain"), component("b", "gain")], [connect("b.u", "a.y", factor=2.0)],
                 parameters=bindings({"a.k": 1.5, "a.u": 4.0}))
    described = open_system(write_ssp_folder(tmp_path / "reversed", top, {"gain": gain}))
    (link,) = described.links
    assert link.label == "a.y -> b.u" and link.conversion.scale == 2.0
    run = simulate(write_ssp_folder(tmp_path / "run", top, {"gain": gain}), 0.1, outputs=["b.u"], time_step=0.1)
    assert run["b.u"][-1] == 2.0 * 1.5 * 4.0
    # a config's connection is read as written
    with pytest.raises(ConfigError, match=r"connection b\.u -> a\.y: 'b\.u' is not an output"):
        open_system(fmus={"a": str(gain), "b": str(gain)}, connections=["b.u -> a.y"])


def test_a_parameter_set_written_for_more_than_the_system_sets_what_is_in_it(gain, tmp_path, caplog):
    # OMSimulator's embrace: a product database's set of 165 parameters, two mapped onto the system
    top = system("top", [component("a", "gain")], parameters=bindings(source="resources/k.ssv", ssm="resources/k.ssm"))
    folder = write_ssp_folder(tmp_path / "database", top, {"gain": gain}, {
        "resources/k.ssv": parameter_set({"product.pipe.length": 2.5, "product.pipe.radius": 0.1, "a.b": 1.0,
                                          "product": 3.0}),
        "resources/k.ssm": mapping(("product.pipe.length", "a.k"))})
    with caplog.at_level(logging.WARNING, logger="modelicagym.system.ssp"):
        described = open_system(folder)
    assert described.parameter_values == {"a.k": 2.5, "a.b": 1.0}
    assert described.notes == [("2 parameters of resources/k.ssv name no component or connector of the system "
                                "('product.pipe.radius', 'product'): they have no effect")]
    assert "'product.pipe.radius'" in caplog.text


def test_a_parameter_value_in_a_unit_defined_nowhere_is_taken_in_the_variables_unit(family_fmu, tmp_path, caplog):
    # OMSimulator's embrace: unit="[m]" for a variable in m, with no ssv:Units to say what [m] is
    consumer = family_fmu("consumer", 2)
    top = system("top", [component("c", "consumer")], parameters=bindings(source="resources/k.ssv"))
    ssv = parameter_set({"c.Q_gain": 250.0}).replace('<ssv:Real value="250.0"/>',
                                                      '<ssv:Real value="250.0" unit="[W]"/>')
    with caplog.at_level(logging.WARNING, logger="modelicagym.system.description"):
        described = open_system(write_ssp_folder(tmp_path / "unit", top, {"consumer": consumer},
                                                 {"resources/k.ssv": ssv}))
    assert described.parameter_values == {"c.Q_gain": 250.0}
    assert described.notes == [("parameter 'c.Q_gain': its value's unit '[W]' is defined nowhere (not in its "
                                "parameter set, not in the FMU): the unit is ignored, the value taken in the "
                                "variable's unit 'W'")]
    assert "defined nowhere" in caplog.text


def test_the_reader_gives_every_system_connectors_value_the_higher_binding_winning(tmp_path):
    # OMSimulator's import_hierarchical_ssv_sources and importParameterMapping: systems of connectors alone,
    # whose scripts print each connector's value
    inner = system("S1", [], [], connectors(q="parameter", r="parameter", free="parameter"),
                   bindings({"q": 3.0, "r": 1.0}))
    top = system("top", [inner], [connect(".p", "S1.q", factor=2.0)], connectors(p="parameter"),
                 bindings({"p": 5.0, "S1.r": 7.0}))
    spec = read_ssp(write_ssp_folder(tmp_path / "connectors", top, {}))
    assert spec.connector_values == {"p": 5.0, "S1.q": 10.0, "S1.r": 7.0}


def test_a_value_bound_to_a_connected_input_gives_way_to_the_connection(gain, tmp_path, caplog):
    # OMSimulator's replaceSubmodel4: root.ssv binds B.u1, which A.dummy feeds (tools export every input's start)
    top = system("top", [component("a", "gain"), component("b", "gain")], [connect("a.y", "b.u")],
                 parameters=bindings({"b.u": 3.0, "a.u": 2.0, "a.k": 1.5}))
    folder = write_ssp_folder(tmp_path / "fed", top, {"gain": gain})
    with caplog.at_level(logging.WARNING, logger="modelicagym.system.description"):
        described = open_system(folder)
    assert described.parameter_values == {"a.u": 2.0, "a.k": 1.5}
    assert described.notes == [("parameter 'b.u': the connection a.y -> b.u feeds it: the value the SSP binds "
                                "to it has no effect")]
    assert "the connection a.y -> b.u feeds it" in caplog.text
    assert simulate(folder, 0.1, outputs=["b.u"], time_step=0.1)["b.u"][-1] == 3.0  # 1.5 * 2, not the bound 3
