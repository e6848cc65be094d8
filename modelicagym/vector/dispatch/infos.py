"""The pool's infos: the one place per-env infos are merged into a vector env's infos.

`add_info` merges one env's info as Gymnasium's vector envs do (``VectorEnv._add_info``, private
to Gymnasium, is not called): each key becomes an array of ``num_envs`` values (``final_obs`` an
object array, a dict value merged recursively) beside its ``_key`` mask of the envs that reported
it. `merge_infos` merges a batch of them; `add_final_infos` adds, in a few array operations, the
``final_obs`` / ``final_info`` of the envs the native step reset in a ``SAME_STEP`` step: the same
merge, made with the same columns and masks, without building each env's info. `env_info` is
the inverse: one env's info out of a vector env's infos (SB3's per-env infos, a Ray host's rollouts).
Every vector env of the package (the pool, its partial batches, the Ray vector env) merges
here; ``tests/vector/test_infos.py`` pins the result against ``AsyncVectorEnv``'s.

Runs in the calling process (where a vector env's step returns).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modelicagym.vector.wire.buffers import PickledBatch, SharedBatch

__all__ = ["Entries", "add_final_infos", "add_info", "env_info", "merge_infos", "select_infos"]

#: ``(env index, info)`` pairs, in env order, to merge into the vector infos
Entries = list[tuple[int, dict[str, Any]]]


def add_info(infos: dict[str, Any], info: dict[str, Any], index: int, num_envs: int) -> dict[str, Any]:
    """Merge env ``index``'s ``info`` into the vector ``infos`` of ``num_envs`` envs; returns them."""
    for key, value in info.items():
        if key == "final_obs":
            column = _final_obs_column(infos, num_envs)
            column[index] = value
        elif isinstance(value, dict):
            column = add_info(infos.get(key, {}), value, index, num_envs)
        else:
            column = infos[key] if key in infos else _column_for(value, num_envs)
            column[index] = value
        infos[key] = column
        infos[f"_{key}"] = _marked(infos.get(f"_{key}"), index, num_envs)
    return infos


def env_info(infos: dict[str, Any], index: int) -> dict[str, Any]:
    """Env ``index``'s own info out of vector ``infos``: the inverse of `add_info`, nested dicts included.

    A key belongs to the env where its ``_key`` mask is set. A key with no mask belongs to every
    env, its row ``index`` being the env's value: Gymnasium masks every key it merges, so an
    unmasked one is a per-row column added beside them (the partial batches' ``env_id``, EnvPool's
    maskless infos); dropping it would lose what the vector env said of each env. A key starting
    with ``_`` is a mask only when the key it masks is there (an env's own ``_key`` is kept).
    """
    info: dict[str, Any] = {}
    for key, value in infos.items():
        if key.startswith("_") and key[1:] in infos:
            continue
        mask = infos.get(f"_{key}")
        if mask is not None and not mask[index]:
            continue
        info[key] = env_info(value, index) if isinstance(value, dict) else value[index]
    return info


def select_infos(infos: dict[str, Any], env_ids: np.ndarray) -> dict[str, Any]:
    """The vector infos of envs ``env_ids`` only (every batched array indexed by them)."""
    return {key: select_infos(value, env_ids) if isinstance(value, dict) else value[env_ids]
            for key, value in infos.items()}


def merge_infos(entries: Entries, num_envs: int) -> dict[str, Any]:
    """The vector infos of ``entries`` (each merged by `add_info`)."""
    infos: dict[str, Any] = {}
    for index, info in entries:
        infos = add_info(infos, info, index, num_envs)
    return infos


def add_final_infos(infos: dict[str, Any], ready: np.ndarray, final_observations: SharedBatch | PickledBatch,
                    num_envs: int) -> None:
    """Add to ``infos`` what `add_info` would for each env of ``ready`` (reset by the native step,
    its last observation in ``final_observations``, its final info empty: `SharedBuffers.take_final_ready`),
    in a few array operations: per-env merging would cost ``SAME_STEP`` a third of its steps per second."""
    if not ready.size:
        return
    final_obs = _final_obs_column(infos, num_envs)
    for index in ready.tolist():
        final_obs[index] = final_observations.read_observation(index)
    infos["final_obs"] = final_obs
    infos["_final_obs"] = _marked(infos.get("_final_obs"), ready, num_envs)
    infos["final_info"] = infos.get("final_info", {})  # an empty info adds no key
    infos["_final_info"] = _marked(infos.get("_final_info"), ready, num_envs)


def _final_obs_column(infos: dict[str, Any], num_envs: int) -> np.ndarray:
    """The ``final_obs`` column of ``infos``: one object per env (observations of any space)."""
    column = infos.get("final_obs")
    return np.full(num_envs, None, dtype=object) if column is None else column


def _column_for(value: Any, num_envs: int) -> np.ndarray:
    """A new column for values like ``value``: numbers in their own dtype, arrays stacked (all
    assumed of one shape), anything else in an object array."""
    if type(value) in (int, float, bool) or isinstance(value, np.number):
        return np.zeros(num_envs, dtype=type(value))
    if isinstance(value, np.ndarray):
        return np.zeros((num_envs, *value.shape), dtype=value.dtype)
    return np.full(num_envs, None, dtype=object)


def _marked(mask: np.ndarray | None, indices: int | np.ndarray, num_envs: int) -> np.ndarray:
    """``mask`` (a new one of ``num_envs`` if ``None``) with ``indices`` set: the envs that reported a key."""
    if mask is None:
        mask = np.zeros(num_envs, dtype=np.bool_)
    mask[indices] = True
    return mask
