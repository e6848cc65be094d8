"""The benchmarks, run as a user runs them (``modelicagym bench ...`` in a fresh process) with
tiny arguments: each prints its table and writes its JSON. Their figures are not checked — a
test never asserts a duration — only that a benchmark nobody ran lately still works."""

from __future__ import annotations

import json
import re
import statistics
import subprocess
import sys
from pathlib import Path

import pytest
from extras import requires

from modelicagym.bench import INTERNAL_BENCHMARKS
from modelicagym.cores import usable_cores

#: benchmark -> tiny arguments, and top-level keys its JSON must hold
BENCHMARKS = {
    "fmi-calls": (["--steps", "50", "--repeats", "1"], {"seconds_per_step"}),
    "model-exchange": (["--steps", "50", "--python-steps", "5", "--repeats", "1", "--target-steps", "20",
                        "--target-rounds", "3"], {"seconds_per_step", "rate_vs_co_simulation", "target"}),
    "throughput": (["--n", "2", "--settings", "default", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "shared": (["--n", "2", "--settings", "light", "--repeats", "1", "--seconds", "0.05"],
               {"cores", "results", "targets"}),
    "partial-batches": (["--n", "4", "--workers", "2", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "solver-accuracy": (["--repeats", "1"], {"rows"}),
    "autoreset": (["--n", "4", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "load-trial": (["--repeats", "1"], {"seconds", "samples"}),
    "python-reward": (["--n", "4", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "saved-states": (["--calls", "20", "--repeats", "1"], {"cores", "results"}),
    "init-once": (["--n", "2", "--init-seconds", "0.01", "--repeats", "1"], {"cores", "results"}),
    "balance": (["--n", "4", "--settings", "skewed", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "barrier": (["--workers", "1", "3", "--steps", "50", "--repeats", "1"], {"usable_cores", "results", "conditions"}),
}


@requires("rl")
def test_the_training_benchmark_trains_every_vector_env(tmp_path: Path) -> None:
    args = ["--models", "cartpole", "pendulum", "--n", "2", "--threads", "1", "--repeats", "1", "--steps", "64"]
    out = run_bench("training", args, tmp_path / "result.json")
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
    out = run_bench("training", args, tmp_path / "result.json")
    assert re.search(r"^pendulum\s+ppo\s+800\s+[0-2]/2 ", out, re.MULTILINE), out
    assert re.search(r"^pendulum\s+sac\s+800\s+[0-2]/2 ", out, re.MULTILINE), out
    assert "1 torch thread per run, 2 runs at once" in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert [(r["algorithm"], r["seed"]) for r in result["runs"]] == [("ppo", 0), ("ppo", 1), ("sac", 0), ("sac", 1)]
    assert all(r["curve"] and len(r["eval_returns"]) == 1 for r in result["runs"])
    assert [(s["algorithm"], s["seeds"]) for s in result["summaries"]] == [("ppo", [0, 1]), ("sac", [0, 1])]
    assert result["torch_threads"] == 1 and {"torch", "stable-baselines3"} <= set(result["versions"])
    assert result["cores"] == usable_cores() and len(result["load_average"]["before"]) == 3


def bench_command(name: str) -> list[str]:
    """``modelicagym bench NAME``, or ``bench internals NAME`` for a benchmark of modelicagym's own parts."""
    internal = name in {internal for internal, _, _ in INTERNAL_BENCHMARKS}
    return [sys.executable, "-m", "modelicagym.cli", "bench", *(["internals"] if internal else []), name]


def run_bench(name: str, args: list[str], json_path: Path) -> str:
    command = [*bench_command(name), *args, "--json", str(json_path)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"bench {name} failed:\n{result.stdout}\n{result.stderr}"
    return result.stdout


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_benchmark_prints_a_table_and_writes_json(name: str, tmp_path: Path) -> None:
    args, keys = BENCHMARKS[name]
    out = run_bench(name, args, tmp_path / "result.json")
    assert "---" in out  # the table's rule
    assert f"wrote {tmp_path / 'result.json'}" in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert keys <= set(result)


def test_the_model_exchange_target_is_a_median_of_paired_ratios(tmp_path: Path) -> None:
    args, _ = BENCHMARKS["model-exchange"]
    out = run_bench("model-exchange", args, tmp_path / "result.json")
    target = json.loads((tmp_path / "result.json").read_text())["target"]
    assert target["row"] == "cvode (native)" and target["rounds"] == 3
    low, high = target["quartiles"]
    assert 0 < low <= target["rate_vs_co_simulation"] <= high
    assert f"median of 3 back-to-back pairs: {target['rate_vs_co_simulation']:.2f}" in out


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
    run_bench("shared", args, tmp_path / "result.json")
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
    out = run_bench("fmu", args, tmp_path / "result.json")
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
    assert group["pool"]["layout"] in out and group["pool"]["layout_reason"] in group["pool"]["layout"]
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


def test_the_fmu_benchmark_refuses_no_envs_in_one_line(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "modelicagym.cli", "bench", "fmu", "any.fmu", "--n", "2", "0",
               "--json", str(tmp_path / "result.json")]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 1 and result.stderr.strip() == "error: bench fmu --n: at least 1, got 0"
    assert not (tmp_path / "result.json").exists()


def test_the_step_paths_benchmark_times_any_fmu_on_both_paths(family_fmu, tmp_path: Path) -> None:
    args = [str(family_fmu("probe", 3)), "--time-step", "0.1", "--steps", "50", "--repeats", "1"]
    out = run_bench("step-paths", args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    assert set(result["seconds_per_step"]) == {"C loop", "FMUEnv.step (native)", "FMUEnv.step (python)"}
    assert result["inputs"][:5] == ["gear", "mode", "enable", "boost", "force"]
    assert "native env step / C loop" in out


def test_the_once_per_process_benchmark_times_copies_against_one_env_per_worker(tmp_path: Path) -> None:
    """``bench once-per-process``: a single env and the pool under both settings, the layouts, and
    the pool's start under both; an FMU without the restriction is refused in one line."""
    from fmu_family import build

    args = [str(build("probe_once", 2)), "--n", "2", "--repeats", "1", "--seconds", "0.05", "--warm", "0",
            "--start-n", "3"]
    out = run_bench("once-per-process", args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    [group] = result["results"]
    assert set(group["steps_per_second"]) == {"single", "copies", "one"}
    assert all(len(samples) == 1 for samples in group["samples"].values())
    assert "an FMU that may be instantiated only once per process" in group["layouts"]["one"]
    assert "once per process" not in group["layouts"]["copies"]
    assert result["start"]["n"] == 3 and set(result["start"]["seconds"]) == {"copies", "one"}
    assert "start (make_vec to the first reset's end) at n=3" in out

    command = [*bench_command("once-per-process"), str(build("leaky", 2))]
    refused = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert refused.returncode == 1
    assert "does not declare canBeInstantiatedOnlyOncePerProcess" in refused.stderr.strip().splitlines()[-1]


def test_the_pool_gain_benchmark_tables_each_fmu_against_its_bar(family_fmu, tmp_path: Path) -> None:
    """``bench pool-gain``: a built-in case and a user's FMU allowed once per process (``--fmu``, its
    config changed by ``--set``), each a row at the bar's n (8; 2 once per process) with the
    rounds' ratios, the bar its measured cost sets, and the pool's layout; the load average at the
    start and the end, in the output and the JSON."""
    from modelicagym.bench.pool_gain import bar

    fmu = family_fmu("probe_once", 2)
    args = ["--cases", "cartpole-user", "--fmu", str(fmu), "--set", "max_episode_steps=40", "--rounds", "2",
            "--seconds", "0.05", "--warm", "0.05"]
    out = run_bench("pool-gain", args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    assert {"cores", "load_average", "rounds", "seconds", "warm", "results"} <= set(result)
    assert len(result["load_average"]["before"]) == len(result["load_average"]["after"]) == 3
    assert out.startswith("load average at the start: ") and "load average (1 min) before " in out
    rows = result["results"]
    assert [(r["case"], r["n"], r["once_per_process"]) for r in rows] == [("cartpole-user", 8, False),
                                                                          (fmu.stem, 2, True)]
    assert rows[1]["fmu"] == str(fmu) and rows[1]["config"]["max_episode_steps"] == 40 and rows[1]["bar"] == 1.0
    for r in rows:
        assert len(r["ratios"]) == len(r["single_steps_per_second"]) == len(r["pool_steps_per_second"]) == 2
        assert r["median"] == statistics.median(r["ratios"])
        assert r["bar"] == bar(r["single_us"], r["n"], r["once_per_process"])
        assert r["met"] == (r["median"] >= r["bar"])
        ratios = " ".join(f"{x:.2f}" for x in r["ratios"])
        assert re.search(rf"^{re.escape(r['label'])} \([\d.,]+ us\)\s+{r['n']}\s+{r['median']:.2f}x \({ratios}\)"
                         rf"\s+>= {r['bar']:.1f}\s+{'yes' if r['met'] else 'no'}$", out, re.MULTILINE), out
        assert f"{r['label']}, n={r['n']}: {r['layout']}" in out


def test_the_pool_gain_benchmark_builds_the_moody_cases_and_sets_no_bar_off_the_bars_n(tmp_path: Path) -> None:
    """The moody FMU, allowed once per process or not, built from the checkout; ``--n`` replaces the
    bar's n, and a row with no bar says so ("-")."""
    args = ["--cases", "moody-once", "moody-100us", "--n", "2", "--rounds", "1", "--seconds", "0.05", "--warm", "0"]
    out = run_bench("pool-gain", args, tmp_path / "result.json")
    rows = json.loads((tmp_path / "result.json").read_text())["results"]
    assert [(r["case"], r["n"], r["once_per_process"], r["bar"]) for r in rows] == [
        ("moody-once", 2, True, 1.0), ("moody-100us", 2, False, None)]
    assert rows[1]["met"] is None and re.search(r"^moody held calm.*\s+-\s+-$", out, re.MULTILINE), out
    assert all(r["config"]["parameters"]["threshold"] == 1e9 for r in rows)


@pytest.mark.parametrize("bad, message", [
    (["--rounds", "0"], "bench internals pool-gain --rounds: at least 1, got 0"),
    (["--cases"], "bench internals pool-gain: nothing to measure: name --cases or give --fmu PATH"),
    (["--cases", "--fmu", "missing.fmu"], "FMU not found: missing.fmu"),
])
def test_the_pool_gain_benchmark_refuses_bad_input_in_one_line(bad: list[str], message: str, tmp_path: Path) -> None:
    command = [*bench_command("pool-gain"), *bad, "--json", str(tmp_path / "r.json")]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 1 and result.stderr.strip().startswith(f"error: {message}"), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "r.json").exists()


def test_the_pool_gain_benchmark_says_where_the_moody_sources_are_outside_a_checkout(monkeypatch, tmp_path) -> None:
    from modelicagym.bench import pool_gain
    from modelicagym.errors import ConfigError

    monkeypatch.setattr(pool_gain, "MOODY_SOURCES", tmp_path / "tests" / "fmus" / "moody")
    with pytest.raises(ConfigError, match=r"run from a checkout of modelicagym, or leave them out"):
        pool_gain.CASES["moody-once"].config()


@pytest.mark.parametrize("single_us, n, once, expected", [
    (2.8, 8, False, 1.0), (19.9, 8, False, 1.0), (20.0, 8, False, 1.5), (999.0, 8, False, 1.5),
    (1000.0, 8, False, 1.8), (100.0, 8, True, 1.5), (100.0, 2, True, 1.0), (100.0, 2, False, None),
    (1000.0, 64, False, None)])
def test_the_pool_gain_bar_follows_the_single_envs_cost(single_us: float, n: int, once: bool,
                                                       expected: float | None) -> None:
    """At n=8: >= 1.8x from 1 ms a step, >= 1.5x from 20 us, else >= 1.0x; once per process at n=2:
    >= 1.0x; no bar at another n."""
    from modelicagym.bench.pool_gain import bar

    assert bar(single_us, n, once) == expected
