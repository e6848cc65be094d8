"""The cores this process may use: its CPU affinity, capped by a cgroup CPU quota, or what the user says.

A pool plans one stepping process per usable core, so this number must be the machine as the
process sees it, not as the host has it: a container started with ``--cpus=2`` on a 64-core host
may run on all 64 cores (its affinity) but gets two cores' worth of time every scheduling period
(its quota). Twenty processes stepping in lockstep there would each be throttled for the rest of
the period, and a synchronous step waits for the last of them. The quota counts whole cores,
rounded down (at least one): a process beyond the quota's share is the one that waits.

``MODELICAGYM_CORES`` (and a pool's ``cores`` argument, which wins over it) overrides what is
detected, in both directions: fewer cores leave room for other work, more let a 2-core machine
plan what a 16-core one would.

Where the usable cores are fewer than the CPUs of the affinity mask, a pool keeps its stepping
processes on that many CPUs (`stepping_cpus`): inside a 1-CPU quota on two CPUs, a hand-over
between two processes on different CPUs wakes an idle CPU that the quota cannot use anyway.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from modelicagym.errors import ConfigError

__all__ = ["CORES_VARIABLE", "CoreCount", "count_cores", "current_cpu", "stepping_cpus", "usable_cores"]

#: the environment variable that overrides the detected cores
CORES_VARIABLE = "MODELICAGYM_CORES"

_CGROUP_ROOT = Path("/sys/fs/cgroup")
_PROC_CGROUP = Path("/proc/self/cgroup")
_THREAD_STAT = Path("/proc/thread-self/stat")
_CPU_ROOT = Path("/sys/devices/system/cpu")
#: seconds over which a pool that keeps to fewer CPUs than its mask has reads which are idle
IDLE_WINDOW = 0.01


@dataclass(frozen=True)
class CoreCount:
    """The usable cores and where the number comes from (for messages and benchmarks)."""

    #: the cores a pool plans for
    cores: int
    #: the CPUs in this process's affinity mask
    affinity: int
    #: the cgroup CPU quota in cores (``None``: no quota), before rounding
    quota: float | None
    #: what overrode the detected number (``""``: nothing did)
    override: str = ""

    def __str__(self) -> str:
        if self.override:
            return f"{self.cores} cores ({self.override}; detected: {self._detected()})"
        return f"{self.cores} cores ({self._detected()})"

    def _detected(self) -> str:
        quota = "" if self.quota is None else f", a cgroup quota of {self.quota:g} CPUs"
        return f"{self.affinity} CPUs in the affinity mask{quota}"


def usable_cores(cores: int | None = None) -> int:
    """The cores a pool may use: ``cores`` if given, else ``MODELICAGYM_CORES``, else the CPUs this
    process may run on, capped by its cgroup CPU quota (at least 1)."""
    return count_cores(cores).cores


def count_cores(
    cores: int | None = None,
    environ: dict[str, str] | None = None,
    cgroup_root: Path = _CGROUP_ROOT,
    proc_cgroup: Path = _PROC_CGROUP,
) -> CoreCount:
    """`usable_cores` with its reasons; ``environ``, ``cgroup_root`` and ``proc_cgroup`` are for
    tests (a fake cgroup tree)."""
    environ = os.environ if environ is None else environ
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    quota = cgroup_quota(cgroup_root, proc_cgroup)
    detected = affinity if quota is None else max(1, min(affinity, math.floor(quota)))
    if cores is not None:
        return CoreCount(_checked(cores, "cores"), affinity, quota, f"cores={cores} was given")
    if environ.get(CORES_VARIABLE, "").strip():
        value = environ[CORES_VARIABLE].strip()
        try:
            given = int(value)
        except ValueError:
            raise ConfigError(f"{CORES_VARIABLE}={value!r} is not a whole number of cores (e.g. {CORES_VARIABLE}="
                              f"{detected}; unset it to use what is detected: {detected})") from None
        return CoreCount(_checked(given, CORES_VARIABLE), affinity, quota, f"{CORES_VARIABLE}={given}")
    return CoreCount(detected, affinity, quota)


def stepping_cpus(
    cores: int, mask: set[int] | None = None, current: int | None = None, idle: dict[int, float] | None = None
) -> tuple[int, ...] | None:
    """The CPUs a pool of ``cores`` usable cores keeps its stepping processes on: ``None`` where
    ``cores`` covers the calling thread's affinity ``mask`` (they run anywhere in it), else the
    ``cores`` CPUs of the mask that were idlest over the last `IDLE_WINDOW` seconds (``idle``: each
    CPU's idle share, read when not given; a pool beside another pool on a busy CPU takes a free
    one), the CPU the thread runs on now first among equals (``current``; read when not given),
    then the mask's order from there."""
    mask = os.sched_getaffinity(0) if mask is None else mask
    if cores >= len(mask):
        return None
    cpus = sorted(mask)
    current = current_cpu() if current is None else current
    start = cpus.index(current) if current in cpus else 0
    ordered = cpus[start:] + cpus[:start]
    idle = _idle_shares(ordered) if idle is None else idle
    return tuple(sorted(ordered, key=lambda cpu: -round(idle.get(cpu, 0.0), 1))[:cores])


