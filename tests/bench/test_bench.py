"""The benchmarks, run as the README runs them (``modelicagym bench ...`` in a fresh process) with
tiny arguments: each prints its table and writes its JSON. Their figures are not checked — a
test never asserts a duration — only that a benchmark nobody ran lately still works."""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

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
    "balance": (["--n", "4", "--settings", "skewed", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
}


def test_the_training_benchmark_trains_every_vector_env(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3", reason="the rl extra is not installed: pip install torch==2.13.0, "
                        "then pip install 'modelicagym[rl]'")
    args = ["--models", "cartpole", "pendulum", "--n", "2", "--threads", "1", "--repeats", "1", "--steps", "64"]
    out = run_bench("training", args, tmp_path / "result.json")
    for candidate in ("pool", "sync", "async", "dummy", "subproc"):
        assert f" {candidate} " in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert [r["model"] for r in result["results"]] == ["cartpole", "pendulum"]
    assert set(result["results"][1]["results"]) == {"pool", "sync", "async", "dummy", "subproc"}


def run_bench(name: str, args: list[str], json_path: Path) -> str:
    command = [sys.executable, "-m", "modelicagym.cli", "bench", name, *args, "--json", str(json_path)]
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
