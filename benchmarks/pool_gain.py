"""The default pool against one env in a loop, per FMU, with the bar each must meet.

For each FMU, one `FMUEnv` stepped in a plain loop (reset when an episode ends) against
``modelicagym.make_vec(config, n)`` with its default layout (next-step autoreset). The pool runs
``--warm`` seconds first, so that its adaptive layout has made its first try; then ``--rounds``
interleaved rounds of ``--seconds`` each. Reported: the median of the rounds' ratios pool/single
(env steps per second), the ratios themselves, the bar, whether it is met, and the pool's layout.

The bar follows from the single env's measured cost a step: at n=8, >= 1.8x where a step costs
>= 1 ms, >= 1.5x from 20 us, else >= 1.0x; an FMU allowed only one instance per process, at n=2:
>= 1.0x. Other numbers of envs get no bar.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import time
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import modelicagym
from benchmarks.balance import MOODY_SOURCES
from modelicagym.bench import conditions, format_table, median, write_json
from modelicagym.bench.shared_machine import users_config
from modelicagym.errors import ArgumentError, ConfigError
from modelicagym.fmu import open_fmu
from modelicagym.fmu.build import build_source_fmu, description_name
from modelicagym.fmu.description_edits import edited_description
from modelicagym.registry import EnvFactory
from modelicagym.try_fmu import try_config
from modelicagym.vector import PoolVectorEnv

logger = logging.getLogger(__name__)

#: the single env's actions, sampled up front and cycled through; the clock is read after each pass
SINGLE_ACTIONS = 50
#: the pool's batches of actions, likewise
POOL_BATCHES = 20
#: the single env's warm-up, seconds (at most ``--warm``)
SINGLE_WARM = 1.0
#: the bars on pool/single at n=8, by a single env's cost a step: (from this many us, bar), costliest first
COST_BARS = ((1000.0, 1.8), (20.0, 1.5), (0.0, 1.0))
#: the bar for an FMU allowed one instance per process, at n=2
ONCE_BAR = 1.0
#: the moody FMU held calm (its costly phase never reached) at the cost its internal step size gives
CALM = "parameters.threshold=1e9"


#: what ``--cases`` measures, for ``--help``
CASES_HELP = """built-in cases (--cases): cartpole-user, the bundled cart-pole given as a user gives any FMU (so the
pool isolates it); cartpole-user-observation, the same with `observation` overridden (the FMU steps
in C, the observation in Python); cartpole-user-python, the same on the Python step path; moody-100us
and moody-1ms, the moody test FMU held calm at ~100 us and ~1 ms a step (built from a checkout's
tests/fmus/moody); moody-once, the same at ~100 us, allowed one instance per process. --fmu adds your
FMUs, configured as `modelicagym info` suggests (--set changes that config), at n=8, or n=2 when once
per process."""


class ScaledObservationEnv(modelicagym.FMUEnv):
    """An FMUEnv whose ``observation`` is overridden, as users write one: the outputs scaled by one
    half. Its FMU steps in C, the observation in Python (``cartpole-user-observation``). Its class
    says its hook keeps no state, so the pool may move it between processes (without that, it would
    keep its place: ``FMUEnv.stateless_hooks``)."""

    stateless_hooks = True

    def make_observation_space(self) -> gym.Space:
        shape = super().make_observation_space().shape
        return gym.spaces.Box(-np.inf, np.inf, shape, np.float64)

    def observation(self) -> np.ndarray:
        return np.asarray(super().observation(), dtype=np.float64) * 0.5


@dataclass(frozen=True)
class Case:
    """One FMU to measure: how the table names it, its config (made when the run starts) and the
    env class over it."""

    name: str
    label: str
    config: Callable[[], dict[str, Any]]
    env_class: type[modelicagym.FMUEnv] = modelicagym.FMUEnv


def _moody(once: bool) -> Path:
    """The moody test FMU (FMI 2.0) built from the checkout's sources, allowed once per process or not."""
    if not MOODY_SOURCES.is_dir():
        raise ConfigError(f"pool-gain: the moody cases are built from {MOODY_SOURCES}, which is not here: "
                          "run from a checkout of modelicagym, or leave them out (--cases cartpole-user)")
    description = edited_description(MOODY_SOURCES / description_name(2), once_per_process=True) if once else None
    return build_source_fmu(MOODY_SOURCES, 2, model_description=description)


def _moody_config(cs_step_size: str, once: bool = False) -> Callable[[], dict[str, Any]]:
    return lambda: try_config(_moody(once), settings=[CALM, f"parameters.cs_step_size={cs_step_size}"])


