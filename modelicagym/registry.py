"""Front doors: ``make("cartpole")``, ``make_vec("cartpole", n=8)``, and Gymnasium registration.

Environments are known by a short name here and by a Gymnasium id
(``gymnasium.make("ModelicaGym/CartPole-v0")`` after ``import modelicagym``). ``make_vec``
returns the multi-process pool; so does ``gymnasium.make_vec(id)`` through the registered vector
entry point, while ``vectorization_mode="sync"``/``"async"`` still give Gymnasium's own classes.
"""

from __future__ import annotations

import difflib
import importlib
import inspect
from collections.abc import Mapping, Sequence
from dataclasses import fields
from functools import partial
from numbers import Integral
from typing import Any

import gymnasium as gym

from modelicagym.errors import ArgumentError, ArgumentTypeError, ModelicaGymError
from modelicagym.fmu.library_copies import check_instances_per_process
from modelicagym.system import open_model

ENVIRONMENTS: dict[str, tuple[str, str]] = {
    "cartpole": ("ModelicaGym/CartPole-v0", "modelicagym.models.cartpole.env:CartPoleEnv"),
    "cartpole-continuous": ("ModelicaGym/CartPoleContinuous-v0", "modelicagym.models.cartpole.env:CartPoleContinuousEnv"),
    "pendulum": ("ModelicaGym/PendulumSwingUp-v0", "modelicagym.models.pendulum.env:PendulumSwingUpEnv"),
}


class UnknownEnvironmentError(ModelicaGymError, gym.error.UnregisteredEnv):
    """``make``/``make_vec`` got a name no modelicagym environment has (Gymnasium's own error too)."""


#: the vector envs ``make_vec`` can make
BACKENDS = ("pool", "sync", "ray")


def _entry_point(name: str) -> str:
    key = name.lower()
    for short, (gym_id, entry_point) in ENVIRONMENTS.items():
        if key in (short, gym_id.lower()):
            return entry_point
    known = list(ENVIRONMENTS) + [gym_id for gym_id, _ in ENVIRONMENTS.values()]
    close = difflib.get_close_matches(name, known, n=2)
    hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    raise UnknownEnvironmentError(f"no modelicagym environment named {name!r}.{hint} Known: {', '.join(known)}")


def _load(entry_point: str) -> Any:
    module, attribute = entry_point.split(":")
    return getattr(importlib.import_module(module), attribute)


class EnvFactory:
    """A picklable ``() -> env`` for one environment, sent to pool workers.

    ``max_envs_per_process`` tells the pool to keep FMUs that may be instantiated only once per
    process one to a worker (where the config asks for it: ``instances_per_process="one"``);
    ``safe_in_caller`` that its envs (a bundled model's) may run in the calling process, without
    the pool asking a worker first (`modelicagym.vector.env_contract`).
    """

    def __init__(self, entry_point: str, options: dict[str, Any], max_envs_per_process: int | None = None):
        self.entry_point = entry_point
        self.options = options
        self.max_envs_per_process = max_envs_per_process
        self.safe_in_caller = getattr(_load(entry_point), "safe_in_caller", False) is True

    def __call__(self) -> gym.Env:
        return _load(self.entry_point)(**self.options)

    def __repr__(self) -> str:
        return f"EnvFactory({self.entry_point!r}, {self.options!r})"


def make(name: str, **options: Any) -> gym.Env:
    """Create one environment by short name or Gymnasium id, e.g. ``make("cartpole", force=11.0)``.

    Args:
        name: a short name (``"cartpole"``, ``"cartpole-continuous"``, ``"pendulum"``) or its
            Gymnasium id (``"ModelicaGym/CartPole-v0"``, ...); a name close to a known one is
            suggested in the error.
        **options: the environment's options: its class's keyword arguments (e.g. ``force`` for
            the cart-pole) and any `FMUEnvConfig` key (e.g. ``max_episode_steps``).

    Returns:
        The environment itself (no Gymnasium wrappers, so nothing stands between you and the
            FMU); ``gymnasium.make("ModelicaGym/CartPole-v0")`` gives the wrapped one.

    Example::

        import modelicagym

        env = modelicagym.make("cartpole", max_episode_steps=200)
        observation, info = env.reset(seed=0)
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        env.close()
    """
    return _load(_entry_point(name))(**options)


