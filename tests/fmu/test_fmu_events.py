"""Events through the runtime, on the bouncing ball: model exchange (CVode root finding, time
events) against co-simulation and against the analytic solution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmu_family import BALL_OUTPUTS

from modelicagym.fmu import FMUInstance
from modelicagym.fmu.instance import RUNGS

DT = 0.05
N_STEPS = 40  # 2 s: three bounces (the third after the time event at 1.5 s), no Zeno yet
PARAMETERS = {"g": 9.81, "e": 0.8, "e_late": 0.5, "t_switch": 1.5, "h_0": 1.0}


V_MIN = 0.1  # the model's rest threshold for the rebound speed


def analytic(g: float, e: float, e_late: float, t_switch: float, h_0: float, t_end: float = 2.0):
    """Bounce times and a function ``t -> (h, v)`` of the exact solution."""
    flights = [(0.0, h_0, 0.0)]  # (start time, height, velocity) of each flight
    resting_from = math.inf
    while True:
        t, h, v = flights[-1]
        t_hit = t + (v + math.sqrt(v * v + 2 * g * h)) / g
        if t_hit > t_end:
            break
        v_hit = v - g * (t_hit - t)
        rebound = -(e_late if t_hit >= t_switch else e) * v_hit
        flights.append((t_hit, 0.0, rebound))
        if rebound < V_MIN:
            resting_from = t_hit
            break

    def state(time: float) -> tuple[float, float]:
        if time >= resting_from:
            return 0.0, 0.0
        t, h, v = [f for f in flights if f[0] <= time][-1]
        s = time - t
        return h + v * s - 0.5 * g * s * s, v - g * s

    return [f[0] for f in flights[1:]], state


def simulate(path, mode: str, parameters=None, rung: str = "auto", episodes: int = 1):
    """Per episode: outputs at every communication point and the bounce times seen."""
    results = []
    with FMUInstance(path, mode=mode, outputs=BALL_OUTPUTS, reset_rung=rung) as fmu:
        for _ in range(episodes):
            fmu.reset(parameters or {})
            rows, bounces = [], []
            for _ in range(N_STEPS):
                fmu.step(DT)
                row = {name: float(view) for name, view in fmu.outputs.views.items()}
                if row["bounces"] > len(bounces):
                    assert row["bounces"] == len(bounces) + 1, "two bounces in one step"
                    bounces.append(row["t_bounce"])
                rows.append(row)
            results.append((rows, bounces, fmu.time))
    return results


@pytest.mark.parametrize("parameters", [{}, {"e": 0.9, "e_late": 0.6, "t_switch": 0.8, "h_0": 1.3}], ids=["default", "other"])
def test_model_exchange_locates_state_and_time_events(family_fmu, fmi_version, parameters):
    exact_bounces, exact = analytic(**{**PARAMETERS, **parameters})
    [(rows, bounces, time)] = simulate(family_fmu("ball", fmi_version), "me", parameters)
    assert time == pytest.approx(2.0)
    assert len(bounces) == len(exact_bounces) >= 2
    np.testing.assert_allclose(bounces, exact_bounces, rtol=0, atol=1e-6)
    t_switch = {**PARAMETERS, **parameters}["t_switch"]
    assert rows[-1]["t_switched"] == t_switch  # the solver stopped exactly at the time event
    assert rows[-1]["e_now"] == {**PARAMETERS, **parameters}["e_late"]
    for k, row in enumerate(rows, 1):
        h, v = exact(k * DT)
        assert row["h"] == pytest.approx(h, abs=1e-6), f"t={k * DT}"
        assert row["v"] == pytest.approx(v, abs=1e-6), f"t={k * DT}"
        assert (row["t_switched"] == t_switch) == (k * DT >= t_switch)


def test_co_simulation_agrees_with_model_exchange_and_the_analytic_solution(family_fmu, fmi_version):
    exact_bounces, exact = analytic(**PARAMETERS)
    [(me, me_bounces, _)] = simulate(family_fmu("ball", fmi_version), "me")
    [(cs, cs_bounces, _)] = simulate(family_fmu("ball", fmi_version), "cs")
    np.testing.assert_allclose(cs_bounces, exact_bounces, rtol=0, atol=1e-6)
    np.testing.assert_allclose(cs_bounces, me_bounces, rtol=0, atol=1e-6)
    for name in BALL_OUTPUTS:
        np.testing.assert_allclose([r[name] for r in cs], [r[name] for r in me], rtol=0, atol=1e-6, err_msg=name)
    h, v = exact(2.0)
    assert cs[-1]["h"] == pytest.approx(h, abs=1e-6) and cs[-1]["v"] == pytest.approx(v, abs=1e-6)


@pytest.mark.parametrize("rung", RUNGS)
@pytest.mark.parametrize("t_switch", [0.2, 1.5])
def test_every_episode_sees_the_time_event(family_fmu, fmi_version, rung, t_switch):
    """The time event of each episode is armed again on reset (model exchange keeps the next event
    time outside the FMU, so a restored snapshot must bring it back too). With t_switch = 0.2 the
    time event comes before any state event could re-arm it."""
    episodes = simulate(family_fmu("ball", fmi_version), "me", {"t_switch": t_switch}, rung=rung, episodes=3)
    first = episodes[0][0]
    assert first[-1]["t_switched"] == t_switch
    for rows, _, _ in episodes[1:]:
        assert rows[-1]["t_switched"] == t_switch
        assert rows == first


@pytest.mark.parametrize("offset", [5e-10, -5e-10, 0.0])
@pytest.mark.parametrize("fmi_version", [2, 3])
def test_a_time_event_within_rounding_of_a_communication_point_happens_at_its_time(family_fmu, fmi_version, offset):
    """The internal RK4 steps to a time event a hair after (or before) a communication point and
    handles it there, instead of asking the model too early (which then failed the step)."""
    t_switch = 0.1 + offset
    with FMUInstance(family_fmu("ball", fmi_version), mode="cs", outputs=["t_switched", "e_now"]) as fmu:
        fmu.reset({**PARAMETERS, "t_switch": t_switch})
        for _ in range(4):
            fmu.step(DT)
        assert fmu.outputs.views["t_switched"] == t_switch
        assert fmu.outputs.views["e_now"] == PARAMETERS["e_late"]