CASES = {case.name: case for case in (
    Case("cartpole-user", "the cart-pole as a user's FMU", lambda: users_config({})),
    Case("cartpole-user-observation", "the same, its observation overridden", lambda: users_config({}),
         ScaledObservationEnv),
    Case("cartpole-user-python", "the same on the Python step path", lambda: users_config({"step_path": "python"})),
    Case("moody-100us", "moody held calm, cs_step_size 2.5e-5", _moody_config("2.5e-5")),
    Case("moody-1ms", "moody held calm, cs_step_size 2.5e-6", _moody_config("2.5e-6")),
    Case("moody-once", "moody_once held calm, cs_step_size 2.5e-5", _moody_config("2.5e-5", once=True)),
)}


def users_case(path: str, settings: list[str]) -> Case:
    """A user's FMU, configured as ``info`` suggests and changed by ``settings`` (``key=value``)."""
    return Case(Path(path).stem, Path(path).stem, lambda: try_config(path, settings=settings))


def bar(single_us: float, n: int, once_per_process: bool) -> float | None:
    """The bar on pool/single for ``n`` envs of an FMU whose single env costs ``single_us`` a step
    (``None``: no bar for this n)."""
    if n == 2 and once_per_process:
        return ONCE_BAR
    if n != 8:
        return None
    return next(bound for cost, bound in COST_BARS if single_us >= cost)


def default_n(once_per_process: bool) -> int:
    """The number of envs the bar is set at."""
    return 2 if once_per_process else 8


def single_run(env: modelicagym.FMUEnv) -> Callable[[float], float]:
    """One env in a loop for ``seconds``: env steps per second."""
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(SINGLE_ACTIONS)]

    def run(seconds: float) -> float:
        steps, started = 0, time.perf_counter()
        while time.perf_counter() - started < seconds:
            for action in actions:
                _, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    env.reset()
            steps += len(actions)
        return steps / (time.perf_counter() - started)

    return run


def pool_run(envs: gym.vector.VectorEnv) -> Callable[[float], float]:
    """The pool stepped for ``seconds`` (its own autoreset): env steps per second."""
    envs.reset(seed=0)
    envs.action_space.seed(0)
    batches = [envs.action_space.sample() for _ in range(POOL_BATCHES)]

    def run(seconds: float) -> float:
        steps, started = 0, time.perf_counter()
        while time.perf_counter() - started < seconds:
            for batch in batches:
                envs.step(batch)
            steps += len(batches) * envs.num_envs
        return steps / (time.perf_counter() - started)

    return run


def _make_vec(config: Mapping[str, Any], n: int, env_class: type[modelicagym.FMUEnv]) -> gym.vector.VectorEnv:
    """The default pool of ``n`` envs: ``make_vec`` for an FMUEnv config, else the same pool over
    env fns of ``env_class`` (as a user pools a subclass)."""
    if env_class is modelicagym.FMUEnv:
        return modelicagym.make_vec(dict(config), n=n)
    entry_point = f"{env_class.__module__}:{env_class.__qualname__}"
    return PoolVectorEnv([EnvFactory(entry_point, dict(config)) for _ in range(n)])


def measure(config: Mapping[str, Any], n: int, rounds: int, seconds: float, warm: float,
            env_class: type[modelicagym.FMUEnv] = modelicagym.FMUEnv) -> dict[str, Any]:
    """The single env's and the pool's rates over interleaved rounds, after the warm-up; the pool's
    layout at the end, and the single env's step path."""
    with ExitStack() as stack:
        envs = _make_vec(config, n, env_class)  # before the single env, as a user makes them
        stack.callback(envs.close)
        env = stack.enter_context(env_class(dict(config)))
        single, pool = single_run(env), pool_run(envs)
        pool(warm)
        single(min(SINGLE_WARM, warm))
        single_rates, pool_rates = [], []
        for _ in range(rounds):
            single_rates.append(single(seconds))
            pool_rates.append(pool(seconds))
        layout = str(envs.layout)
        step_path = {"path": env.step_path, "reason": env.step_path_reason}
    ratios = [p / s for p, s in zip(pool_rates, single_rates)]
    return {"single_steps_per_second": single_rates, "pool_steps_per_second": pool_rates, "ratios": ratios,
            "median": median(ratios), "single_us": 1e6 / median(single_rates), "layout": layout,
            "step_path": step_path}


