"""A reward written in Python against the native one: the cart-pole's steps per second with its
reward computed in C, per env in Python, or on a slice's arrays in Python.

The reward is the paper's (1 a step, -100 on termination) every way, so only where it is computed
differs:

* ``native``: the config's ``positive_reward`` / ``negative_reward``, in C;
* ``per env``: ``reward=f(env, observation, action, terminated)`` in the config: C steps the FMU,
  Python calls ``f`` once per env and step;
* ``arrays``: ``batch_reward=f(envs, observations, actions, terminated)``: C steps the FMU, Python
  calls ``f`` once per slice and step (a single env: one row);
* ``python path``: the per-env reward on the Python step path (``step_path="python"``): what such an
  env cost before a Python reward kept the native step.

For a single env and for the pool (``make_vec``'s default layout) at each n, one run creates every
candidate and times them interleaved over several rounds, random pushes; medians of env steps
per second, and each candidate's rate over the native one's. The pool's layout differs by
candidate (an env whose reward runs per env stays where it is; the others may move between the
calling process and the worker), so each n also times a slice of n envs stepped in this process
as a worker steps it (`~modelicagym.vector.slice.env_slice.EnvSlice`, no processes): what computing the
rewards in Python costs a batch, the extra C call of the autoreset included.
"""

from __future__ import annotations

import argparse
import logging
import os
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

import modelicagym
from modelicagym.bench import add_round_arguments, conditions, format_table, median, write_json
from modelicagym.bench.throughput import EPISODE_STEPS, Run, interleaved_rates, single_loop, vector_loop
from modelicagym.vector.api import BufferSpec, EnvSlice, SharedBuffers

logger = logging.getLogger(__name__)


def paper_reward(env: Any, observation: Any, action: Any, terminated: bool) -> float:
    """The paper's reward, per env, in Python."""
    return -100.0 if terminated else 1.0


def paper_rewards(envs: Any, observations: Any, actions: Any, terminated: np.ndarray) -> np.ndarray:
    """The paper's reward, on arrays, in Python."""
    return np.where(terminated, -100.0, 1.0)


#: candidate -> the cart-pole's config keys
CANDIDATES: dict[str, dict[str, Any]] = {
    "native": {},
    "per env": {"reward": paper_reward},
    "arrays": {"batch_reward": paper_rewards},
    "python path": {"reward": paper_reward, "step_path": "python"},
}


@contextmanager
def slice_loop(n: int, options: dict[str, Any], seed: int) -> Iterator[Run]:
    """Random pushes for a slice of ``n`` cart-poles stepped in this process, as a worker steps its
    slice (next-step autoreset), on freshly made shared buffers."""
    envs = [modelicagym.make("cartpole", **options).unwrapped for _ in range(n)]
    buffers, fd = SharedBuffers.create(BufferSpec(envs[0].observation_space, envs[0].action_space, n, 1))
    part = EnvSlice(envs, first_env=0, slot=0, autoreset_mode=AutoresetMode.NEXT_STEP)
    try:
        part.attach(buffers, needs_reset=True)
        buffers.step_mask[:] = 1
        buffers.reset_mask[:] = True
        part.reset(list(range(seed, seed + n)), None)
        rng = np.random.default_rng(seed)

        def run(steps: int) -> int:
            batches = max(1, steps // n)
            for actions in rng.integers(0, 2, size=(batches, n)):
                buffers.actions.write_batch(actions)
                part.step()
            return batches * n

        yield run
    finally:
        part.detach()
        os.close(fd)
        for env in envs:
            env.close()


def measure(n: int | None, repeats: int, seconds: float) -> dict[str, Any]:
    """Steps per second of every candidate: one env (``n=None``), or a pool of ``n`` and a slice of ``n``."""
    runs, layouts = {}, {}
    with ExitStack() as stack:
        for name, options in CANDIDATES.items():
            options = {**options, "max_episode_steps": EPISODE_STEPS}
            if n is None:
                env = modelicagym.make("cartpole", **options)
                stack.callback(env.close)
                runs[name] = single_loop(env, seed=1)
                layouts[name] = env.unwrapped.step_path
                continue
            pool = modelicagym.make_vec("cartpole", n=n, **options)
            stack.callback(pool.close)
            runs[name] = vector_loop(pool, n, seed=n)
            layouts[name] = str(pool.layout)
            runs[f"slice {name}"] = stack.enter_context(slice_loop(n, options, seed=n))
        samples, _ = interleaved_rates(runs, repeats, seconds)
    rates = {name: median(values) for name, values in samples.items()}
    over_native = {name: rate / rates["slice native" if name.startswith("slice ") else "native"]
                   for name, rate in rates.items()}
    return {"n": n, "steps_per_second": rates, "samples": samples, "layouts": layouts, "over_native": over_native}


def report(results: list[dict[str, Any]]) -> str:
    names = list(CANDIDATES)
    rows = []
    for r in results:
        pool = "single" if r["n"] is None else f"pool n={r['n']}"
        for prefix, label in (("", pool), ("slice ", f"slice n={r['n']}")):
            if f"{prefix}native" in r["steps_per_second"]:
                rows.append((label, *(f"{r['steps_per_second'][prefix + name]:,.0f}" for name in names),
                             *(f"{r['over_native'][prefix + name]:.2f}x" for name in names[1:])))
    rates = format_table(("envs", *names, *(f"{name}/native" for name in names[1:])), rows)
    layouts = "\n".join(
        f"pool n={r['n']}: " + ", ".join(f"{name} {r['layouts'][name].split(' (')[0]}" for name in names)
        for r in results if r["n"] is not None
    )
    return (f"cart-pole env steps per second, by where the reward is computed:\n{rates}\n\n"
            f"the pools' layouts:\n{layouts}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_round_arguments(parser, "python-reward")
    parser.set_defaults(n=[8, 64])


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = []
    for n in [None, *args.n]:
        logger.info("measuring %s", "a single env" if n is None else f"a pool of {n}")
        results.append(measure(n, args.repeats, args.seconds))
    line, data = conditions(load_before, args.repeats, args.seconds)
    print(report(results))
    print(f"\n{line}")
    print(f"wrote {write_json(args.json, {**data, 'results': results})}")
    return 0
