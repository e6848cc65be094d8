"""Loops of direct feedthrough (modelicagym/system/loops.py) run with a one-step delay, as
co-simulation engines run them: every connection under Jacobi, the connection the stepping order (or
``loop_breaks``) picks under Gauss-Seidel. Each system here is built from our own C FMUs
(tests/fmus/gain, pcontrol, feedplant) and held to the delayed-value recurrence written out by hand
below, on the native and the Python step path, which agree bit for bit; a loop whose gain exceeds
one stops with a `LoopDivergedError` naming it, on both paths, never a NaN."""

from __future__ import annotations

import re
import shlex
import zipfile
from pathlib import Path

import numpy as np
import pytest
from extras import requires
from fmu_family import rewrite

from modelicagym import FMUEnv, cli
from modelicagym.errors import ConfigError, LoopDivergedError
from modelicagym.system import open_system
from modelicagym.system.loops import LOOP_BOUND

H = 0.01
ACTIONS = [1.0, 1.0, 0.5, -0.25, 2.0, 0.0, 1.5, 1.5, -1.0, 0.75] * 3
PATHS = ["auto", "python"]


@pytest.fixture
def fmus(family_fmu):
    return {"gain2": str(family_fmu("gain", 2)), "gain3": str(family_fmu("gain", 3)),
            "pcontrol": str(family_fmu("pcontrol", 2)), "feedplant": str(family_fmu("feedplant", 3))}


def run(config: dict, actions: list[float]) -> np.ndarray:
    """The observations after the reset and after each action, on ``config``'s step path (checked)."""
    with FMUEnv(config) as env:
        assert env.step_path == ("python" if config.get("step_path") == "python" else "native"), env.step_path_reason
        rows = [env.reset(seed=0)[0]]
        rows += [env.step(np.array([a]))[0] for a in actions]
    return np.array(rows)


def both_paths(config: dict, actions: list[float] = ACTIONS) -> np.ndarray:
    """The run on the native path, after checking that the Python path gives the same bits."""
    native, python = run(config, actions), run({**config, "step_path": "python"}, actions)
    np.testing.assert_array_equal(native, python)
    return native


def assert_recurrence(actual: np.ndarray, expected: list[list[float]]) -> None:
    # the FMUs compute the same formulas in C (a compiler may fuse a multiply-add; RK4 over 1 ms
    # substeps sums h u in pieces): equal up to rounding
    np.testing.assert_allclose(actual, np.array(expected), rtol=1e-12, atol=1e-14)


# -- a controller and a plant: y = k (r - u) into der(x) = u, y = x + d u, fed back -------------

K, D, X0 = 2.0, 0.5, 0.2


def controller_plant(fmus: dict, **options) -> dict:
    return {"fmus": {"ctrl": fmus["pcontrol"], "plant": fmus["feedplant"]},
            "connections": ["ctrl.y -> plant.u", "plant.y -> ctrl.u"], "inputs": ["ctrl.r"],
            "outputs": ["ctrl.y", "plant.y", "plant.x"], "parameters": {"ctrl.k": K, "plant.x_0": X0},
            "time_step": H, **options}