def measure_case(case: Case, config: Mapping[str, Any], ns: list[int] | None, rounds: int, seconds: float,
                 warm: float) -> list[dict[str, Any]]:
    """One row per number of envs (the bar's when ``ns`` is None) for ``case``, made from ``config``."""
    once = open_fmu(config["fmu"], validate=config.get("validate", True)).once_per_process(config.get("mode"))
    rows = []
    for n in ns or [default_n(once)]:
        logger.info("measuring %s, n=%d", case.name, n)
        row = {"case": case.name, "label": case.label, "fmu": str(config["fmu"]), "once_per_process": once, "n": n,
               "config": json.loads(json.dumps(config, default=str)),
               **measure(config, n, rounds, seconds, warm, case.env_class)}
        row["bar"] = bar(row["single_us"], n, once)
        row["met"] = None if row["bar"] is None else row["median"] >= row["bar"]
        rows.append(row)
    return rows


def _cost(us: float) -> str:
    return f"{us:.1f} us" if us < 10 else f"{us:,.0f} us"


def report(rows: list[dict[str, Any]]) -> str:
    """The table (one row per FMU and n) and each pool's layout at the end."""
    table = format_table(
        ("FMU (single env, us a step)", "n", "pool/single (rounds)", "bar", "met"),
        [(f"{r['label']} ({_cost(r['single_us'])})", r["n"],
          f"{r['median']:.2f}x ({' '.join(f'{x:.2f}' for x in r['ratios'])})",
          "-" if r["bar"] is None else f">= {r['bar']:.1f}", {True: "yes", False: "no", None: "-"}[r["met"]])
         for r in rows],
    )
    layouts = "\n".join(f"  {r['label']}, n={r['n']}: {r['layout']}" for r in rows)
    return (f"the default pool against one env in a loop, env steps per second:\n{table}\n\n"
            f"the pool's layout at the end:\n{layouts}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES), metavar="CASE",
                        help=f"built-in FMUs to measure, of {', '.join(CASES)} (default: all; none with --fmu alone)")
    parser.add_argument("--fmu", nargs="+", default=[], metavar="PATH",
                        help="your FMUs, configured as `modelicagym info` suggests")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="change one key of your FMUs' configs, the value read as JSON (e.g. --set time_step=0.01)")
    parser.add_argument("--n", type=int, nargs="+",
                        help="numbers of envs (default: 8, or 2 for an FMU allowed once per process)")
    parser.add_argument("--rounds", type=int, default=5,
                        help="interleaved rounds, the median of their ratios reported (default 5)")
    parser.add_argument("--seconds", type=float, default=0.5,
                        help="seconds a round, single env and pool each (default 0.5)")
    parser.add_argument("--warm", type=float, default=8.0,
                        help="seconds the pool runs first, so that its adaptive layout has made its first try "
                             "(default 8)")
    parser.add_argument("--json", default="bench-results/pool-gain.json",
                        help="where to write the JSON (default bench-results/pool-gain.json)")
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = __doc__
    parser.epilog = CASES_HELP


def _check(args: argparse.Namespace) -> None:
    for option, value, low in (("--rounds", args.rounds, 1), *(("--n", n, 1) for n in args.n or [])):
        if value < low:
            raise ArgumentError(f"pool-gain {option}: at least {low}, got {value}")
    if args.seconds <= 0 or args.warm < 0:
        raise ArgumentError(f"pool-gain: --seconds must be more than 0 and --warm at least 0, "
                            f"got {args.seconds} and {args.warm}")
    if not args.cases and not args.fmu:
        raise ArgumentError("pool-gain: nothing to measure: name --cases or give --fmu PATH")


def run(args: argparse.Namespace) -> int:
    _check(args)
    load_before = os.getloadavg()
    print(f"load average at the start: {' '.join(f'{x:.2f}' for x in load_before)} (1, 5, 15 min), "
          f"{os.cpu_count()} cores", flush=True)
    cases = [CASES[name] for name in args.cases] + [users_case(path, args.set) for path in args.fmu]
    configs = [case.config() for case in cases]  # every config first: a bad one stops the run before any measures
    rows = [row for case, config in zip(cases, configs)
            for row in measure_case(case, config, args.n, args.rounds, args.seconds, args.warm)]
    line, data = conditions(load_before, args.rounds, args.seconds)
    print(report(rows))
    print(f"\n{line}; the pool warmed {args.warm} s first")
    data = {**data, "rounds": args.rounds, "seconds": args.seconds, "warm": args.warm, "results": rows}
    print(f"wrote {write_json(args.json, data)}")
    return 0
