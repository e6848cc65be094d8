"""A pool's start (construction and first reset) with ``init="each"`` against ``init="once"``.

Over an FMU whose initialization is slow (by default the test FMU ``tests/fmus/slowinit``, whose
initialization spends ``--init-seconds`` of CPU), for each n one pool is made and reset per mode,
the modes alternating over ``--repeats`` rounds. ``each``: every env initializes itself in its
process (a worker's slice one after the other); ``once``: one env does, the others load its state.
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial
from pathlib import Path
from typing import Any

from modelicagym.bench import conditions, format_table, median, write_json
from modelicagym.env import FMUEnv
from modelicagym.fmu.build import build_source_fmu
from modelicagym.vector import PoolVectorEnv

#: the test FMU built when no ``--fmu`` is given (a source checkout)
SLOWINIT_SOURCES = Path(__file__).resolve().parents[1] / "tests" / "fmus" / "slowinit"


def start_seconds(fmu: Path, n: int, init: str, init_seconds: float) -> float:
    """Seconds from the pool's construction to the end of its first reset."""
    fns = [partial(FMUEnv, fmu=str(fmu), inputs=["u"], outputs=["y"], time_step=0.1,
                   parameters={"init_seconds": init_seconds}) for _ in range(n)]
    started = time.perf_counter()
    with PoolVectorEnv(fns, init=init) as envs:
        envs.reset(seed=0)
        return time.perf_counter() - started


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    fmu = Path(args.fmu) if args.fmu else build_source_fmu(SLOWINIT_SOURCES, 2)
    results: dict[str, Any] = {}
    for n in args.n:
        samples: dict[str, list[float]] = {"each": [], "once": []}
        for k in range(args.repeats):
            for init in (("each", "once") if k % 2 == 0 else ("once", "each")):
                samples[init].append(start_seconds(fmu, n, init, args.init_seconds))
        results[str(n)] = {init: median(values) for init, values in samples.items()} | {"samples": samples}
    line, machine = conditions(load_before, args.repeats, 0.0)
    rows = [(n, f"{r['each']:.2f}", f"{r['once']:.2f}", f"{r['each'] / r['once']:.1f}x") for n, r in results.items()]
    print(f"initialization: {args.init_seconds} s of CPU per env; {os.cpu_count()} cores")
    print(format_table(("n", "s to start, each", "s to start, once", "each / once"), rows))
    print(line.replace(" interleaved rounds of 0.0 s", " alternating rounds"))
    path = write_json(args.json, {"results": results, **machine, "init_seconds": args.init_seconds, "fmu": str(fmu)})
    print(f"wrote {path}")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--n", type=int, nargs="+", default=[2, 8, 64], help="numbers of envs")
    parser.add_argument("--init-seconds", type=float, default=0.2, help="CPU seconds of one initialization")
    parser.add_argument("--fmu", default=None, help="an FMU with the slowinit test FMU's variables (default: build it)")
    parser.add_argument("--repeats", type=int, default=3, help="alternating rounds (median reported)")
    parser.add_argument("--json", default="bench-results/init-once.json", help="where to write the JSON")
