"""Throughput on a shared machine: the pool against a single env and its alternatives, under load.

A machine running a pool is rarely idle: the learner runs beside the envs, people train two seeds
at once, a compile takes a core. For the default (light) cart-pole and a heavy one
(``cs_step_size=1e-4``, ~95 us of FMU work a step), at each n, this measures env steps per second
of ``single`` (one env in a plain loop), ``sync`` (`gymnasium.vector.SyncVectorEnv`), ``pool``
(``modelicagym.make_vec``, its default: adaptive layout) and ``pool0`` (``num_workers=0``: every env
in the calling process), under four loads. The setting ``user`` is the light cart-pole's FMU given
as a user gives any FMU (a plain ``FMUEnv`` config over its path; ``user-heavy``: the heavy one):
the pool's default keeps it out of the calling process (crash isolation: a worker stands in for
the calling process and takes every env when that is faster; ``user-1ms``: ~1 ms a step;
``user-python``, ``user-python-heavy``: the same on the Python step path), and the extra candidate ``caller``
(``caller_steps=True``: the calling process steps a slice, the layout adapts) is what the default
was before, so the rows say what isolation costs; ``one_worker`` (``num_workers=cores - 1``: every
env in fewer workers, isolated, fixed, as many parties as cores) is the consolidated layout alone;
``fixed`` (``adapt_layout=False``: the planned workers, no stand-in) is the layout the default had
on the Python path before the stand-in worker.

* ``idle``: nothing else runs (plus ``c_loop``, the one-core C loop: the physical limit);
* ``busy``: one busy Python process beside it;
* ``two``: two trainings at once: the candidate runs in two processes at the same time (each its
  own env or pool), started together; their rates are summed;
* ``learner``: a learner-like load in the calling process: a numpy matmul of ~1 ms after every
  batch (after every n steps of the single env), counted in the wall time, as a user sees it.

Every candidate of a group runs for the same wall time in each of several interleaved rounds;
medians are reported. Targets (2 cores): busy:
pool >= 0.8x single at n=2, >= 1.5x at n=8 and 64, heavy n=2 >= 0.9x, heavy n=8 >= 1.2x; two: the
pools' sum >= 0.9x the better of one pool alone (idle) and two singles at once, at n=2, 8 and 64;
idle: pool >= 1.0x single at n=2, >= 2.2x at n=8, >= 1.75x the C loop at n=64, heavy n=2 >= 1.8x.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import logging
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

import gymnasium as gym
import numpy as np

from modelicagym.bench import add_round_arguments, conditions, format_table, median, write_json
from modelicagym.bench.throughput import EPISODE_STEPS, c_loop, make_vector
from modelicagym.cores import usable_cores

logger = logging.getLogger(__name__)

SETTINGS = {"light": {}, "heavy": {"cs_step_size": 1e-4}, "user": {}, "user-heavy": {"cs_step_size": 1e-4},
            "user-1ms": {"cs_step_size": 1e-5}, "user-python": {"step_path": "python"},
            "user-python-heavy": {"step_path": "python", "cs_step_size": 1e-4}}
LOADS = ("idle", "busy", "two", "learner")
CANDIDATES = ("single", "sync", "pool", "pool0")
#: the settings whose env is a user's FMU, with their extra candidate: the calling process steps a slice
USER_SETTINGS = ("user", "user-heavy", "user-1ms", "user-python", "user-python-heavy")
USER_CANDIDATES = (*CANDIDATES, "caller", "one_worker", "fixed")
#: the bounds on pool/single at n=8, idle, by a step's cost: >= 1.0x, >= 1.5x from 20 us, >= 1.8x from 1 ms
USER_N8_BOUNDS = {"user": 1.0, "user-python": 1.0, "user-heavy": 1.5, "user-python-heavy": 1.5, "user-1ms": 1.8}
#: seconds of numpy work per batch in the ``learner`` load
LEARNER_SECONDS = 1e-3
#: the busy process's command line carries this, so that tests can find it
BUSY_MARKER = "modelicagym-bench-busy"

#: runs for a wall time and returns env steps done
Run = Callable[[float], int]


def _options(setting: str) -> dict[str, Any]:
    return dict(SETTINGS[setting], max_episode_steps=EPISODE_STEPS)


def candidates(setting: str) -> tuple[str, ...]:
    """The candidates measured for ``setting``."""
    return USER_CANDIDATES if setting in USER_SETTINGS else CANDIDATES


def users_config(options: dict[str, Any]) -> dict[str, Any]:
    """The cart-pole's ``FMUEnv`` config, as a user would write it for the cart-pole's FMU: the
    same env, but nothing says its FMU is ours."""
    import modelicagym

    with modelicagym.make("cartpole", **options) as env:
        config = env.config
        fields = {field.name: getattr(config, field.name) for field in dataclasses.fields(config)}
        return {**fields, "fmu": str(config.fmu)}


def make_candidate(candidate: str, setting: str, n: int, stack: ExitStack) -> Callable[[Callable[[], None]], Run]:
    """The candidate's loop; given what to do after each batch (the learner's work), a ``Run``."""
    import modelicagym

    options = _options(setting)
    actions = _Actions(n)
    user = setting in USER_SETTINGS
    if candidate in ("single", "c_loop"):
        env = stack.enter_context(modelicagym.FMUEnv(users_config(options)) if user
                                  else modelicagym.make("cartpole", **options))
        if candidate == "c_loop":
            run_c = c_loop(env)
            return lambda after: _timed(lambda: run_c(4096))
        env.reset(seed=n)

        def single(after: Callable[[], None]) -> Run:
            def batch() -> int:
                for action in actions.next_list():
                    _, _, terminated, truncated, _ = env.step(action)
                    if terminated or truncated:
                        env.reset()
                after()
                return n
            return _timed(batch)
        return single
    layouts = {"pool": {}, "pool0": {"num_workers": 0}, "caller": {"caller_steps": True},
               "one_worker": {"num_workers": max(1, usable_cores() - 1)}, "fixed": {"adapt_layout": False}}
    if user and candidate == "sync":
        envs = gym.vector.SyncVectorEnv([functools.partial(modelicagym.FMUEnv, users_config(options))] * n)
    elif user:
        envs = modelicagym.make_vec(users_config(options), n=n, **layouts[candidate])
    elif candidate == "pool0":
        envs = modelicagym.make_vec("cartpole", n=n, num_workers=0, **options)
    else:
        envs = make_vector(candidate, n, options)
    stack.callback(envs.close)
    envs.reset(seed=n)

    def vector(after: Callable[[], None]) -> Run:
        def batch() -> int:
            envs.step(actions.next_array())
            after()
            return n
        return _timed(batch)
    vector.envs = envs  # type: ignore[attr-defined]
    return vector


class _Actions:
    """Random pushes drawn in advance, one batch of ``n`` at a time (drawing is not measured)."""

    def __init__(self, n: int, batches: int = 1024) -> None:
        self._arrays = list(np.random.default_rng(n).integers(0, 2, size=(batches, n)))
        self._lists = [array.tolist() for array in self._arrays]
        self._k = 0

    def next_array(self) -> np.ndarray:
        self._k = (self._k + 1) % len(self._arrays)
        return self._arrays[self._k]

    def next_list(self) -> list[int]:
        self._k = (self._k + 1) % len(self._lists)
        return self._lists[self._k]


def _timed(batch: Callable[[], int]) -> Run:
    """``batch`` repeated for ``seconds`` of wall time; env steps per second."""
    def run(seconds: float) -> float:
        steps, started = 0, time.perf_counter()
        deadline = started + seconds
        while True:
            for _ in range(16):
                steps += batch()
            now = time.perf_counter()
            if now >= deadline:
                return steps / (now - started)
    return run


@functools.cache
def learner_work() -> Callable[[], None]:
    """A numpy matmul sized to take about ``LEARNER_SECONDS`` (sized once: every group does the same work)."""
    size = 64
    while True:
        a = np.random.default_rng(0).random((size, size))
        a @ a  # the first product starts BLAS's threads: not part of the work
        started = time.perf_counter()
        for _ in range(5):
            a @ a
        if (time.perf_counter() - started) / 5 >= LEARNER_SECONDS or size >= 2048:
            return lambda: a @ a
        size = int(size * 1.25)


@contextmanager
def busy_process() -> Iterator[None]:
    """One busy Python process beside the measurement, for as long as the block runs."""
    process = subprocess.Popen([sys.executable, "-c", f"while True: pass  # {BUSY_MARKER}"])
    try:
        yield
    finally:
        process.kill()
        process.wait()


def measure_group(load: str, setting: str, n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Rates of every candidate for one (load, setting, n), medians of interleaved rounds."""
    if load == "two":
        return _measure_two(setting, n, repeats, seconds)
    python_path = SETTINGS[setting].get("step_path") == "python"  # no C loop over a Python step
    names = [*candidates(setting), "c_loop"] if load == "idle" and not python_path else list(candidates(setting))
    after = learner_work() if load == "learner" else (lambda: None)
    samples: dict[str, list[float]] = {name: [] for name in names}
    with ExitStack() as stack:
        makers = {name: make_candidate(name, setting, n, stack) for name in names}
        runs = {name: maker(after) for name, maker in makers.items()}
        if load == "busy":
            stack.enter_context(busy_process())
        for _ in range(repeats):
            for name, run in runs.items():
                samples[name].append(run(seconds))
        layouts = {name: str(makers[name].envs.layout)  # type: ignore[attr-defined]
                   for name in ("pool", "caller") if name in makers}
    return _group(load, setting, n, samples, {"pool_layout": layouts["pool"], "layouts": layouts})


