"""Usable cores: the affinity mask, capped by a cgroup CPU quota (v1 and v2, read from fake cgroup
trees laid out as Docker and systemd lay them out), overridden by ``MODELICAGYM_CORES`` or a
pool's ``cores``."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from step_paths import cartpole_fns

from modelicagym.cores import CORES_VARIABLE, count_cores, stepping_cpus
from modelicagym.errors import ConfigError
from modelicagym.vector import PoolVectorEnv

AFFINITY = len(os.sched_getaffinity(0))


def _tree(tmp_path: Path, proc_lines: str, files: dict[str, str]) -> tuple[Path, Path]:
    root = tmp_path / "cgroup"
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    proc = tmp_path / "proc_cgroup"
    proc.write_text(proc_lines)
    return root, proc


def _count(tmp_path: Path, proc_lines: str, files: dict[str, str], **options: object):
    root, proc = _tree(tmp_path, proc_lines, files)
    return count_cores(environ=options.pop("environ", {}), cgroup_root=root, proc_cgroup=proc, **options)


def test_a_v2_container_quota_caps_the_cores(tmp_path: Path) -> None:
    # docker run --cpus=1.5 on cgroup v2: the container's own cgroup is its root
    count = _count(tmp_path, "0::/\n", {"cpu.max": "150000 100000\n"})
    assert count.quota == 1.5 and count.cores == 1 and count.affinity == AFFINITY
    assert "a cgroup quota of 1.5 CPUs" in str(count)


def test_the_tightest_quota_of_a_v2_cgroup_and_its_ancestors_counts(tmp_path: Path) -> None:
    files = {"cpu.max": "max 100000\n", "user.slice/cpu.max": "100000 100000\n",
             "user.slice/job.scope/cpu.max": "max 100000\n"}
    assert _count(tmp_path, "0::/user.slice/job.scope\n", files).quota == 1.0


def test_a_v1_quota_is_read_from_the_cpu_controller(tmp_path: Path) -> None:
    files = {"cpu,cpuacct/docker/abc/cpu.cfs_quota_us": "100000\n", "cpu,cpuacct/docker/abc/cpu.cfs_period_us":
             "100000\n", "cpu,cpuacct/cpu.cfs_quota_us": "-1\n", "cpu,cpuacct/cpu.cfs_period_us": "100000\n"}
    count = _count(tmp_path, "4:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n", files)
    assert count.quota == 1.0 and count.cores == 1


def test_no_quota_leaves_the_affinity(tmp_path: Path) -> None:
    assert _count(tmp_path, "0::/\n", {"cpu.max": "max 100000\n"}).cores == AFFINITY
    assert _count(tmp_path, "3:cpu,cpuacct:/\n", {"cpu,cpuacct/cpu.cfs_quota_us": "-1\n",
                                                  "cpu,cpuacct/cpu.cfs_period_us": "100000\n"}).quota is None
    assert _count(tmp_path, "0::/gone\n", {}).quota is None  # unreadable: no quota


def test_a_quota_above_the_affinity_leaves_the_affinity(tmp_path: Path) -> None:
    assert _count(tmp_path, "0::/\n", {"cpu.max": f"{100000 * (AFFINITY + 8)} 100000\n"}).cores == AFFINITY


def test_the_variable_and_the_argument_override_what_is_detected(tmp_path: Path) -> None:
    quota = {"cpu.max": "100000 100000\n"}
    by_variable = _count(tmp_path, "0::/\n", quota, environ={CORES_VARIABLE: "16"})
    assert by_variable.cores == 16 and f"{CORES_VARIABLE}=16" in str(by_variable)
    assert _count(tmp_path, "0::/\n", quota, environ={CORES_VARIABLE: "16"}, cores=3).cores == 3


@pytest.mark.parametrize("value", ["two", "0", "-4", "1.5"])
def test_a_bad_variable_is_refused_naming_it(tmp_path: Path, value: str) -> None:
    with pytest.raises(ConfigError, match=CORES_VARIABLE):
        _count(tmp_path, "0::/\n", {}, environ={CORES_VARIABLE: value})


def test_fewer_cores_than_cpus_step_on_as_many_from_the_threads_own() -> None:
    assert stepping_cpus(2, {0, 1, 2, 3}, current=3, idle={}) == (3, 0)
    assert stepping_cpus(1, {2, 5}, current=5, idle={2: 0.5, 5: 0.5}) == (5,)
    assert stepping_cpus(1, {2, 5}, current=7, idle={}) == (2,)  # a CPU outside the mask: from the mask's first


def test_the_idlest_cpus_win_over_the_threads_own() -> None:
    """A second training beside a first that keeps CPU 0 busy takes the free CPU, wherever its
    thread happened to run; CPUs about as idle as each other keep the thread's own first."""
    assert stepping_cpus(1, {0, 1}, current=0, idle={0: 0.02, 1: 0.97}) == (1,)
    assert stepping_cpus(2, {0, 1, 2, 3}, current=0, idle={0: 0.0, 1: 0.9, 2: 0.1, 3: 0.9}) == (1, 3)
    assert stepping_cpus(1, {0, 1}, current=1, idle={0: 0.93, 1: 0.96}) == (1,)


def test_cores_for_every_cpu_of_the_mask_keep_to_none() -> None:
    assert stepping_cpus(4, {0, 1, 2, 3}, current=0) is None
    assert stepping_cpus(16, {0, 1}, current=1) is None


@pytest.mark.processes
def test_a_pool_plans_a_party_per_given_core_whatever_the_machine() -> None:
    """``cores=4`` plans the caller and three workers on any machine (and ``MODELICAGYM_CORES`` the
    same; tests/conftest.py's pools run with what the machine has)."""
    native, _ = cartpole_fns(8)
    with PoolVectorEnv(native, cores=4) as pool:
        assert pool.cores == 4 and pool.num_workers == 3 and pool.layout.envs_in_caller == 2
    with pytest.raises(ConfigError, match="cores must be a whole number"):
        PoolVectorEnv(native, cores=0)