def controller_plant_by_hand(master: str, plant_first: bool = False, substeps: int = 1) -> list[list[float]]:
    """Reset: each component in stepping order takes the other's output as it stands, r at its
    start value 0. A communication step: Jacobi feeds both the values at t; Gauss-Seidel feeds the
    component stepping second its partner's new value, the first one its partner's value at t.
    An env step is ``substeps`` communication steps of H / substeps."""
    if plant_first:  # the plant's input is read from the previous step: the controller's output at its start, 0
        u, y_plant = 0.0, X0
        y_ctrl = K * (0.0 - y_plant)
    else:
        y_ctrl = K * (0.0 - X0)
        u, y_plant = y_ctrl, X0 + D * y_ctrl
    x = X0
    rows = [[y_ctrl, y_plant, x]]
    h = H / substeps
    for r in ACTIONS:
        for _ in range(substeps):
            if master == "jacobi":
                u = y_ctrl
                y_ctrl = K * (r - y_plant)
                x = x + h * u
                y_plant = x + D * u
            elif plant_first:
                u = y_ctrl
                x = x + h * u
                y_plant = x + D * u
                y_ctrl = K * (r - y_plant)
            else:
                y_ctrl = K * (r - y_plant)
                u = y_ctrl
                x = x + h * u
                y_plant = x + D * u
        rows.append([y_ctrl, y_plant, x])
    return rows


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_a_controller_and_a_plant_close_a_loop_with_a_one_step_delay(fmus, master):
    actual = both_paths(controller_plant(fmus, master=master))
    assert_recurrence(actual, controller_plant_by_hand(master))


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_substeps_delay_a_loop_by_one_communication_step(fmus, master):
    actual = both_paths(controller_plant(fmus, master=master, substeps=2))
    assert_recurrence(actual, controller_plant_by_hand(master, substeps=2))


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_a_loop_of_model_exchange_components_runs_alike(fmus, master):
    # each FMU in model exchange, its solver over the step (the native integrator, or Python's)
    config = controller_plant(fmus, master=master)
    config["fmus"] = {name: {"fmu": path, "mode": "me"} for name, path in config["fmus"].items()}
    np.testing.assert_allclose(both_paths(config), np.array(controller_plant_by_hand(master)), rtol=1e-9, atol=1e-12)


def test_gauss_seidel_breaks_the_loop_where_loop_breaks_says(fmus):
    config = controller_plant(fmus, loop_breaks=["ctrl.y -> plant.u"])
    with FMUEnv(config) as env:
        assert env.description.order == ["plant", "ctrl"]
        assert env.metadata["loops"] == [("loop ctrl.y -> plant.u, plant.y -> ctrl.u: gauss-seidel reads "
                                         "ctrl.y -> plant.u from the previous step (named in loop_breaks)")]
    assert_recurrence(both_paths(config), controller_plant_by_hand("gauss-seidel", plant_first=True))


@pytest.mark.parametrize("master, line", [
    ("gauss-seidel", "gauss-seidel reads plant.y -> ctrl.u from the previous step (ctrl steps first in the loop)"),
    ("jacobi", "jacobi reads every connection of it from the previous step"),
])
def test_the_env_says_where_each_loop_is_delayed(fmus, master, line):
    with FMUEnv(controller_plant(fmus, master=master)) as env:
        assert env.metadata["loops"] == [f"loop ctrl.y -> plant.u, plant.y -> ctrl.u: {line}"]


# -- a power bond: a source's effort v = E - R i one way, a load's flow i = v / R_L the other -------

R, R_LOAD = 0.5, 2.0


def power_bond(fmus: dict, **options) -> dict:
    return {"fmus": {"source": fmus["gain2"], "load": fmus["gain3"]},
            "connections": [("source.y", "load.u"), ("load.y", "source.u")], "inputs": ["source.b"],
            "outputs": ["source.y", "load.y"], "parameters": {"source.k": -R, "load.k": 1.0 / R_LOAD},
            "time_step": H, **options}


def power_bond_by_hand(master: str) -> list[list[float]]:
    """The source (declared first) settles on the load's start output 0 with E at its start 0."""
    v = 0.0 + -R * 0.0
    i = 1.0 / R_LOAD * v + 0.0
    rows = [[v, i]]
    for e in ACTIONS:
        v_new = -R * i + e
        i = 1.0 / R_LOAD * (v if master == "jacobi" else v_new) + 0.0
        v = v_new
        rows.append([v, i])
    return rows


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_a_power_bond_runs_under_both_masters(fmus, master):
    assert_recurrence(both_paths(power_bond(fmus, master=master)), power_bond_by_hand(master))


# -- a ring of three gains -----------------------------------------------------------------------

KA, KB, KC, BB, BC = 0.5, -0.8, 1.5, 0.25, -0.1


def ring(fmus: dict, **options) -> dict:
    return {"fmus": {"a": fmus["gain2"], "b": fmus["gain3"], "c": fmus["gain2"]},
            "connections": ["a.y -> b.u", "b.y -> c.u", "c.y -> a.u"], "inputs": ["a.b"],
            "outputs": ["a.y", "b.y", "c.y"], "parameters": {"a.k": KA, "b.k": KB, "c.k": KC, "b.b": BB, "c.b": BC},
            "time_step": H, **options}


