"""The pool's names for the rest of modelicagym: what ``sb3``, ``distributed``, ``experiments`` and
the benchmarks use of the pool besides its user API (`modelicagym.vector`).

They are exported here on purpose, so that the pool's folders may change behind them: no module
outside ``vector/`` imports any other of the pool's modules (a test reads every import).
"""

from modelicagym.vector.checks import check_reset_mask, seeds_per_env, values_per_env
from modelicagym.vector.dispatch.dispatcher import collect_poll_time, go_poll_time
from modelicagym.vector.dispatch.infos import add_info, env_info
from modelicagym.vector.layout.placement import LayoutState
from modelicagym.vector.layout.plan import plan_workers
from modelicagym.vector.pool import INIT_MODES, POOL_OPTIONS
from modelicagym.vector.reset_options import check_options_per_env, options_for, with_initial_state
from modelicagym.vector.saved_states import VectorState, split_states
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import BufferSpec, SharedBuffers

__all__ = [
    # the options of `PoolVectorEnv` (make_vec's backend options) and its ``init`` modes
    "INIT_MODES",
    "POOL_OPTIONS",
    # where a pool's envs run: a plan of many hosts, and a pool's layout as the user commands report it
    "LayoutState",
    "plan_workers",
    # what a vector env of pools checks of its caller's arguments, how it splits them among its pools
    # and merges their infos
    "add_info",
    "check_options_per_env",
    "check_reset_mask",
    "env_info",
    "options_for",
    "seeds_per_env",
    "split_states",
    "values_per_env",
    "with_initial_state",
    "VectorState",
    # what the maintainers' benchmarks measure of the pool's parts
    "BufferSpec",
    "EnvSlice",
    "SharedBuffers",
    "collect_poll_time",
    "go_poll_time",
]
