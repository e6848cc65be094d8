"""Ray, imported on demand, and the connection to a cluster.

Nothing here runs at ``import modelicagym``: Ray is an optional extra (``pip install
'modelicagym[ray]'``) and is imported by the first call that needs it.

Authentication: Ray (>= 2.60) enables token authentication; this module never changes that. A
driver finds the cluster's token where Ray looks for it: ``$RAY_AUTH_TOKEN``, the file named by
``$RAY_AUTH_TOKEN_PATH``, or ``~/.ray/auth_token`` (``ray get-auth-token`` prints it on the head
node).
"""

from __future__ import annotations

import logging
import time
from types import ModuleType

from modelicagym.distributed.errors import RayNotInstalledError

__all__ = ["connect", "format_env_range", "require_ray", "wait_for_free_cpus"]

logger = logging.getLogger(__name__)


def require_ray() -> ModuleType:
    """The ``ray`` module, or a `RayNotInstalledError` that says how to install it."""
    try:
        import ray
    except ImportError as error:
        raise RayNotInstalledError(
            f"this needs Ray, which is not installed ({error}): pip install 'modelicagym[ray]'"
        ) from error
    return ray


def connect(address: str | None = None) -> ModuleType:
    """Connect this process to Ray, unless it already is, and return the ``ray`` module.

    ``address``: ``None`` or ``""`` is ``ray.init()``'s default (the cluster in ``$RAY_ADDRESS``,
    else a new Ray on this machine); ``"auto"`` the cluster already running on this machine;
    ``"HOST:PORT"`` the head node's GCS address. An already connected process keeps its connection
    (``address`` is then ignored, with a debug message), so tests and applications may call
    ``ray.init`` themselves with any options. The connection lasts until ``ray.shutdown()`` or the
    end of the process.
    """
    ray = require_ray()
    if ray.is_initialized():
        if address:
            logger.debug("already connected to Ray; not connecting to %r", address)
        return ray
    ray.init(address=address or None, logging_level=logging.WARNING, log_to_driver=True)
    logger.info("connected to Ray: %s CPUs on %d node(s)", ray.cluster_resources().get("CPU", 0), len(ray.nodes()))
    return ray


def wait_for_free_cpus(cpus: float, timeout: float) -> bool:
    """Wait up to ``timeout`` seconds until the connected cluster has ``cpus`` CPUs free (Ray
    releases a killed actor's CPUs asynchronously); True if it has."""
    ray = require_ray()
    deadline = time.monotonic() + timeout
    while ray.available_resources().get("CPU", 0.0) < cpus:
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.02)
    return True


def format_env_range(indices: range | list[int] | tuple[int, ...]) -> str:
    """``envs 4-7`` / ``env 3``: how messages name a contiguous run of env indices."""
    indices = list(indices)
    if len(indices) == 1:
        return f"env {indices[0]}"
    if indices == list(range(indices[0], indices[-1] + 1)):
        return f"envs {indices[0]}-{indices[-1]}"
    return f"envs {', '.join(map(str, indices))}"