def ring_by_hand(master: str, break_into_b: bool = False) -> list[list[float]]:
    """Reset in stepping order (a, b, c; or b, c, a when a.y -> b.u is the break), each gain on its
    predecessor's output as it stands (a's offset, the action, at its start 0)."""
    a = b = c = 0.0
    if break_into_b:
        b = KB * a + BB
        c = KC * b + BC
        a = KA * c + 0.0
    else:
        a = KA * (KC * 0.0 + BC) + 0.0
        b = KB * a + BB
        c = KC * b + BC
    rows = [[a, b, c]]
    for e in ACTIONS:
        if master == "jacobi":
            a, b, c = KA * c + e, KB * a + BB, KC * b + BC
        elif break_into_b:
            b = KB * a + BB
            c = KC * b + BC
            a = KA * c + e
        else:
            a = KA * c + e
            b = KB * a + BB
            c = KC * b + BC
        rows.append([a, b, c])
    return rows


@pytest.mark.parametrize("master, breaks", [("jacobi", []), ("gauss-seidel", []),
                                            ("gauss-seidel", ["a.y -> b.u"])])
def test_a_ring_of_three_runs_with_one_delayed_connection(fmus, master, breaks):
    config = ring(fmus, master=master, loop_breaks=breaks)
    with FMUEnv(config) as env:
        (line,) = env.metadata["loops"]
    delayed = {"jacobi": "every connection of it", "gauss-seidel": "a.y -> b.u" if breaks else "c.y -> a.u"}[master]
    assert line.startswith(f"loop a.y -> b.u, b.y -> c.u, c.y -> a.u: {master} reads {delayed} from the previous")
    assert_recurrence(both_paths(config), ring_by_hand(master, break_into_b=bool(breaks)))


# -- a loop whose gain exceeds one --------------------------------------------------------------

def diverging(fmus: dict, **options) -> dict:
    return {"fmus": {"a": fmus["gain2"], "b": fmus["gain3"]}, "connections": ["a.y -> b.u", "b.y -> a.u"],
            "inputs": ["a.b"], "outputs": ["a.y", "b.y"], "parameters": {"a.k": 10.0, "b.k": -10.0},
            "time_step": H, **options}


def first_divergence(master: str) -> tuple[float, str, float]:
    """When, along which connection and with what value the loop first leaves +-LOOP_BOUND, for a
    constant action 1: under Jacobi both connections carry the delay (checked in the order they are
    declared), under Gauss-Seidel b.y -> a.u alone (a steps first)."""
    a = b = 0.0
    for n in range(1, 10_000):
        a, b = (10.0 * b + 1.0, -10.0 * a) if master == "jacobi" else (10.0 * b + 1.0, -10.0 * (10.0 * b + 1.0))
        checked = [("a.y -> b.u", a), ("b.y -> a.u", b)] if master == "jacobi" else [("b.y -> a.u", b)]
        for label, value in checked:
            if abs(value) > LOOP_BOUND:
                return n * H, label, value
    raise AssertionError("no divergence")


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
@pytest.mark.parametrize("step_path", PATHS)
def test_a_loop_with_gain_above_one_stops_with_an_error_naming_it(fmus, master, step_path):
    time, label, value = first_divergence(master)
    with FMUEnv(diverging(fmus, master=master, step_path=step_path)) as env:
        env.reset(seed=0)
        with pytest.raises(LoopDivergedError) as caught:
            for _ in range(1000):
                observation = env.step(np.array([1.0]))[0]
                assert np.isfinite(observation).all()
        assert env.fmu.time == pytest.approx(time - H)  # the step that diverged did not count
    message = str(caught.value)
    assert message.startswith(f"system(a, b): the loop a.y -> b.u, b.y -> a.u diverged under {master}: {label} "
                              f"carried {value:g} from the previous step at t = {time:g}, beyond 1e+100.")
    assert ("loop_breaks" if master == "gauss-seidel" else "master='gauss-seidel'") in message
    assert "time step" in message and isinstance(caught.value, ArithmeticError)


