"""The benchmarks of modelicagym's own parts: FMI calls, solvers, the pool's mechanisms.

They matter to whoever changes those parts, and the design's figures rest on them; a user measures
with ``modelicagym bench`` instead. They run from a clone of the repository, from its root, and are
not installed with the package::

    python -m benchmarks --help
    python -m benchmarks NAME [...]

Each module measures like ``modelicagym bench`` (its candidates side by side in interleaved rounds,
a table with the machine's conditions, JSON under ``bench-results/``) with the shared helpers of
`modelicagym.bench`. C that only they run lives in ``csrc/`` (`benchmarks.native`).
"""

from __future__ import annotations

__all__ = ["BENCHMARKS"]

#: (name, module, summary) of every benchmark, in the order ``--help`` lists them; a module is
#: imported only when its benchmark runs
BENCHMARKS = (
    ("fmi-calls", "benchmarks.fmi_calls", "one cart-pole step, layer by layer: doStep, the FMI calls, FMUEnv.step"),
    ("model-exchange", "benchmarks.model_exchange",
     "each solver (CVode, Euler, RK4) on both step paths against co-simulation"),
    ("autoreset", "benchmarks.autoreset", "the pool in each autoreset mode: same-step against next-step"),
    ("python-reward", "benchmarks.python_reward",
     "a reward written in Python (per env, on arrays) against the native one"),
    ("partial-batches", "benchmarks.partial_batches", "send/recv (EnvPool's partial batches) against the barrier step"),
    ("balance", "benchmarks.balance", "the layout balanced by cost, for envs whose cost varies with their state"),
    ("pool-gain", "benchmarks.pool_gain", "the default pool against one env, per FMU, with the bar each must meet"),
    ("systems", "benchmarks.systems",
     "a system's step: one env against Ecos from Python, and the default pool at n=8 and n=2"),
    ("once-per-process", "benchmarks.once_per_process",
     "once per process: copies of its binary against one env a worker"),
    ("init-once", "benchmarks.init_once", 'a pool\'s start, each env initializing against init="once"'),
    ("saved-states", "benchmarks.saved_states", "bytes and microseconds per saved and loaded state"),
    ("load-trial", "benchmarks.load_trial", "an FMU binary's first load (tried in a child) against a kept verdict"),
    ("barrier", "benchmarks.barrier", "an empty step's synchronisation, by number of workers"),
    ("runner", "benchmarks.runner", "the paper study's training loop against the bare pool, part by part"),
    ("solver-accuracy", "benchmarks.solver_accuracy", "the cart-pole's internal step: error against cost"),
    ("omsimulator-suite", "benchmarks.omsimulator_suite",
     "OMSimulator's test-suite systems: which load and run, and the values its scripts print (--suite)"),
)
