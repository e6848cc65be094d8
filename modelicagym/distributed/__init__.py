"""Beyond one machine: envs and sweeps on a Ray cluster (the optional ``modelicagym[ray]`` extra).

* `RayVectorEnv` (``modelicagym.make_vec(name, n, backend="ray")``): a Gymnasium vector env whose
  envs live in Ray actors, each stepping its slice on a local pool, with a ``rollout`` call that
  ships a policy once and returns ``T`` steps as arrays;
* the building blocks of `modelicagym.experiments.RayRunner` (``modelicagym reproduce --ray``),
  which runs a sweep's (setting, repeat) groups as Ray tasks.

Ray is imported when first needed, never by ``import modelicagym``; without it these raise
`RayNotInstalledError`. Layers: ``cluster`` (import and connect), ``host`` (the actor),
``vector_env``; errors in ``errors``. Nothing here imports the experiments.
"""

from modelicagym.distributed.cluster import connect, require_ray
from modelicagym.distributed.errors import ActorDiedError, ClusterError, RayNotInstalledError, SweepGroupError
from modelicagym.distributed.host import Rollout
from modelicagym.distributed.vector_env import RAY_OPTIONS, RayVectorEnv

__all__ = [
    "RAY_OPTIONS",
    "ActorDiedError",
    "ClusterError",
    "RayNotInstalledError",
    "RayVectorEnv",
    "Rollout",
    "SweepGroupError",
    "connect",
    "require_ray",
]
