"""What a saved state costs: its bytes, and microseconds per ``save_state`` / ``load_state``.

For the bundled models (cart-pole and pendulum, FMI 2.0 and 3.0, co-simulation and model exchange)
and any ``--fmu`` given, one instance is initialized and stepped a few times; then the state is
saved and loaded ``--calls`` times in interleaved rounds (`FMUInstance.save_state`: get the FMU
state, serialize it, free it; `load_state`: deserialize, set, free, and in model exchange restart
the solver). The env's ``get_state`` / ``set_state`` add a few µs of Python around them.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from pathlib import Path
from typing import Any

from modelicagym.bench import conditions, format_table, median, write_json
from modelicagym.fmu import FMUInstance, open_fmu
from modelicagym.models.cartpole import cartpole_fmu
from modelicagym.models.pendulum import pendulum_fmu

logger = logging.getLogger(__name__)


def targets(extra: list[str]) -> list[tuple[str, Path, str]]:
    """``(label, FMU path, mode)`` of every FMU and mode measured."""
    bundled = [(f"{name} fmi{v}", make(v)) for name, make in (("cartpole", cartpole_fmu), ("pendulum", pendulum_fmu))
               for v in (2, 3)]
    given = [(Path(p).name, Path(p)) for p in extra]
    return [(f"{label} {mode}", path, mode) for label, path in bundled + given for mode in open_fmu(path).modes]


def measure(path: Path, mode: str, calls: int, repeats: int) -> dict[str, Any]:
    """Bytes of the state and µs per save and per load (medians of ``repeats`` rounds of ``calls``)."""
    fmu = FMUInstance(path, mode=mode)
    try:
        fmu.reset()
        for _ in range(5):
            fmu.step(fmu.step_size or 0.01)
        state = fmu.save_state()
        save, load = [], []
        for _ in range(repeats):
            started = time.perf_counter()
            for _ in range(calls):
                fmu.save_state()
            save.append((time.perf_counter() - started) / calls * 1e6)
            started = time.perf_counter()
            for _ in range(calls):
                fmu.load_state(state)
            load.append((time.perf_counter() - started) / calls * 1e6)
    finally:
        fmu.close()
    return {"bytes": len(state.data), "save_us": median(save), "load_us": median(load)}


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = {}
    for label, path, mode in targets(args.fmu):
        results[label] = measure(path, mode, args.calls, args.repeats)
    line, machine = conditions(load_before, args.repeats, 0.0)
    rows = [(label, r["bytes"], f"{r['save_us']:.1f}", f"{r['load_us']:.1f}") for label, r in results.items()]
    print(format_table(("FMU", "bytes", "µs per save", "µs per load"), rows))
    print(line.replace("of 0.0 s", f"of {args.calls} calls"))
    path = write_json(args.json, {"results": results, **machine, "calls": args.calls, "repeats": args.repeats})
    print(f"wrote {path}")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fmu", nargs="*", default=[], help="further FMUs to measure (every mode they offer)")
    parser.add_argument("--calls", type=int, default=2000, help="calls per round")
    parser.add_argument("--repeats", type=int, default=5, help="rounds (median reported)")
    parser.add_argument("--json", default="bench-results/saved-states.json", help="where to write the JSON")