@pytest.mark.parametrize("step_path", PATHS)
def test_a_loop_value_that_overflows_is_caught_as_not_finite(fmus, step_path):
    # b's offset 1e300 times a's gain 1e10 overflows at the first step: inf, never passed on silently
    config = diverging(fmus, step_path=step_path, parameters={"a.k": 1e10, "b.k": 0.5, "b.b": 1e300})
    with FMUEnv(config) as env:
        env.reset(seed=0)
        with pytest.raises(LoopDivergedError, match=re.escape("b.y -> a.u carried inf from the previous step at "
                                                              "t = 0.01, not finite.")):
            env.step(np.array([0.0]))


# -- what is declared, what is assumed, and what is refused ---------------------------------------

def test_an_output_declaring_no_dependencies_is_said_to_close_the_loop(fmus, tmp_path):
    bare = rewrite(Path(fmus["gain2"]), tmp_path / "bare.fmu",
                   edit_description=lambda text: text.replace(' dependencies="1"', ""))
    system = open_system(fmus={"a": str(bare), "b": fmus["gain3"]}, connections=["a.y -> b.u", "b.y -> a.u"])
    assert system.loop_lines("gauss-seidel") == [
        ("loop a.y -> b.u, b.y -> a.u: gauss-seidel reads b.y -> a.u from the previous step (a steps first in the "
        "loop); a.y declares no dependencies, so FMI takes it to depend on every input, which closes this loop")]


def test_a_state_output_opens_the_loop(fmus):
    # the plant's x depends on no input (ModelStructure says so): a cycle through it is no loop of feedthrough
    system = open_system(fmus={"ctrl": fmus["pcontrol"], "plant": fmus["feedplant"]},
                         connections=["ctrl.y -> plant.u", "plant.x -> ctrl.u"])
    assert system.loops == []


@pytest.mark.parametrize("breaks, message", [
    (["ctrl.y -> plant.v"], ("loop_breaks: 'ctrl.y -> plant.v' is not a connection of the system. Did you mean "
                            "'ctrl.y -> plant.u'?")),
    (["ctrl.y"], "loop_breaks: 'ctrl.y' is not a connection 'component.output -> component.input'"),
    ("ctrl.y -> plant.u", "loop_breaks is a list of connections"),
])
def test_a_wrong_loop_break_is_refused_naming_it(fmus, breaks, message):
    with pytest.raises(ConfigError, match="^" + re.escape(f"system(ctrl, plant): {message}")):
        FMUEnv(controller_plant(fmus, loop_breaks=breaks))


def test_a_break_on_no_loop_and_a_break_under_jacobi_are_refused(fmus):
    with pytest.raises(ConfigError, match="ctrl.y -> plant.u is on no loop"):
        FMUEnv(controller_plant(fmus, connections=["ctrl.y -> plant.u"], loop_breaks=["ctrl.y -> plant.u"]))
    with pytest.raises(ConfigError, match="jacobi reads every connection from the previous step"):
        FMUEnv(controller_plant(fmus, master="jacobi", loop_breaks=["ctrl.y -> plant.u"]))


# -- info and try say where each loop is broken --------------------------------------------------

SSD = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription version="1.0" name="loop"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription">
  <ssd:System name="loop">
    <ssd:Elements>
      <ssd:Component name="ctrl" source="resources/ctrl.fmu"/>
      <ssd:Component name="plant" source="resources/plant.fmu"/>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="ctrl" startConnector="y" endElement="plant" endConnector="u"/>
      <ssd:Connection startElement="plant" startConnector="y" endElement="ctrl" endConnector="u"/>
    </ssd:Connections>
  </ssd:System>
