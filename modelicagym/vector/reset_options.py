"""A vector reset's options: the shared ones and, under ``"options_per_env"``, one dict per env.

The caller's ``options`` are checked once (:func:`check_options_per_env`); each party is then sent
its envs' part only (:func:`options_for`: the entries may hold large states), and each env gets the
shared options updated by its own entry (:func:`options_of_env`). A pool and a vector env of pools
(``distributed``) split them alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from modelicagym.errors import ArgumentError, ArgumentTypeError

__all__ = ["check_options_per_env", "options_for", "options_of_env", "with_initial_state"]


def check_options_per_env(options: dict[str, Any] | None, num_envs: int) -> None:
    """``reset``'s ``options["options_per_env"]``: one dict (or None) per env, refused before any env sees it."""
    if options is None or "options_per_env" not in options:
        return
    per_env = options["options_per_env"]
    if not isinstance(per_env, Sequence) or isinstance(per_env, (str, bytes)) or len(per_env) != num_envs:
        got = f"{len(per_env)} entries" if isinstance(per_env, Sequence) else type(per_env).__name__
        raise ArgumentError(f"options['options_per_env'] must be a list of {num_envs} dicts (one per env), got {got}")
    bad = next((k for k, entry in enumerate(per_env) if entry is not None and not isinstance(entry, dict)), None)
    if bad is not None:
        raise ArgumentTypeError(f"options['options_per_env'][{bad}] must be a dict or None, "
                                f"got {type(per_env[bad]).__name__}")


def options_for(options: dict[str, Any] | None, indices: range) -> dict[str, Any] | None:
    """The part of ``options`` for the envs ``indices`` (a party's): their entries of
    ``"options_per_env"``, so that no party is sent the others' (they may hold large states)."""
    if options is None or "options_per_env" not in options:
        return options
    return {**options, "options_per_env": options["options_per_env"][indices.start : indices.stop]}


def options_of_env(options: dict[str, Any] | None, offset: int) -> dict[str, Any] | None:
    """The reset options of env ``offset`` of ``options`` (a party's part): the shared ones,
    updated by its own entry of ``"options_per_env"`` when there is one."""
    if options is None or "options_per_env" not in options:
        return options
    shared = {key: value for key, value in options.items() if key != "options_per_env"}
    return {**shared, **(options["options_per_env"][offset] or {})}


def with_initial_state(options: dict[str, Any] | None, state: Any, num_envs: int) -> dict[str, Any]:
    """``options`` that start each of ``num_envs`` envs from ``state`` (``init="once"``: the state
    of the env that initialized itself), each env's own entry kept."""
    per_env = (options or {}).get("options_per_env") or [None] * num_envs
    return {**(options or {}), "options_per_env": [{**(entry or {}), "initial_state": state} for entry in per_env]}
