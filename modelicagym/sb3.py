"""Stable-Baselines3 on any modelicagym vector env: `SB3VecEnv`.

SB3 does not take a Gymnasium ``VectorEnv``; it has its own ``VecEnv`` API, whose conventions
differ: an env that ends is reset in the same step, its last observation goes in
``infos[i]["terminal_observation"]`` and ``infos[i]["TimeLimit.truncated"]`` says a truncation,
infos are one dict per env, rewards are float32, and ``seed(s)`` gives env ``i`` the seed
``s + i`` at the next ``reset()``. `SB3VecEnv` speaks that API over the pool
(``modelicagym.make_vec``), Gymnasium's ``SyncVectorEnv`` of our envs or the Ray vector env, in
whatever autoreset mode the vector env was made with: in ``SAME_STEP`` mode (the pool's fastest
for SB3: ``make_vec(..., autoreset_mode="SameStep")``) it only reshapes what each step returns;
in ``NEXT_STEP`` and ``DISABLED`` mode it resets the envs that ended with a ``reset_mask`` right
after the step. Its results equal SB3's own ``DummyVecEnv`` over the same envs, step by step, so
``VecNormalize``, ``VecMonitor`` and ``evaluate_policy`` just work.

Needs the ``rl`` extra (``pip install torch==2.13.0`` for a CPU-only torch first, then
``pip install "modelicagym[rl]"``); ``import modelicagym`` never imports it.

Example::

    import modelicagym
    from modelicagym.sb3 import SB3VecEnv, folderless_logger
    from stable_baselines3 import PPO

    envs = SB3VecEnv(modelicagym.make_vec("cartpole", n=8, max_episode_steps=500, autoreset_mode="SameStep"))
    model = PPO("MlpPolicy", envs)
    model.set_logger(folderless_logger(model.verbose))  # else every learn() makes a /tmp/SB3-<date> folder
    model.learn(20_000)
    envs.close()
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from modelicagym.errors import ArgumentError
from modelicagym.vector.api import env_info

try:
    from stable_baselines3.common.logger import Logger, make_output_format
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn
except ImportError as error:  # pragma: no cover - the extra's tests skip without it
    raise ImportError(
        "modelicagym.sb3 needs Stable-Baselines3: pip install torch==2.13.0 (a CPU build), then "
        'pip install "modelicagym[rl]"'
    ) from error

__all__ = ["SB3VecEnv", "folderless_logger"]

#: the keys a same-step vector env adds for an env that ended
_FINAL_KEYS = ("final_obs", "_final_obs", "final_info", "_final_info")


def folderless_logger(verbose: int = 0) -> Logger:
    """SB3's logger as its own default gives it (stdout when ``verbose``, else silent) but without a
    folder: SB3's default makes a ``/tmp/SB3-<date and time>`` folder at every ``learn()``, empty when
    nothing is logged to files. Set it with ``model.set_logger(folderless_logger(model.verbose))``."""
    return Logger(folder=None, output_formats=[make_output_format("stdout", "")] if verbose else [])


class SB3VecEnv(VecEnv):
    """A modelicagym vector env (the pool, ``SyncVectorEnv``, the Ray vector env) as an SB3 ``VecEnv``.

    Args:
        venv: the vector env; `SB3VecEnv` owns it from now on (``close()`` closes it).

    ``env_method``, ``get_attr`` and ``set_attr`` with ``indices`` reach only those envs on a
    ``SyncVectorEnv``; on vector envs whose envs live in other processes they go through the
    vector env's ``call``/``set_attr``, which address every env: ``get_attr`` and ``env_method``
    return the selected envs' results (a method is then called on every env, so give
    side-effecting methods no ``indices``), ``set_attr`` sets the others to the value they have.
    ``env_is_wrapped`` checks the wrappers of a ``SyncVectorEnv``'s envs; the envs of
    ``make_vec`` are never wrapped, and envs in other processes are reported so.
    """

    def __init__(self, venv: gym.vector.VectorEnv) -> None:
        if not isinstance(venv, gym.vector.VectorEnv):
            raise ArgumentError(f"SB3VecEnv wraps a gymnasium.vector.VectorEnv, got {type(venv).__name__}")
        self.venv = venv
        self.autoreset_mode = AutoresetMode(venv.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP))
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None

    # ------------------------------------------------------------------ stepping

    def reset(self) -> VecEnvObs:
        """Reset every env, with the seeds of `seed` and the options of `set_options` (used once)."""
        seeds = None if all(seed is None for seed in self._seeds) else list(self._seeds)
        groups: dict[str, list[int]] = {}
        for index, options in enumerate(self._options):
            groups.setdefault(repr(options), []).append(index)
        if len(groups) == 1:
            observations, infos = self.venv.reset(seed=seeds, options=self._options[0] or None)
            self.reset_infos = [env_info(infos, i) for i in range(self.num_envs)]
        else:  # different options per env: one masked reset per set of options
            observations = np.array(self.venv.reset(seed=seeds)[0])
            for indices in groups.values():
                mask = np.zeros(self.num_envs, dtype=np.bool_)
                mask[indices] = True
                reset, infos = self.venv.reset(seed=seeds, options={**self._options[indices[0]], "reset_mask": mask})
                observations[mask] = np.asarray(reset)[mask]
                for i in indices:
                    self.reset_infos[i] = env_info(infos, i)
        self._reset_seeds()
        self._reset_options()
        return np.array(observations)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """One step of every env, with SB3's same-step reset and per-env infos."""
        observations, rewards, terminations, truncations, infos = self.venv.step(self._actions)
        observations = np.array(observations)
        dones = terminations | truncations
        ended = np.flatnonzero(dones).tolist()
        if self.autoreset_mode is AutoresetMode.SAME_STEP:
            own_infos = {key: value for key, value in infos.items() if key not in _FINAL_KEYS}
            step_infos = [env_info(own_infos, i) for i in range(self.num_envs)]
            for i in ended:
                self.reset_infos[i] = step_infos[i]
                step_infos[i] = {**env_info(infos["final_info"], i), "terminal_observation": infos["final_obs"][i]}
        else:
            step_infos = [env_info(infos, i) for i in range(self.num_envs)]
            if ended:
                reset, reset_infos = self.venv.reset(options={"reset_mask": dones.copy()})
                for i in ended:
                    step_infos[i]["terminal_observation"] = observations[i].copy()
                    observations[i] = reset[i]
                    self.reset_infos[i] = env_info(reset_infos, i)
        for i in range(self.num_envs):
            step_infos[i]["TimeLimit.truncated"] = bool(truncations[i] and not terminations[i])
        return observations, np.asarray(rewards, dtype=np.float32), dones, step_infos

    def close(self) -> None:
        self.venv.close()

    # ------------------------------------------------------------------ the envs themselves

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Attribute ``attr_name`` of the selected envs."""
        selected = self._get_indices(indices)
        envs = self._local_envs()
        if envs is not None:
            return [envs[i].get_wrapper_attr(attr_name) for i in selected]
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in selected]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set attribute ``attr_name`` of the selected envs to ``value``."""
        selected = list(self._get_indices(indices))
        envs = self._local_envs()
        if envs is not None:
            for i in selected:
                envs[i].set_wrapper_attr(attr_name, value)
            return
        values = [value] * self.num_envs if len(selected) == self.num_envs else list(self.venv.get_attr(attr_name))
        for i in selected:
            values[i] = value
        self.venv.set_attr(attr_name, values)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """What method ``method_name`` of the selected envs returns."""
        selected = self._get_indices(indices)
        envs = self._local_envs()
        if envs is not None:
            return [envs[i].get_wrapper_attr(method_name)(*method_args, **method_kwargs) for i in selected]
        results = self.venv.call(method_name, *method_args, **method_kwargs)
        return [results[i] for i in selected]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """Whether the selected envs are wrapped in ``wrapper_class`` (see the class docstring)."""
        from stable_baselines3.common.env_util import is_wrapped

        selected = self._get_indices(indices)
        envs = self._local_envs()
        return [envs is not None and is_wrapped(envs[i], wrapper_class) for i in selected]

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            warnings.warn(f"The render mode is {self.render_mode}, but this method assumes it is `rgb_array` "
                          "to obtain images.", stacklevel=2)
            return [None] * self.num_envs
        return list(self.venv.call("render"))

    def _local_envs(self) -> Sequence[gym.Env] | None:
        """The env objects, where they live in this process (``SyncVectorEnv``); else ``None``."""
        envs = getattr(self.venv, "envs", None)
        return envs if isinstance(envs, Sequence) and len(envs) == self.num_envs else None

    def __repr__(self) -> str:
        return f"SB3VecEnv({self.venv!r})"