def _idle_shares(cpus: list[int], window: float | None = None) -> dict[int, float]:
    """Each CPU's idle share over ``window`` seconds (`IDLE_WINDOW`), from the time it spent in its
    idle states (``/sys/devices/system/cpu/cpuN/cpuidle``, in µs); empty where that cannot be read."""
    window = IDLE_WINDOW if window is None else window
    before = _idle_us(cpus)
    if before is None:
        return {}
    start = time.monotonic()
    time.sleep(window)
    after, elapsed_us = _idle_us(cpus), (time.monotonic() - start) * 1e6
    if after is None:
        return {}
    return {cpu: min(1.0, (after[cpu] - before[cpu]) / elapsed_us) for cpu in cpus}


def _idle_us(cpus: list[int]) -> dict[int, int] | None:
    """Microseconds each CPU spent idle since boot, or ``None`` where one cannot be read."""
    total = {}
    for cpu in cpus:
        times = [_read(state / "time") for state in (_CPU_ROOT / f"cpu{cpu}" / "cpuidle").glob("state*")]
        if not times or not all(t.isdigit() for t in times):
            return None
        total[cpu] = sum(int(t) for t in times)
    return total


def current_cpu() -> int | None:
    """The CPU the calling thread runs on now (field 39 of ``/proc/thread-self/stat``), or ``None``."""
    stat = _read(_THREAD_STAT)
    try:
        return int(stat[stat.rindex(")") + 2:].split()[36])
    except (ValueError, IndexError):
        return None


def _checked(cores: int, name: str) -> int:
    if isinstance(cores, bool) or not isinstance(cores, int) or cores < 1:
        raise ConfigError(f"{name} must be a whole number of cores >= 1, got {cores!r}")
    return cores


def cgroup_quota(cgroup_root: Path = _CGROUP_ROOT, proc_cgroup: Path = _PROC_CGROUP) -> float | None:
    """The tightest CPU quota, in CPUs, on this process's cgroup and its ancestors (cgroup v2's
    ``cpu.max``, v1's ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``); ``None`` without one."""
    try:
        lines = proc_cgroup.read_text().splitlines()
    except OSError:
        return None
    quotas = []
    for line in lines:
        _, controllers, path = line.split(":", 2)
        if controllers == "":  # v2: one unified hierarchy
            quotas += [_v2_quota(folder) for folder in _folders(cgroup_root, path)]
        elif "cpu" in controllers.split(","):
            for mount in (cgroup_root / controllers, cgroup_root / "cpu", cgroup_root / "cpu,cpuacct"):
                quotas += [_v1_quota(folder) for folder in _folders(mount, path)]
    quotas = [quota for quota in quotas if quota is not None]
    return min(quotas) if quotas else None


def _folders(mount: Path, path: str) -> list[Path]:
    """The cgroup's folder under ``mount`` and its ancestors up to the mount (a container usually
    sees its own cgroup as the root: its path is then "/")."""
    folder = mount / path.strip("/")
    folders = [folder, *folder.parents]
    return [f for f in folders if f == mount or mount in f.parents]


def _v2_quota(folder: Path) -> float | None:
    fields = _read(folder / "cpu.max").split()
    if len(fields) != 2 or fields[0] == "max":
        return None
    return _ratio(fields[0], fields[1])


def _v1_quota(folder: Path) -> float | None:
    quota, period = _read(folder / "cpu.cfs_quota_us"), _read(folder / "cpu.cfs_period_us")
    return _ratio(quota, period) if quota and period and not quota.startswith("-") else None


def _ratio(quota: str, period: str) -> float | None:
    try:
        quota_us, period_us = int(quota), int(period)
    except ValueError:
        return None
    return quota_us / period_us if quota_us > 0 and period_us > 0 else None


def _read(path: Path) -> str:
    try:
        return path.read_text().strip()
    except OSError:
        return ""