</ssd:SystemStructureDescription>
"""


@pytest.fixture
def ssp(fmus, tmp_path):
    path = tmp_path / "loop.ssp"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("SystemStructure.ssd", SSD)
        archive.write(fmus["pcontrol"], "resources/ctrl.fmu")
        archive.write(fmus["feedplant"], "resources/plant.fmu")
    return path


def test_an_ssp_systems_loop_breaks_where_the_config_says(fmus, ssp):
    config = {key: value for key, value in controller_plant(fmus).items() if key not in ("fmus", "connections")}
    config.update(fmu=str(ssp), loop_breaks=["ctrl.y -> plant.u"])
    with FMUEnv(config) as env:
        assert env.metadata["loops"] == [("loop ctrl.y -> plant.u, plant.y -> ctrl.u: gauss-seidel reads "
                                         "ctrl.y -> plant.u from the previous step (named in loop_breaks)")]
    assert_recurrence(both_paths(config), controller_plant_by_hand("gauss-seidel", plant_first=True))


def test_info_says_where_each_loop_is_broken(ssp, capsys):
    assert cli.main(["info", str(ssp)]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = lines.index("stepping order (Gauss-Seidel): ctrl, plant")
    assert lines[at + 1:at + 3] == [
        ("loops of direct feedthrough (each read with a one-step delay; 'master': 'jacobi' reads every connection "
        "of a loop from the previous step):"),
        ("  loop ctrl.y -> plant.u, plant.y -> ctrl.u: gauss-seidel reads plant.y -> ctrl.u from the previous step "
        "(ctrl steps first in the loop)")]


@requires("plots")
def test_try_says_where_each_loop_is_broken(fmus, tmp_path):
    from modelicagym.try_fmu import try_fmu

    result = try_fmu(controller_plant(fmus, master="jacobi"), out=tmp_path / "loop.png", steps=5)
    assert "loop ctrl.y -> plant.u, plant.y -> ctrl.u: jacobi reads every connection of it from the previous step" \
        in result.lines()


# -- in a pool -------------------------------------------------------------------------------------

@pytest.mark.processes
@pytest.mark.timeout(120)
@pytest.mark.usefixtures("pool_services")
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
@pytest.mark.parametrize("step_path", PATHS)
def test_a_pool_runs_loops_as_the_recurrence_says(fmus, master, step_path):
    import modelicagym

    n = 3
    with modelicagym.make_vec(controller_plant(fmus, master=master, step_path=step_path), n=n, num_workers=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native" if step_path == "auto" else "python"}
        rows = [pool.reset(seed=0)[0]]
        rows += [pool.step(np.full((n, 1), a))[0] for a in ACTIONS]
    expected = controller_plant_by_hand(master)
    for k in range(n):
        assert_recurrence(np.array([row[k] for row in rows]), expected)


@pytest.mark.processes
@pytest.mark.timeout(120)
@pytest.mark.usefixtures("pool_services")
@pytest.mark.parametrize("step_path", PATHS)
def test_a_pool_stops_on_a_diverged_loop_naming_it(fmus, step_path):
    import modelicagym

    time, label, value = first_divergence("gauss-seidel")
    with modelicagym.make_vec(diverging(fmus, step_path=step_path), n=2, num_workers=2) as pool:
        pool.reset(seed=0)
        with pytest.raises(LoopDivergedError) as caught:  # the pool's EnvError, of the env's error's type too
            for _ in range(1000):
                pool.step(np.ones((2, 1)))
    assert f"{label} carried {value:g} from the previous step at t = {time:g}" in str(caught.value)


# -- docs/systems.md's loop example, as a user follows it --------------------------------------------

ROOT = Path(__file__).resolve().parents[2]


def test_the_docs_loop_example_runs_as_written(tmp_path, monkeypatch, capsys):
    text = (ROOT / "docs" / "systems.md").read_text(encoding="utf-8")
    section = text[text.index("## Loops, delays and the guard"):]
    section = section[:section.index("\n## ")]
    blocks = dict.fromkeys(("bash", "python", "text"), "")
    for language, body in re.findall(r"```(\w+)\n(.*?)```", section, re.DOTALL):
        blocks[language] += body
    monkeypatch.chdir(tmp_path)  # the sample's FMUs land here
    for line in blocks["bash"].splitlines():
        command = shlex.split(line, comments=True)
        assert command[0] == "modelicagym" and cli.main(command[1:]) == 0
    capsys.readouterr()
    exec(compile(blocks["python"], "systems.md", "exec"), {})  # noqa: S102 - the page's example, as written
    assert capsys.readouterr().out == blocks["text"]
