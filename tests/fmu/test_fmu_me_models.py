"""Model exchange (the default integrator, whose solver loop runs in C; `test_native_integrator.py`
holds it against the Python loop) on two family members made for it, each against its analytic
solution and against co-simulation:

``staircase``
    time events announced with ``nextEventTime`` (the solver must stop exactly on them), two
    event-iteration passes at every third stair, and an event that terminates the simulation;
``stiff``
    a linear model with eigenvalues -1e4 and -1, where an explicit solver needs tiny steps and
    CVode (BDF) does not.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmu_family import STAIRCASE_OUTPUTS, STIFF_OUTPUTS

from modelicagym.fmu import FMUInstance

DT = 0.1
N_STEPS = 30  # 3 s: 10 stairs at the default period, 3 of them (the 3rd, 6th, 9th) with two passes
STAIRCASE = {"period": 0.3, "height": 1.0, "k": 2.0}
STAIRCASE_CASES = {
    # stairs on communication points (0.3 * n against 0.1 * k, equal up to rounding)
    "default": ({}, 0.0),
    # stairs inside communication steps (0.25 * n), negative stairs, an input
    "other": ({"period": 0.25, "height": -0.5, "k": 3.0}, 0.5),
}
STIFF = {"lambda": 1e4, "x1_0": 0.0, "x2_0": 0.0}
STIFF_CASES = {
    "default": ({}, 1.0),
    "other": ({"lambda": 1e3, "x1_0": 2.0, "x2_0": -1.0}, -0.5),
}


def simulate(path, mode: str, outputs, parameters, u: float, dt: float, n_steps: int, **options):
    """Outputs after each step (with the instance's time and what ``step`` returned), with the input
    ``u`` held constant; stops after the step that ends the simulation."""
    rows = []
    with FMUInstance(path, mode=mode, inputs=["u"], outputs=outputs, **options) as fmu:
        fmu.reset(parameters)
        fmu.inputs.views["u"][...] = u
        for _ in range(n_steps):
            ended = fmu.step(dt)
            rows.append({"time": fmu.time, "ended": ended, **{n: float(v) for n, v in fmu.outputs.views.items()}})
            if ended:
                assert fmu.terminated
                break
    return rows


def stairs_by(t: float, period: float) -> int:
    """Number of stairs taken by time ``t`` (the stair at t itself included, whatever the rounding)."""
    return math.floor(t / period + 1e-9)


def staircase_exact(t: float, u: float, period: float, height: float, k: float) -> tuple[float, float]:
    """``(level, x)`` at time ``t``: on [i * period, (i + 1) * period) the level is i * height and x
    relaxes from its value at the stair towards (level + u) / k at rate k."""
    n = stairs_by(t, period)
    x = 0.0
    for i in range(n + 1):
        span = min((i + 1) * period, t) - i * period
        rest = (i * height + u) / k
        x = rest + (x - rest) * math.exp(-k * span)
    return n * height, x


def stiff_exact(t: float, u: float, lam: float, x1_0: float, x2_0: float) -> tuple[float, float]:
    """``(x1, x2)`` at time ``t`` for constant ``u``: x1 = u + a e^(-lam t) with a = x1_0 - u, and
    x2 = u + b e^(-t) + c e^(-lam t) with c = a / (1 - lam) (lam != 1) and b = x2_0 - u - c."""
    assert lam != 1.0, "the formula needs lam != 1 (at lam = 1 the e^(-t) term gets a factor t)"
    a = x1_0 - u
    c = a / (1.0 - lam)
    b = x2_0 - u - c
    return u + a * math.exp(-lam * t), u + b * math.exp(-t) + c * math.exp(-lam * t)


def staircase(family_fmu, fmi_version, mode, case="default", **options):
    """The staircase over ``N_STEPS`` steps of ``DT`` for one of `STAIRCASE_CASES`, and its parameters."""
    parameters, u = STAIRCASE_CASES[case]
    path = family_fmu("staircase", fmi_version)
    rows = simulate(path, mode, STAIRCASE_OUTPUTS, parameters, u, DT, N_STEPS, **options)
    return rows, {**STAIRCASE, **parameters}, u


def stiff(family_fmu, fmi_version, mode, case="default"):
    """The stiff model over 1 s in steps of 0.01 for one of `STIFF_CASES`, and its parameters."""
    parameters, u = STIFF_CASES[case]
    rows = simulate(family_fmu("stiff", fmi_version), mode, STIFF_OUTPUTS, parameters, u, 0.01, 100)
    return rows, {**STIFF, **parameters}, u


# -- staircase ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(STAIRCASE_CASES))
def test_model_exchange_stops_exactly_on_the_stairs(family_fmu, fmi_version, case):
    """CVode at the default tolerance: level, stairs and event times exact, x within 1e-6."""
    rows, p, u = staircase(family_fmu, fmi_version, "me", case)
    assert len(rows) == N_STEPS
    for row in rows:
        t = row["time"]
        n = stairs_by(t, p["period"])
        level, x = staircase_exact(t, u, **p)
        assert row["steps_taken"] == n, f"t={t}"
        assert row["level"] == pytest.approx(level, abs=1e-12), f"t={t}"
        # the time the FMU saw at the event is the announced one, n * period, to the last bit
        assert row["t_last_event"] == (n * p["period"] if n else -1.0), f"t={t}"
        assert row["x"] == pytest.approx(x, abs=1e-6), f"t={t}"
        assert not row["ended"] and not row["stopped"]
    assert rows[-1]["steps_taken"] == (10 if case == "default" else 12)


@pytest.mark.parametrize("mode", ["me", "cs"])
def test_every_third_stair_takes_two_event_iteration_passes(family_fmu, fmi_version, mode):
    """``iterations`` counts event-update passes: one after initialization, one per stair, and one
    more per third stair (the first pass only asks for another with newDiscreteStatesNeeded)."""
    rows, p, _ = staircase(family_fmu, fmi_version, mode)
    for row in rows:
        n = stairs_by(row["time"], p["period"])
        assert row["iterations"] == 1 + n + n // 3, f"t={row['time']}"
    assert rows[-1]["iterations"] - rows[-1]["steps_taken"] == 1 + 3  # initialization, 3rd, 6th, 9th stairs


def test_fixed_step_euler_also_stops_on_the_stairs(family_fmu, fmi_version):
    """Forward Euler at a fixed step still takes each stair once, at its time; x is first-order
    accurate. The time is exact only to rounding: the integrator's time is a sum of Euler steps,
    and a sum within 1e-12 of nextEventTime counts as the event (1.2499999999999947 for 1.25)."""
    rows, p, u = staircase(family_fmu, fmi_version, "me", "other", solver="euler", solver_step=1e-3)
    for row in rows:
        t = row["time"]
        n = stairs_by(t, p["period"])
        level, x = staircase_exact(t, u, **p)
        assert (row["steps_taken"], row["level"]) == (n, level), f"t={t}"
        assert row["iterations"] == 1 + n + n // 3, f"t={t}"
        assert row["t_last_event"] == pytest.approx(n * p["period"] if n else -1.0, abs=1e-12), f"t={t}"
        assert row["x"] == pytest.approx(x, abs=1e-3), f"t={t}"


@pytest.mark.parametrize("mode", ["me", "cs"])
@pytest.mark.parametrize("t_stop", [1.0, 0.95], ids=["on_a_step", "inside_a_step"])
def test_the_model_ends_the_episode_at_t_stop(family_fmu, fmi_version, mode, t_stop):
    """The time event at t_stop sets terminateSimulation: ``step`` returns True for the step that
    reaches t_stop (the 10th of 0.1 s) and not before, in every episode. The outputs are those at
    t_stop, where the FMU stopped."""
    with FMUInstance(family_fmu("staircase", fmi_version), mode=mode, outputs=STAIRCASE_OUTPUTS) as fmu:
        for _ in range(2):
            fmu.reset({"t_stop": t_stop})
            ended = [fmu.step(DT) for _ in range(10)]
            assert ended == [False] * 9 + [True]
            assert fmu.terminated
            out = {n: float(v) for n, v in fmu.outputs.views.items()}
            level, x = staircase_exact(t_stop, 0.0, **STAIRCASE)
            assert out["stopped"] == 1.0
            assert out["t_last_event"] == t_stop
            assert (out["steps_taken"], out["level"]) == (3, level)
            assert out["iterations"] == 1 + 3 + 1 + 1  # initialization, 3 stairs, 3rd stair's extra pass, stop
            assert out["x"] == pytest.approx(x, abs=1e-6)


def test_staircase_co_simulation_agrees_with_model_exchange(family_fmu, fmi_version):
    me, p, u = staircase(family_fmu, fmi_version, "me", "other")
    cs, _, _ = staircase(family_fmu, fmi_version, "cs", "other")
    for name in STAIRCASE_OUTPUTS:
        np.testing.assert_allclose([r[name] for r in cs], [r[name] for r in me], rtol=0, atol=1e-6, err_msg=name)
    _, x = staircase_exact(me[-1]["time"], u, **p)
    assert cs[-1]["x"] == pytest.approx(x, abs=1e-6)


# -- stiff -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(STIFF_CASES))
def test_cvode_solves_the_stiff_model(family_fmu, fmi_version, case):
    """CVode at the default tolerance, re-initialized at every communication point (0.01 s)."""
    rows, p, u = stiff(family_fmu, fmi_version, "me", case)
    assert len(rows) == 100 and rows[-1]["time"] == pytest.approx(1.0)
    for row in rows:
        x1, x2 = stiff_exact(row["time"], u, p["lambda"], p["x1_0"], p["x2_0"])
        assert row["x1"] == pytest.approx(x1, abs=1e-6), f"t={row['time']}"
        assert row["x2"] == pytest.approx(x2, abs=1e-6), f"t={row['time']}"


@pytest.mark.parametrize("case", sorted(STIFF_CASES))
def test_stiff_co_simulation_agrees_with_model_exchange_and_the_exact_solution(family_fmu, fmi_version, case):
    """Co-simulation's RK4 at cs_step_size = 1e-5 (lambda * h = 0.1, well inside RK4's stability
    region) is as exact as CVode."""
    me, p, u = stiff(family_fmu, fmi_version, "me", case)
    cs, _, _ = stiff(family_fmu, fmi_version, "cs", case)
    for name in STIFF_OUTPUTS:
        np.testing.assert_allclose([r[name] for r in cs], [r[name] for r in me], rtol=0, atol=1e-6, err_msg=name)
    for row in cs:
        x1, x2 = stiff_exact(row["time"], u, p["lambda"], p["x1_0"], p["x2_0"])
        assert (row["x1"], row["x2"]) == pytest.approx((x1, x2), abs=1e-6), f"t={row['time']}"
