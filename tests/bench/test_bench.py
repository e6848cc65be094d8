"""The benchmarks a user runs, run as a user runs them (``modelicagym bench ...`` in a fresh process)
with tiny arguments: each prints its table and writes its JSON. Their figures are not checked — a
test never asserts a duration — only that a benchmark nobody ran lately still works. Those of
modelicagym's own parts are tested in ``tests/benchmarks/``."""

from __future__ import annotations

import json
import re
import statistics
import sys
from pathlib import Path

import pytest
from bench_runs import run, run_bench, user_bench
from extras import requires

from modelicagym.cores import usable_cores

#: benchmark -> tiny arguments, and top-level keys its JSON must hold
BENCHMARKS = {
    "throughput": (["--n", "2", "--settings", "default", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "shared": (["--n", "2", "--settings", "light", "--repeats", "1", "--seconds", "0.05"],
               {"cores", "results", "targets"}),
}


@requires("rl")
def test_the_training_benchmark_trains_every_vector_env(tmp_path: Path) -> None:
    args = ["--models", "cartpole", "pendulum", "--n", "2", "--threads", "1", "--repeats", "1", "--steps", "64"]
    out = run_bench(user_bench("training"), args, tmp_path / "result.json")
    for candidate in ("pool", "sync", "async", "dummy", "subproc"):
        assert f" {candidate} " in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert [r["model"] for r in result["results"]] == ["cartpole", "pendulum"]
    assert set(result["results"][1]["results"]) == {"pool", "sync", "async", "dummy", "subproc"}


def test_the_training_benchmark_over_seeds_tables_each_preset(tmp_path: Path) -> None:
    """``--seeds``: every run in the JSON with its curve, per preset the seeds that solved and the
    spread, and the conditions a reader needs to compare (threads, versions, load)."""
    pytest.importorskip("stable_baselines3", reason="the rl extra is not installed: pip install torch==2.13.0, "
                        "then pip install 'modelicagym[rl]'")
    args = ["--seeds", "2", "--models", "pendulum", "--algorithms", "ppo", "sac", "--budget", "800",
            "--eval-episodes", "1"]
    out = run_bench(user_bench("training"), args, tmp_path / "result.json")
    assert re.search(r"^pendulum\s+ppo\s+800\s+[0-2]/2 ", out, re.MULTILINE), out
    assert re.search(r"^pendulum\s+sac\s+800\s+[0-2]/2 ", out, re.MULTILINE), out
    assert "1 torch thread per run, 2 runs at once" in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert [(r["algorithm"], r["seed"]) for r in result["runs"]] == [("ppo", 0), ("ppo", 1), ("sac", 0), ("sac", 1)]
    assert all(r["curve"] and len(r["eval_returns"]) == 1 for r in result["runs"])
    assert [(s["algorithm"], s["seeds"]) for s in result["summaries"]] == [("ppo", [0, 1]), ("sac", [0, 1])]
    assert result["torch_threads"] == 1 and {"torch", "stable-baselines3"} <= set(result["versions"])
    assert result["cores"] == usable_cores() and len(result["load_average"]["before"]) == 3


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_benchmark_prints_a_table_and_writes_json(name: str, tmp_path: Path) -> None:
    args, keys = BENCHMARKS[name]
    out = run_bench(user_bench(name), args, tmp_path / "result.json")
    assert "---" in out  # the table's rule
    assert f"wrote {tmp_path / 'result.json'}" in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert keys <= set(result)


def _processes_with(marker: str) -> list[int]:
    """Pids of the processes whose command line holds ``marker``."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and marker in (entry / "cmdline").read_bytes().decode(errors="replace"):
                found.append(int(entry.name))
        except OSError:
            continue
    return found


def test_the_shared_machine_benchmark_leaves_no_load_behind(tmp_path: Path) -> None:
    from modelicagym.bench.shared_machine import BUSY_MARKER

    args = ["--loads", "busy", "two", "--n", "2", "--settings", "light", "user", "--repeats", "2", "--seconds", "0.05"]
    run_bench(user_bench("shared"), args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    assert [(group["load"], group["setting"]) for group in result["results"]] == [
        ("busy", "light"), ("busy", "user"), ("two", "light"), ("two", "user")]
    user = result["results"][1]  # a user's FMU: the default pool isolates it, "caller" is the opt-in
    assert "0/2 envs in the calling process" in user["layouts"]["pool"]
    assert "0/2 envs in the calling process" not in user["layouts"]["caller"]
    assert "caller" in result["results"][3]["steps_per_second"]
    two = result["results"][2]
    assert len(two["pairs"]["pool"]) == 2 and all(len(pair) == 2 for pair in two["pairs"]["pool"])
    assert two["steps_per_second"]["pool"] == statistics.median(map(sum, two["pairs"]["pool"]))  # the pair's sum
    assert _processes_with(BUSY_MARKER) == [] and _processes_with("modelicagym.bench.shared_machine") == []


@pytest.mark.parametrize(("name", "settings"), [("leaky", {}), ("probe_once", {}),
                                              ("probe_once", {"instances_per_process": "one"})])
def test_the_fmu_benchmark_measures_a_users_fmu_and_names_its_step_path(name: str, settings: dict[str, str],
                                                                       tmp_path: Path) -> None:
    """``bench fmu`` on a test FMU, its config as ``info`` suggests it changed by ``--config``; an
    FMU allowed once per process gets a SyncVectorEnv (further instances load copies of its binary)
    unless its config keeps one instance per process: then none (it would hold two), and it says why."""
    from fmu_family import build

    (tmp_path / "config.json").write_text(json.dumps({"max_episode_steps": 40, **settings}))
    args = [str(build(name, 2)), "--config", str(tmp_path / "config.json"), "--n", "2", "--repeats", "1",
            "--seconds", "0.05"]
    out = run_bench(user_bench("fmu"), args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    assert {"fmu", "model", "fmi_version", "step_path", "config", "cores", "load_average", "wake_round_trip_us",
            "guest_halt_poll_ns", "results"} <= set(result)
    assert result["config"]["max_episode_steps"] == 40
    path = result["step_path"]
    assert f"single env: {path['path']} ({path['reason']})" in out
    [group] = result["results"]
    one_per_process = settings.get("instances_per_process") == "one"
    measured = {"single", "async", "pool"} | (set() if one_per_process else {"sync"})
    assert set(group["steps_per_second"]) == measured and all(v > 0 for v in group["steps_per_second"].values())
    assert ("sync" in group["skipped"]) == one_per_process
    pool_paths = group["pool"]["step_paths"]
    assert sum(p["envs"] for p in pool_paths) == 2
    for p in pool_paths:
        assert f"pool n=2: {p['envs']} env(s) {p['path']} ({p['reason']})" in out
    assert {"wall_s", "fmu_s", "env_python_s", "pool_overhead_s"} <= set(group["pool"]["timing"])
    assert group["pool"]["plain_layout"] in out and group["pool"]["layout_reason"] in group["pool"]["layout"]
    assert group["pool"]["plain_layout"].startswith("pool n=2: ") and "stand-in" not in group["pool"]["plain_layout"]
    assert f"random actions sampled in: {result['action_bounds']}" in out
    single = group["single_time"]
    assert 0 < single["fmu_us"] < single["wall_us"]


def test_the_fmu_benchmark_logs_its_progress_without_tqdm(monkeypatch: pytest.MonkeyPatch,
                                                           caplog: pytest.LogCaptureFixture) -> None:
    from modelicagym.bench.own_fmu import progress_reporter

    monkeypatch.setitem(sys.modules, "tqdm", None)
    with caplog.at_level("INFO", logger="modelicagym.bench.own_fmu"), progress_reporter(2) as progress:
        progress("n=2: envs made")
        progress("n=2, single: calibrated")
    assert [r.getMessage() for r in caplog.records] == ["[1/2] n=2: envs made", "[2/2] n=2, single: calibrated"]


def test_the_fmu_benchmark_draws_no_bar_into_a_log(monkeypatch: pytest.MonkeyPatch,
                                                  caplog: pytest.LogCaptureFixture) -> None:
    """With tqdm installed, but stderr a pipe or a file (not a terminal): log lines, no bar."""
    import io

    from modelicagym.bench.own_fmu import _tqdm, progress_reporter

    if _tqdm() is None:
        pytest.skip("tqdm (the progress extra) is not installed")
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    with caplog.at_level("INFO", logger="modelicagym.bench.own_fmu"), progress_reporter(1) as progress:
        progress("n=2: envs made")
    assert [r.getMessage() for r in caplog.records] == ["[1/1] n=2: envs made"] and sys.stderr.getvalue() == ""


def test_the_fmu_benchmark_names_the_bounds_it_samples_in() -> None:
    from modelicagym.bench.own_fmu import bounds_line

    config = {"inputs": ["u", "T_amb", "valve"], "action_bounds": {"u": (0.0, 1.0), "valve": (-1.0, 1.0)}}
    assert bounds_line(config, ("valve",)) == (
        "u in [0, 1]; valve in [-1, 1] (assumed: nothing in the FMU says its range; give action_bounds with --set); "
        "T_amb in the range the FMU declares")


def test_the_fmu_benchmark_refuses_no_envs_in_one_line(tmp_path: Path) -> None:
    result = run([*user_bench("fmu"), "any.fmu", "--n", "2", "0", "--json", str(tmp_path / "result.json")],
                 timeout=120)
    assert result.returncode == 1 and result.stderr.strip() == "error: bench fmu --n: at least 1, got 0"
    assert not (tmp_path / "result.json").exists()


def test_the_step_paths_benchmark_times_any_fmu_on_both_paths(family_fmu, tmp_path: Path) -> None:
    args = [str(family_fmu("probe", 3)), "--time-step", "0.1", "--steps", "50", "--repeats", "1"]
    out = run_bench(user_bench("step-paths"), args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    assert set(result["seconds_per_step"]) == {"C loop", "FMUEnv.step (native)", "FMUEnv.step (python)"}
    assert result["inputs"][:5] == ["gear", "mode", "enable", "boost", "force"]
    assert "native env step / C loop" in out
