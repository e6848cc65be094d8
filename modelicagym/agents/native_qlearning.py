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

import numpy as np

from modelicagym.agents.discretization import Discretizer
from modelicagym.native.library import NativeBuildError, load_library

__all__ = ["NativeQLearning", "native_library"]

logger = logging.getLogger(__name__)


class MgQLearner(ctypes.Structure):
    """``mg_qlearner`` of ``csrc/qlearning.h``."""

    _fields_ = [
        ("n_envs", ctypes.c_int64),
        ("n_states", ctypes.c_int64),
        ("n_actions", ctypes.c_int64),
        ("n_vars", ctypes.c_int64),
        ("max_edges", ctypes.c_int64),
        ("q", ctypes.c_void_p),
        ("epsilon", ctypes.c_void_p),
        ("edges", ctypes.c_void_p),
        ("strides", ctypes.c_void_p),
        ("learning_rate", ctypes.c_double),
        ("discount", ctypes.c_double),
        ("exploration_decay", ctypes.c_double),
        ("bootstrap_on_truncation", ctypes.c_int32),
    ]


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
        self._ref = ctypes.byref(self.state)
        self._states, self._act, self._learn = library.mg_q_states, library.mg_q_act, library.mg_q_learn
        self.n_envs = n_envs

    def states(self, observations: np.ndarray) -> np.ndarray:
        """State index of each env's observation (``(n_envs, n_vars)`` in)."""
        observations = np.ascontiguousarray(observations, dtype=np.float64)
        states = np.empty(self.n_envs, dtype=np.int64)
        self._states(self._ref, observations.ctypes.data, states.ctypes.data)
        return states

    def act(self, states: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """Epsilon-greedy actions from ``draws`` (``(n_envs, 2)``, rows any stride apart)."""
        states = np.ascontiguousarray(states, dtype=np.int64)
        actions = np.empty(self.n_envs, dtype=np.int64)
        if draws.strides[1] != draws.itemsize:
            draws = np.ascontiguousarray(draws)
        self._act(self._ref, states.ctypes.data, draws.ctypes.data, draws.strides[0] // draws.itemsize,
                  actions.ctypes.data)
        return actions

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
        arrays = (
            np.ascontiguousarray(states, dtype=np.int64), np.ascontiguousarray(actions, dtype=np.int64),
            np.ascontiguousarray(rewards, dtype=np.float64), np.ascontiguousarray(next_states, dtype=np.int64),
            np.ascontiguousarray(terminated, dtype=np.bool_), np.ascontiguousarray(truncated, dtype=np.bool_),
            np.ascontiguousarray(mask, dtype=np.bool_),
        )
        self._learn(self._ref, *(array.ctypes.data for array in arrays))