def make_vec(
    name: str | Mapping[str, Any],
    n: int,
    *,
    options_per_env: Sequence[dict[str, Any]] | None = None,
    env_options: Mapping[str, Any] | None = None,
    pool_options: Mapping[str, Any] | None = None,
    backend: str = "pool",
    ray_options: Mapping[str, Any] | None = None,
    **options: Any,
) -> gym.vector.VectorEnv:
    """Create ``n`` environments stepped in parallel by the multi-process pool (or on Ray).

    Options go to every environment, except those named like one of the pool's (the keyword
    arguments of `~modelicagym.vector.PoolVectorEnv`: ``num_workers``, ``autoreset_mode``,
    ``step_timeout``, ``restart_dead_workers``, ``caller_steps``, ...), which configure the pool
    instead. A name both accept is an error: say which you mean with ``env_options`` or
    ``pool_options``, which go only where they say.

    Args:
        name: a short name or Gymnasium id (as for `make`), or an `FMUEnv` config dict
            (``{"fmu": ..., ...}``): any FMU can be pooled.
        n: how many environments.
        options_per_env: ``n`` dicts, the ``i``-th updating the options of environment ``i``
            (e.g. one parameter set per env for domain randomisation). ``None``: every
            environment gets the same options.
        env_options: options for the environments only (for a name the pool also accepts).
        pool_options: options for the pool only (the keyword arguments of
            `~modelicagym.vector.PoolVectorEnv`).
        backend: ``"pool"`` (`~modelicagym.vector.PoolVectorEnv`), ``"sync"`` (Gymnasium's
            ``SyncVectorEnv`` over the same environments; of the pool options only
            ``autoreset_mode`` applies) or ``"ray"`` (`~modelicagym.distributed.RayVectorEnv`:
            the environments in Ray actors, each stepping its share on a local pool that the pool
            options configure).
        ray_options: options of `~modelicagym.distributed.RayVectorEnv` (``backend="ray"``
            only): ``num_actors``, ``cpus_per_actor``, ``address``, ... (`~modelicagym.distributed.RAY_OPTIONS`); given
            among ``options`` they go there too.
        **options: options of every environment (as for `make`), or of the pool (see above).

    Returns:
        The vector env: a `~modelicagym.vector.PoolVectorEnv` with the default ``backend``.

    Raises:
        ArgumentTypeError: ``n`` is not an int.
        ArgumentError: ``n`` below 1, ``options_per_env`` not of ``n`` entries, an unknown
            ``backend``, an unknown pool or Ray option (with the close matches), or a name both the
            environment and the pool accept.

    Example::

        import modelicagym

        envs = modelicagym.make_vec("cartpole", n=4, options_per_env=[{"force": f} for f in (5, 11, 17, 23)])
        observations, infos = envs.reset(seed=0)
        observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
        envs.close()
    """
    from modelicagym.vector.api import POOL_OPTIONS

    if isinstance(n, bool) or not isinstance(n, Integral):
        raise ArgumentTypeError(f"n must be an int, got {type(n).__name__} {n!r}")
    if n < 1:
        raise ArgumentError(f"n must be at least 1, got {n}")
    if options_per_env is not None and len(options_per_env) != n:
        raise ArgumentError(f"options_per_env has {len(options_per_env)} entries for n={n} environments")
    if backend not in BACKENDS:
        raise ArgumentError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    _check_names(pool_options or {}, POOL_OPTIONS, "pool option")
    ray_options = dict(ray_options or {})
    if backend == "ray":
        from modelicagym.distributed.vector_env import RAY_OPTIONS

        _check_names(ray_options, RAY_OPTIONS, "Ray option")
        ray_options.update({key: options.pop(key) for key in [k for k in options if k in RAY_OPTIONS]})
    elif ray_options:
        raise ArgumentError(f"ray_options apply to backend='ray' only, not {backend!r}")
    once_per_process = False
    if isinstance(name, Mapping):
        entry_point, options = "modelicagym.env:FMUEnv", {**name, **options}
        model = open_model(options.get("fmu"), fmus=options.get("fmus"), connections=options.get("connections", ()),
                           loop_breaks=options.get("loop_breaks", ()), validate=options.get("validate", True))
        once_per_process = model.once_per_process(options.get("mode"))
    else:
        entry_point = _entry_point(name)
    env_keys = _env_option_names(_load(entry_point))
    to_pool = {}
    for key in [k for k in options if k in POOL_OPTIONS]:
        if env_keys is not None and key in env_keys:
            raise ArgumentError(f"{key!r} is an option of both the env and the pool: pass it as "
                                f"env_options={{{key!r}: ...}} or pool_options={{{key!r}: ...}}")
        to_pool[key] = options.pop(key)
    if env_keys is not None:
        _check_names({k: v for k, v in options.items() if k not in env_keys}, POOL_OPTIONS, "pool option",
                     only_if_close=True)
    env_fns = []
    for i in range(n):
        env_config = {**options, **(env_options or {}), **(options_per_env[i] if options_per_env else {})}
        env_fns.append(EnvFactory(entry_point, env_config, _envs_per_process(env_config, once_per_process)))
    return _vector_env(backend, env_fns, {**to_pool, **(pool_options or {})}, ray_options)