def _measure_two(setting: str, n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Each candidate in two processes at once; per round the sum of their rates."""
    samples: dict[str, list[float]] = {name: [] for name in candidates(setting)}
    pairs: dict[str, list[list[float]]] = {name: [] for name in candidates(setting)}
    children: dict[str, list[subprocess.Popen]] = {}
    try:
        for name in candidates(setting):
            children[name] = [_start_child(name, setting, n, seconds) for _ in range(2)]
        for pair in children.values():
            for child in pair:
                _expect(child, "ready")
        for _ in range(repeats):
            for name, pair in children.items():
                for child in pair:
                    child.stdin.write("go\n")
                    child.stdin.flush()
                rates = [float(_expect(child, None)) for child in pair]
                samples[name].append(sum(rates))
                pairs[name].append(rates)
    finally:
        for pair in children.values():
            for child in pair:
                child.kill()
                child.wait()
    return _group("two", setting, n, samples, {"pairs": pairs})


def _start_child(candidate: str, setting: str, n: int, seconds: float) -> subprocess.Popen:
    command = [sys.executable, "-m", "modelicagym.bench.shared_machine", "--child", candidate, setting, str(n),
               str(seconds)]
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)


def _expect(child: subprocess.Popen, word: str | None) -> str:
    line = child.stdout.readline().strip()
    if not line or (word is not None and line != word):
        raise RuntimeError(f"a benchmark child process said {line!r} (exit code {child.poll()})")
    return line


def child_main(candidate: str, setting: str, n: int, seconds: float) -> None:
    """A ``two`` child: make the candidate, say ``ready``, then one rate per ``go`` line until EOF."""
    with ExitStack() as stack:
        run = make_candidate(candidate, setting, n, stack)(lambda: None)
        print("ready", flush=True)
        for line in sys.stdin:
            if line.strip() == "go":
                print(run(seconds), flush=True)


def _group(load: str, setting: str, n: int, samples: dict[str, list[float]], extra: dict[str, Any]) -> dict[str, Any]:
    rates = {name: median(values) for name, values in samples.items()}
    ratios = {f"{name}/single": rates[name] / rates["single"]
              for name in ("pool", "pool0", "sync", "caller", "one_worker", "fixed") if name in rates}
    if "c_loop" in rates:
        ratios["pool/c_loop"] = rates["pool"] / rates["c_loop"]
    return {"load": load, "setting": setting, "n": n, "steps_per_second": rates, "samples": samples,
            "ratios": ratios, **extra}


def targets(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The targets that this run measured: what, the measured value, the bound, met."""
    by = {(r["load"], r["setting"], r["n"]): r for r in results}
    rows = []

    def target(what: str, key: tuple, value: Callable[[dict], float | None], bound: float) -> None:
        if key in by and (measured := value(by[key])) is not None:
            rows.append({"target": what, "measured": measured, "bound": bound, "met": measured >= bound})

    for setting, n, bound in (("light", 2, 0.8), ("light", 8, 1.5), ("light", 64, 1.5), ("heavy", 2, 0.9),
                              ("heavy", 8, 1.2)):
        target(f"busy {setting} n={n}: pool/single", ("busy", setting, n), lambda r: r["ratios"]["pool/single"], bound)
    for n in (2, 8, 64):
        for setting in SETTINGS:
            idle = by.get(("idle", setting, n))
            if idle is None:
                continue

            def versus_best(r: dict, idle: dict = idle) -> float:
                best = max(idle["steps_per_second"]["pool"], r["steps_per_second"]["single"])
                return r["steps_per_second"]["pool"] / best
            target(f"two {setting} n={n}: pools' sum / max(one pool idle, two singles)", ("two", setting, n),
                   versus_best, 0.9)
    for key, field, bound in ((("idle", "light", 2), "pool/single", 1.0), (("idle", "light", 8), "pool/single", 2.2),
                              (("idle", "light", 64), "pool/c_loop", 1.75), (("idle", "heavy", 2), "pool/single", 1.8)):
        target(f"idle {key[1]} n={key[2]}: {field}", key, lambda r, field=field: r["ratios"][field], bound)
    for setting, bound in USER_N8_BOUNDS.items():  # a pool of a user's FMU never slower than one env
        target(f"idle {setting} n=8: pool/single", ("idle", setting, 8), lambda r: r["ratios"]["pool/single"], bound)
    return rows


def report(results: list[dict[str, Any]], target_rows: list[dict[str, Any]]) -> str:
    parts = []
    for load in LOADS:
        rows = [r for r in results if r["load"] == load]
        if not rows:
            continue
        columns = [*USER_CANDIDATES, "c_loop"] if load == "idle" else list(USER_CANDIDATES)
        ratios = ("pool/single", "pool0/single", "caller/single", "one_worker/single", "fixed/single")
        table = format_table(
            ("setting", "n", *columns, *ratios),
            [(r["setting"], r["n"], *(_cell(r["steps_per_second"].get(c), "{:,.0f}") for c in columns),
              *(_cell(r["ratios"].get(ratio), "{:.2f}x") for ratio in ratios)) for r in rows],
        )
        summed = " (two processes at once, rates summed)" if load == "two" else ""
        parts.append(f"{load}{summed}: env steps per second\n{table}")
    if target_rows:
        parts.append("targets:\n" + format_table(
            ("target", "measured", "bound", "met"),
            [(t["target"], f"{t['measured']:.2f}", f"{t['bound']:.2f}", "yes" if t["met"] else "no") for t in target_rows],
        ))
    return "\n\n".join(parts)


def _cell(value: float | None, form: str) -> str:
    return "-" if value is None else form.format(value)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--loads", nargs="+", default=list(LOADS), choices=LOADS)
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    add_round_arguments(parser, "shared")


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = []
    for load in args.loads:
        for setting in args.settings:
            for n in args.n:
                logger.info("measuring %s, %s, n=%d", load, setting, n)
                results.append(measure_group(load, setting, n, args.repeats, args.seconds))
    line, data = conditions(load_before, args.repeats, args.seconds)
    target_rows = targets(results)
    print(report(results, target_rows))
    print(f"\n{line}")
    print(f"wrote {write_json(args.json, {**data, 'results': results, 'targets': target_rows})}")
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        child_main(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]))
