"""The benchmarks of modelicagym's own parts, run as a maintainer runs them (``python -m benchmarks
...`` from a clone, in a fresh process) with tiny arguments: each prints its table and writes its
JSON. Their figures are not checked — a test never asserts a duration — only that a benchmark
nobody ran lately still works."""

from __future__ import annotations

import importlib.util
import json
import re
import statistics
from pathlib import Path

import pytest
from bench_runs import own_bench, run, run_bench

#: benchmark -> tiny arguments, and top-level keys its JSON must hold
BENCHMARKS = {
    "fmi-calls": (["--steps", "50", "--repeats", "1"], {"seconds_per_step"}),
    "model-exchange": (["--steps", "50", "--python-steps", "5", "--repeats", "1", "--target-steps", "20",
                        "--target-rounds", "3"], {"seconds_per_step", "rate_vs_co_simulation", "target"}),
    "partial-batches": (["--n", "4", "--workers", "2", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "solver-accuracy": (["--repeats", "1"], {"rows"}),
    "autoreset": (["--n", "4", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "load-trial": (["--repeats", "1"], {"seconds", "samples"}),
    "python-reward": (["--n", "4", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "saved-states": (["--calls", "20", "--repeats", "1"], {"cores", "results"}),
    "init-once": (["--n", "2", "--init-seconds", "0.01", "--repeats", "1"], {"cores", "results"}),
    "balance": (["--n", "4", "--settings", "skewed", "--repeats", "1", "--seconds", "0.05"], {"cores", "results"}),
    "barrier": (["--workers", "1", "3", "--steps", "50", "--repeats", "1"], {"usable_cores", "results", "conditions"}),
    "systems": (["--systems", "drive", "--rounds", "1", "--seconds", "0.05", "--warm", "0.05"], {"cores", "results"}),
}


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_benchmark_prints_a_table_and_writes_json(name: str, tmp_path: Path) -> None:
    args, keys = BENCHMARKS[name]
    out = run_bench(own_bench(name), args, tmp_path / "result.json")
    assert "---" in out  # the table's rule
    assert f"wrote {tmp_path / 'result.json'}" in out
    result = json.loads((tmp_path / "result.json").read_text())
    assert keys <= set(result)


def test_the_model_exchange_target_is_a_median_of_paired_ratios(tmp_path: Path) -> None:
    args, _ = BENCHMARKS["model-exchange"]
    out = run_bench(own_bench("model-exchange"), args, tmp_path / "result.json")
    target = json.loads((tmp_path / "result.json").read_text())["target"]
    assert target["row"] == "cvode (native)" and target["rounds"] == 3
    low, high = target["quartiles"]
    assert 0 < low <= target["rate_vs_co_simulation"] <= high
    assert f"median of 3 back-to-back pairs: {target['rate_vs_co_simulation']:.2f}" in out


def test_the_once_per_process_benchmark_times_copies_against_one_env_per_worker(tmp_path: Path) -> None:
    """``once-per-process``: a single env and the pool under both settings, the layouts, and
    the pool's start under both; an FMU without the restriction is refused in one line."""
    from fmu_family import build

    args = [str(build("probe_once", 2)), "--n", "2", "--repeats", "1", "--seconds", "0.05", "--warm", "0",
            "--start-n", "3"]
    out = run_bench(own_bench("once-per-process"), args, tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    [group] = result["results"]
    assert set(group["steps_per_second"]) == {"single", "copies", "one"}
    assert all(len(samples) == 1 for samples in group["samples"].values())
    assert "an FMU that may be instantiated only once per process" in group["layouts"]["one"]
    assert "once per process" not in group["layouts"]["copies"]
    assert result["start"]["n"] == 3 and set(result["start"]["seconds"]) == {"copies", "one"}
    assert "start (make_vec to the first reset's end) at n=3" in out

    command = [*own_bench("once-per-process"), str(build("leaky", 2))]
    refused = run(command, timeout=600)
    assert refused.returncode == 1
    assert "does not declare canBeInstantiatedOnlyOncePerProcess" in refused.stderr.strip().splitlines()[-1]


def test_the_pool_gain_benchmark_tables_each_fmu_against_its_bar(family_fmu, tmp_path: Path) -> None:
    """``pool-gain``: a built-in case and a user's FMU allowed once per process (``--fmu``, its
    config changed by ``--set``), each a row at the bar's n (8; 2 once per process) with the
    rounds' ratios, the bar its measured cost sets, and the pool's layout; the load average at the
    start and the end, in the output and the JSON."""
    from benchmarks.pool_gain import bar

    fmu = family_fmu("probe_once", 2)
    args = ["--cases", "cartpole-user", "--fmu", str(fmu), "--set", "max_episode_steps=40", "--rounds", "2",
            "--seconds", "0.05", "--warm", "0.05"]
    out = run_bench(own_bench("pool-gain"), args, tmp_path / "result.json")
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
    out = run_bench(own_bench("pool-gain"), args, tmp_path / "result.json")
    rows = json.loads((tmp_path / "result.json").read_text())["results"]
    assert [(r["case"], r["n"], r["once_per_process"], r["bar"]) for r in rows] == [
        ("moody-once", 2, True, 1.0), ("moody-100us", 2, False, None)]
    assert rows[1]["met"] is None and re.search(r"^moody held calm.*\s+-\s+-$", out, re.MULTILINE), out
    assert all(r["config"]["parameters"]["threshold"] == 1e9 for r in rows)


@pytest.mark.parametrize("bad, message", [
    (["--rounds", "0"], "pool-gain --rounds: at least 1, got 0"),
    (["--cases"], "pool-gain: nothing to measure: name --cases or give --fmu PATH"),
    (["--cases", "--fmu", "missing.fmu"], "FMU not found: missing.fmu"),
])
def test_the_pool_gain_benchmark_refuses_bad_input_in_one_line(bad: list[str], message: str, tmp_path: Path) -> None:
    command = [*own_bench("pool-gain"), *bad, "--json", str(tmp_path / "r.json")]
    result = run(command, timeout=120, cwd=tmp_path)
    assert result.returncode == 1 and result.stderr.strip().startswith(f"error: {message}"), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "r.json").exists()


def test_the_pool_gain_benchmark_says_where_the_moody_sources_are_outside_a_checkout(monkeypatch, tmp_path) -> None:
    from benchmarks import pool_gain
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
    from benchmarks.pool_gain import bar

    assert bar(single_us, n, once) == expected


@pytest.mark.parametrize("bad, message", [
    (["--rounds", "0"], "systems: --rounds at least 1, --seconds more than 0, --warm at least 0; got 0, 0.3, 8.0"),
    (["--systems", "dcmotor"], "systems: dcmotor is built from OMSimulator's test suite: give --oms"),
    (["--systems", "linear-transformation", "--oms", "missing"], "systems --oms missing: no such folder"),
])
def test_the_systems_benchmark_refuses_bad_input_in_one_line(bad: list[str], message: str, tmp_path: Path) -> None:
    command = [*own_bench("systems"), *bad, "--json", str(tmp_path / "r.json")]
    result = run(command, timeout=120, cwd=tmp_path)
    assert result.returncode == 1 and result.stderr.strip().startswith(f"error: {message}"), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "r.json").exists()


def test_the_systems_benchmark_says_why_ecos_is_not_measured_without_ecospy(tmp_path: Path) -> None:
    """Ecos is a maintainers' comparison: without ``ecospy`` its columns are left out, with a line that says so."""
    if importlib.util.find_spec("ecospy") is not None:
        pytest.skip("ecospy is installed here: its columns are measured")
    args = ["--systems", "drive", "--rounds", "1", "--seconds", "0.05", "--warm", "0.05"]
    out = run_bench(own_bench("systems"), args, tmp_path / "result.json")
    assert out.startswith("Ecos not measured: No module named 'ecospy' (pip install ecospy tbb"), out
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["ecos"] is None
    assert set(result["results"][0]["steps_per_second"]) == {"one env", "one env, held", "pool n=8", "pool n=2"}
