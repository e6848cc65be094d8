"""What the load trial costs: the first load of an FMU binary on a machine, and a later one.

Each round uses a cache folder of its own and the cart-pole FMU copied out of the builder's place
(so it is tried like a user's FMU, not skipped as a bundled model). It times `check_first_load`
three ways: here, on the never-tried binary (the trial: a child process starts Python, loads,
instantiates, initializes and frees the FMU); then in a new process, where the verdict is kept
(reading the extraction's manifest and the verdict: what every later process pays once per
binary); and again in that process (a known binary: nothing). For scale, that process also times
the `FMUInstance` construction that follows.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from modelicagym.bench import format_table, median, write_json

#: run in a new process: the check with the verdict kept, again, and the construction after it
_LATER_LOAD = """
import json, sys, time
from modelicagym.fmu import FMUInstance, open_fmu
from modelicagym.fmu.trial import check_first_load
description = open_fmu(sys.argv[1])
library = description.library_path("cs")
started = time.perf_counter()
check_first_load(description, "cs", library)
checked = time.perf_counter()
check_first_load(description, "cs", library)
again = time.perf_counter()
FMUInstance(description).close()
built = time.perf_counter()
print(json.dumps({"kept verdict, new process": checked - started, "known binary, same process": again - checked,
                  "FMUInstance after the check": built - again}))
"""


def measure(repeats: int) -> dict[str, Any]:
    """Seconds of each way of loading, per round."""
    from modelicagym.fmu import open_fmu
    from modelicagym.fmu.trial import check_first_load
    from modelicagym.models.cartpole import cartpole_fmu

    built = cartpole_fmu()
    samples: dict[str, list[float]] = {}
    saved = os.environ.get("MODELICAGYM_CACHE")
    try:
        for _ in range(repeats):
            with tempfile.TemporaryDirectory(prefix="modelicagym-load-trial-") as folder:
                os.environ["MODELICAGYM_CACHE"] = str(Path(folder) / "cache")
                fmu = Path(shutil.copy(built, Path(folder) / "user-cartpole.fmu"))
                description = open_fmu(fmu)
                started = time.perf_counter()
                check_first_load(description, "cs", description.library_path("cs"))
                samples.setdefault("first load: the trial", []).append(time.perf_counter() - started)
                later = subprocess.run([sys.executable, "-c", _LATER_LOAD, str(fmu)], capture_output=True, text=True,
                                       check=True)
                for name, seconds in json.loads(later.stdout).items():
                    samples.setdefault(name, []).append(seconds)
    finally:
        if saved is None:
            os.environ.pop("MODELICAGYM_CACHE", None)
        else:
            os.environ["MODELICAGYM_CACHE"] = saved
    return {"seconds": {name: median(values) for name, values in samples.items()}, "samples": samples,
            "repeats": repeats, "cores": os.cpu_count(), "load_average": os.getloadavg()}


def report(result: dict[str, Any]) -> str:
    rows = [(name, f"{seconds * 1e3:.3f} ms") for name, seconds in result["seconds"].items()]
    return (format_table(("cart-pole FMU, co-simulation", "median"), rows)
            + f"\n\ncores: {result['cores']}; load average (1 min) after {result['load_average'][0]:.2f}; "
            f"medians of {result['repeats']} rounds")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=int, default=5, help="rounds (median reported)")
    parser.add_argument("--json", default="bench-results/load_trial.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = measure(args.repeats)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
