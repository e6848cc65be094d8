"""The batched Q-learning agent's hot path in one C call each (``native/csrc/qlearning.c``).

`QLearningAgent` steps a batch of 15-25 envs with about fifty numpy calls per training step,
each costing more than the arithmetic it does; its ``states``, ``act`` and ``learn`` are here
single calls into our native library, written operation for operation as numpy evaluates them, so
the Q-tables, epsilons and episodes are bit for bit the same. Where the library cannot be built
(no C compiler), the agent keeps its numpy path.
"""

from __future__ import annotations

import ctypes
import functools
import logging
from functools import partial

import numpy as np

from modelicagym.agents.discretization import Discretizer
from modelicagym.native.abi import MgQLearner
from modelicagym.native.library import NativeBuildError, load_library

__all__ = ["NativeQLearning", "native_library"]

logger = logging.getLogger(__name__)


@functools.cache
def native_library() -> ctypes.CDLL | None:
    """Our native library, or ``None`` (said once) where it cannot be built."""
    try:
        return load_library()
    except NativeBuildError as error:
        logger.warning("the Q-learning agent runs on numpy (slower): %s", error)
        return None


class NativeQLearning:
    """``states``/``act``/``learn`` of one agent's Q-tables and epsilons, updated in place.

    Args:
        library: our native library.
        q_table: ``(n_envs, n_states, n_actions)`` float64, C-contiguous.
        epsilon: ``(n_envs,)`` float64.
        discretizer: maps observations to states.
        learning_rate, discount, exploration_decay, bootstrap_on_truncation: the agent's config.
    """

    def __init__(
        self,
        library: ctypes.CDLL,
        q_table: np.ndarray,
        epsilon: np.ndarray,
        discretizer: Discretizer,
        learning_rate: float,
        discount: float,
        exploration_decay: float,
        bootstrap_on_truncation: bool,
    ) -> None:
        n_envs, n_states, n_actions = q_table.shape
        self._edges = np.ascontiguousarray(discretizer.padded_edges, dtype=np.float64)
        self._strides = np.ascontiguousarray(discretizer.strides, dtype=np.int64)
        self._q, self._epsilon = q_table, epsilon
        self.state = MgQLearner(
            n_envs, n_states, n_actions, self._edges.shape[0], self._edges.shape[1], q_table.ctypes.data,
            epsilon.ctypes.data, self._edges.ctypes.data, self._strides.ctypes.data, learning_rate, discount,
            exploration_decay, int(bootstrap_on_truncation),
        )
        self.n_envs = n_envs
        # Inputs are copied into these (tens of nanoseconds), whose addresses are taken once: taking
        # an arbitrary array's address through ctypes costs about a microsecond each time.
        self._observations = np.zeros((n_envs, self._edges.shape[0]), dtype=np.float64)
        self._draws = np.zeros((n_envs, 2), dtype=np.float64)
        self._states, self._next_states, self._actions = (np.zeros(n_envs, dtype=np.int64) for _ in range(3))
        self._rewards = np.zeros(n_envs, dtype=np.float64)
        self._terminated, self._truncated, self._mask = (np.zeros(n_envs, dtype=np.bool_) for _ in range(3))
        self._out = np.zeros(n_envs, dtype=np.int64)
        ref = ctypes.byref(self.state)
        self._states_call = partial(library.mg_q_states, ref, self._observations.ctypes.data, self._out.ctypes.data)
        self._act_call = partial(
            library.mg_q_act, ref, self._states.ctypes.data, self._draws.ctypes.data, self._out.ctypes.data
        )
        self._learn_call = partial(library.mg_q_learn, ref, *(array.ctypes.data for array in (
            self._states, self._actions, self._rewards, self._next_states, self._terminated, self._truncated,
            self._mask,
        )))

    def states(self, observations: np.ndarray) -> np.ndarray:
        """State index of each env's observation (``(n_envs, n_vars)`` in)."""
        self._observations[...] = observations
        self._states_call()
        return self._out.copy()

    def act(self, states: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """Epsilon-greedy actions from ``draws`` (``(n_envs, 2)`` uniforms)."""
        self._states[...] = states
        self._draws[...] = draws
        self._act_call()
        return self._out.copy()

    def learn(
        self,
        states: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        next_states: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        mask: np.ndarray,
    ) -> None:
        """The Q-learning update of the envs in ``mask``, then the decay of their epsilon."""
        self._states[...] = states
        self._actions[...] = actions
        self._rewards[...] = rewards
        self._next_states[...] = next_states
        self._terminated[...] = terminated
        self._truncated[...] = truncated
        self._mask[...] = mask
        self._learn_call()