def _envs_per_process(config: Mapping[str, Any], once_per_process: bool) -> int | None:
    """1 where an env keeps its FMU's one-instance-per-process rule (``instances_per_process="one"``
    on an FMU that declares it), so the pool gives it a worker of its own; else no limit (further
    instances in a process load private copies of the FMU's binary)."""
    setting = check_instances_per_process(config.get("instances_per_process", "copies"))
    return 1 if once_per_process and setting == "one" else None


def _vector_env(
    backend: str, env_fns: list[EnvFactory], pool_options: dict[str, Any], ray_options: dict[str, Any]
) -> gym.vector.VectorEnv:
    """The vector env of ``backend`` over ``env_fns``."""
    from modelicagym.vector import PoolVectorEnv

    if backend == "pool":
        return PoolVectorEnv(env_fns, **pool_options)
    autoreset_mode = pool_options.pop("autoreset_mode", gym.vector.AutoresetMode.NEXT_STEP)
    if backend == "sync":
        if pool_options:
            raise ArgumentError(f"backend='sync' takes no pool options, got {sorted(pool_options)}")
        return gym.vector.SyncVectorEnv(env_fns, autoreset_mode=autoreset_mode)
    from modelicagym.distributed import RayVectorEnv

    init = pool_options.pop("init", "each")  # across actors, not per actor's pool
    return RayVectorEnv(env_fns, autoreset_mode=autoreset_mode, pool_options=pool_options, init=init, **ray_options)


def _env_option_names(env_class: Any) -> set[str] | None:
    """The keyword options ``env_class`` accepts, or ``None`` when it takes any (``**kwargs``)
    that are not an `FMUEnv`'s config keys."""
    from modelicagym.env.config import FMUEnvConfig
    from modelicagym.env.fmu_env import FMUEnv

    parameters = inspect.signature(env_class.__init__).parameters.values()
    names = {p.name for p in parameters if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)} - {"self"}
    if any(p.kind is p.VAR_KEYWORD for p in parameters):
        if not (isinstance(env_class, type) and issubclass(env_class, FMUEnv)):
            return None
        names |= {f.name for f in fields(FMUEnvConfig)}
    return names


def _check_names(given: Mapping[str, Any], known: Sequence[str], what: str, only_if_close: bool = False) -> None:
    """Raise for a name in ``given`` that is not ``known``, suggesting close matches (with
    ``only_if_close``, only for names close to a known one: a misspelt pool option)."""
    for key in given:
        if key in known:
            continue
        close = difflib.get_close_matches(key, known, n=2)
        if close or not only_if_close:
            hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
            raise ArgumentError(f"unknown {what} {key!r}.{hint} {what.capitalize()}s: {', '.join(known)}")


def _vector_entry_point(name: str, num_envs: int = 1, **kwargs: Any) -> gym.vector.VectorEnv:
    return make_vec(name, num_envs, **kwargs)


def register_environments() -> None:
    """Register every environment with Gymnasium (done on ``import modelicagym``)."""
    for gym_id, entry_point in ENVIRONMENTS.values():
        if gym_id not in gym.registry:
            gym.register(id=gym_id, entry_point=entry_point, vector_entry_point=partial(_vector_entry_point, gym_id))
