"""The pool's infos: per-env infos merged as Gymnasium merges them, and the ``final_obs`` /
``final_info`` of envs the native step reset in the same step, built with a few array operations."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from modelicagym.vector.wire.buffers import PickledBatch, SharedBatch

__all__ = ["Entries", "add_final_infos", "merge_infos"]

#: ``(env index, info)`` pairs, in env order, to merge into the vector infos
Entries = list[tuple[int, dict[str, Any]]]


def merge_infos(add_info: Callable[[dict[str, Any], dict[str, Any], int], dict[str, Any]],
                entries: Entries) -> dict[str, Any]:
    """The vector infos of ``entries``, each merged by ``add_info`` (``VectorEnv._add_info``)."""
    infos: dict[str, Any] = {}
    for index, info in entries:
        infos = add_info(infos, info, index)
    return infos


def add_final_infos(infos: dict[str, Any], ready: np.ndarray, final_observations: SharedBatch | PickledBatch, n: int) -> None:
    """Add to ``infos`` what ``_add_info`` would for each env of ``ready`` (reset by the native
    step, its last observation in ``final_observations``: `SharedBuffers.take_final_ready`), in a
    few array operations: per-env merging would cost ``SAME_STEP`` a third of its steps per second."""
    if not ready.size:
        return
    final_obs = infos.get("final_obs")
    if final_obs is None:
        final_obs = np.full(n, None, dtype=object)
    for index in ready.tolist():
        final_obs[index] = final_observations.read_observation(index)
    infos["final_obs"] = final_obs
    infos["_final_obs"] = _marked(infos.get("_final_obs"), ready, n)
    infos.setdefault("final_info", {})
    infos["_final_info"] = _marked(infos.get("_final_info"), ready, n)


def _marked(mask: np.ndarray | None, indices: np.ndarray, n: int) -> np.ndarray:
    """``mask`` (a new one of ``n`` if ``None``) with ``indices`` set, as ``_add_info`` marks infos."""
    if mask is None:
        mask = np.zeros(n, dtype=np.bool_)
    mask[indices] = True
    return mask
