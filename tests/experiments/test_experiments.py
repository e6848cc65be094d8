"""Tests of the sweep machinery: configs, runs, result files, resume, atomic writes, report, CLI.

The runs use a stand-in for the cart-pole FMU env (gymnasium's CartPole with the same options,
observation convention and rewards) so they test this package alone, fast.
"""

from __future__ import annotations

import csv
import json
import logging
import sys
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from extras import requires
from toy_envs import counter, drift

import modelicagym
from modelicagym.agents import QLearningAgent
from modelicagym.cores import usable_cores
from modelicagym.errors import DataError
from modelicagym.experiments import (
    PAPER_SWEEPS,
    ConfigError,
    Setting,
    SettingSummary,
    SweepConfig,
    load_config,
    main,
    moving_average,
    read_sweep,
    render_report,
    run_sweeps,
    summarize,
)
from modelicagym.experiments.analysis import LEARNING_RATIO
from modelicagym.experiments.bounds import longest_episode, sweep_bounds
from modelicagym.experiments.cli import select_sweeps
from modelicagym.experiments.paper import FINDINGS, PAPER_NUMBERS
from modelicagym.experiments.plots import plot_sweep
from modelicagym.experiments.report import read_notes
from modelicagym.experiments.results import (
    COLUMNS,
    SweepResult,
    atomic_write,
    completed_sweeps,
    is_complete,
    write_combined_csv,
)

THETA_0 = float(np.deg2rad(85))


class StandInCartPole(gym.Wrapper):
    """gymnasium's CartPole with the FMU env's options, theta from the +x axis, rewards +p/-n."""

    def __init__(
        self,
        force=15.0,
        m_cart=10.0,
        m_pole=1.0,
        theta_0=THETA_0,
        theta_dot_0=0.0,
        time_step=0.05,
        positive_reward=1.0,
        negative_reward=-100.0,
        max_episode_steps=None,
        mode="cs",
    ):
        super().__init__(gym.make("CartPole-v1", max_episode_steps=max_episode_steps))
        u = self.env.unwrapped
        u.force_mag, u.masscart, u.masspole, u.tau = force, m_cart, m_pole, time_step
        u.total_mass, u.polemass_length = m_cart + m_pole, m_pole * u.length
        self.start = np.array([0.0, 0.0, theta_0 - np.pi / 2, theta_dot_0])
        self.rewards = positive_reward, negative_reward
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float64)

    def reset(self, **kwargs):
        _, info = self.env.reset(**kwargs)
        self.env.unwrapped.state = self.start.copy()
        return self.start + [0, 0, np.pi / 2, 0], info

    def step(self, action):
        obs, _, terminated, truncated, info = self.env.step(action)
        reward = self.rewards[1] if terminated else self.rewards[0]
        return np.asarray(obs, np.float64) + [0, 0, np.pi / 2, 0], reward, terminated, truncated, info


def make_standin(env_id, **options):
    assert env_id == "cartpole"
    return StandInCartPole(**options)


class Recorder:
    """A ``make_vec`` stand-in that remembers its calls."""

    def __init__(self, fail_after_steps: int | None = None):
        self.calls = []
        self.fail_after_steps = fail_after_steps

    def __call__(self, env_id, n, *, options_per_env=None, **options):
        self.calls.append((env_id, n, options_per_env, options))
        envs = gym.vector.SyncVectorEnv([lambda o={**options, **p}: StandInCartPole(**o) for p in options_per_env])
        if self.fail_after_steps is not None:
            envs = _FailingVectorEnv(envs, self.fail_after_steps)
        return envs


class _FailingVectorEnv(gym.vector.VectorWrapper):
    def __init__(self, env, steps):
        super().__init__(env)
        self.left = steps

    def step(self, actions):
        self.left -= 1
        if self.left < 0:
            raise RuntimeError("worker died")
        return self.env.step(actions)


def tiny(name="tiny", episodes=3, repeats=2, **changes) -> SweepConfig:
    base = SweepConfig(
        name=name,
        settings=(Setting("5 N", {"force": 5.0}), Setting("17 N", {"force": 17.0})),
        episodes=episodes,
        repeats=repeats,
        base_options={"max_episode_steps": 50},
        agent=PAPER_SWEEPS["force"].agent,
    )
    return replace(base, **changes)


# --- configs ---------------------------------------------------------------------------------------

TOML = """
name = "my-sweep"
env = "cartpole"
episodes = 10
repeats = 3
seed = 7
base_options = { m_cart = 10.0, max_episode_steps = 100 }

[agent]
n_bins = 6
intervals = [[-2.4, 2.4], [-1, 1], [1.36, 1.78], [-2, 2]]
learning_rate = 0.5

[[settings]]
label = "light"
options = { m_pole = 0.5 }

[[settings]]
label = "default"
"""


def test_config_from_toml_and_json_roundtrip(tmp_path):
    (tmp_path / "s.toml").write_text(TOML)
    config = load_config(tmp_path / "s.toml")
    assert config.name == "my-sweep" and config.episodes == 10 and config.repeats == 3 and config.seed == 7
    assert [s.label for s in config.settings] == ["light", "default"]
    assert config.options_for(config.settings[0]) == {"m_cart": 10.0, "max_episode_steps": 100, "m_pole": 0.5}
    assert config.agent.n_bins == 6 and config.agent.q_learning.learning_rate == 0.5
    assert config.agent.q_learning.discount == 1.0
    (tmp_path / "s.json").write_text(json.dumps(config.to_dict()))
    assert load_config(tmp_path / "s.json") == config
    assert SweepConfig.from_dict(PAPER_SWEEPS["masses"].to_dict()) == PAPER_SWEEPS["masses"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"episodes": None}, "missing keys \\['episodes'\\]"),
        ({"epsiodes": 3}, "unknown keys \\['epsiodes'\\]"),
        ({"episodes": 0}, "'episodes' must be an integer >= 1"),
        ({"repeats": 2.5}, "'repeats' must be an integer >= 1"),
        ({"name": "a b"}, "letters, digits"),
        ({"settings": []}, "'settings' is empty"),
        ({"settings": "force"}, "'settings' must be a list"),
        ({"settings": [{"label": "a"}, {"label": "a"}]}, "duplicate setting labels \\['a'\\]"),
        ({"settings": [{"options": {}}]}, "settings\\[0\\]: missing keys \\['label'\\]"),
        ({"settings": [{"label": "a", "options": 3}]}, "'options' must be a table"),
        ({"base_options": [1]}, "'base_options' must be a table"),
        ({"agent": {"n_bin": 3}}, "agent: unknown keys \\['n_bin'\\]"),
        ({"agent": {"learning_rate": 2.0}}, "invalid Q-learning hyperparameters \\['learning_rate'\\]"),
        ({"agent": {"intervals": [[1, 0]]}}, "'intervals' must be a list of \\[low, high\\]"),
        ({"agent": {"intervals": [["a", "b"]]}}, "'intervals' must be a list of \\[low, high\\]"),
        ({"seed": "zero"}, "'seed' must be int"),
    ],
)
def test_config_errors_say_what_is_wrong(change, message):
    data = {"name": "s", "episodes": 2, "settings": [{"label": "a"}], **change}
    data = {k: v for k, v in data.items() if v is not None}
    with pytest.raises(ConfigError, match=message):
        SweepConfig.from_dict(data)


def test_config_file_errors_name_the_file(tmp_path):
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ConfigError, match="bad.json"):
        load_config(tmp_path / "bad.json")
    (tmp_path / "bad.toml").write_text('name = "x"\nepisodes = 0\nsettings = [{label = "a"}]\n')
    with pytest.raises(ConfigError, match="bad.toml: sweep 'x': 'episodes'"):
        load_config(tmp_path / "bad.toml")
    with pytest.raises(ConfigError, match=".toml or .json"):
        load_config(tmp_path / "sweep.yaml")


def test_scaled_episodes():
    assert PAPER_SWEEPS["masses"].scaled(0.1).episodes == 20
    assert PAPER_SWEEPS["masses"].scaled(0.001).episodes == 1
    with pytest.raises(ConfigError):
        PAPER_SWEEPS["masses"].scaled(0)


def test_paper_sweeps_match_the_paper():
    expected = {"force": (100, 3), "masses": (200, 5), "reward": (200, 3), "time_step": (200, 5)}
    assert {n: (c.episodes, len(c.settings)) for n, c in PAPER_SWEEPS.items()} == expected
    for name, config in PAPER_SWEEPS.items():
        assert config.repeats == 5 and config.base_options["max_episode_steps"] == 500
        assert [s.label for s in config.settings] == list(PAPER_NUMBERS[name])
    assert PAPER_SWEEPS["time_step"].options_for(PAPER_SWEEPS["time_step"].settings[0])["time_step"] == 0.01
    np.testing.assert_allclose(PAPER_SWEEPS["force"].base_options["theta_0"], np.deg2rad(85))


def test_every_finding_can_be_checked():
    fake = {}
    for name, config in PAPER_SWEEPS.items():
        result = SweepResult(config, np.full((len(config.settings), 5, config.episodes), 10), np.zeros(1))
        fake[name] = summarize(result)
    for finding in FINDINGS:
        holds, evidence = finding.check(fake[finding.sweep])
        assert isinstance(holds, bool) and evidence


def test_select_sweeps(tmp_path):
    assert [c.name for c in select_sweeps(None)] == list(PAPER_SWEEPS)
    assert [c.episodes for c in select_sweeps("force, reward", episodes_scale=0.5)] == [50, 100]
    with pytest.raises(ConfigError, match="unknown sweeps \\['forces'\\]"):
        select_sweeps("forces")
    (tmp_path / "s.toml").write_text(TOML)
    assert [c.name for c in select_sweeps(None, [tmp_path / "s.toml"])] == ["my-sweep"]
    assert [c.name for c in select_sweeps("force", [tmp_path / "s.toml"])] == ["force", "my-sweep"]
    with pytest.raises(ConfigError, match="several sweeps named \\['my-sweep'\\]"):
        select_sweeps(None, [tmp_path / "s.toml"] * 2)


# --- analysis --------------------------------------------------------------------------------------


def test_moving_average_and_summaries():
    np.testing.assert_allclose(moving_average(np.arange(6.0), 3), [1, 2, 3, 4])
    np.testing.assert_allclose(moving_average(np.arange(3.0), 20), [1.0])
    lengths = np.zeros((2, 2, 40))
    lengths[0] = 10
    lengths[1, :, :20], lengths[1, 0, 20:], lengths[1, 1, 20:] = 10, 20, 40
    summary = summarize(SweepResult(tiny(episodes=40), lengths, np.zeros_like(lengths)))
    flat, learner = summary["5 N"], summary["17 N"]
    assert (flat.mean, flat.first, flat.last, flat.learns) == (10, 10, 10, False)
    assert (learner.mean, learner.mean_std, learner.first, learner.last, learner.last_std) == (20, 5, 10, 30, 10)
    assert learner.learns and learner.env_steps == 1600
    assert LEARNING_RATIO > 1
    assert learner.last_seconds is None
    timed = tiny(episodes=40, base_options={"time_step": 0.05})
    assert summarize(SweepResult(timed, lengths, lengths))["17 N"].last_seconds == pytest.approx(1.5)


def test_ordering_findings_count_the_repeats_that_agree():
    [finding] = [f for f in FINDINGS if f.sweep == "reward"]
    lasts = {"-200": (60.0, 30.0), "-100": (40.0, 35.0), "-50": (20.0, 10.0)}
    summaries = {label: SettingSummary(label, v, v, v, 0) for label, v in lasts.items()}
    holds, evidence = finding.check(summaries)
    assert holds and evidence == "last-20 mean: -200 45.0 > -100 37.5 > -50 15.0; in 1 of 2 repeats"


# --- runs, files, resume -----------------------------------------------------------------------------


@requires("plots")
@pytest.mark.processes
def test_tiny_sweep_end_to_end(tmp_path):
    make_vec = Recorder()
    [result] = run_sweeps([tiny()], tmp_path, make_vec=make_vec, make=make_standin, progress=False, bounds_budget=5000)
    env_id, n, options_per_env, options = make_vec.calls[0]
    assert (env_id, n) == ("cartpole", 4)
    assert options_per_env == [{"force": 5.0}] * 2 + [{"force": 17.0}] * 2
    assert options == {"max_episode_steps": 50}

    with open(tmp_path / "tiny" / "episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["experiment", "setting", "repeat", "episode", "length", "reward"]
    assert len(rows) == 2 * 2 * 3
    assert rows[0]["experiment"] == "tiny" and rows[-1]["setting"] == "17 N"
    lengths = np.array([int(r["length"]) for r in rows]).reshape(2, 2, 3)
    np.testing.assert_array_equal(lengths, result.lengths)
    # Every episode but a truncated one ends with the -100 penalty after length - 1 steps of +1.
    rewards = np.array([float(r["reward"]) for r in rows]).reshape(2, 2, 3)
    np.testing.assert_array_equal(rewards, np.where(lengths == 50, 50.0, lengths - 101.0))

    run = json.loads((tmp_path / "tiny" / "run.json").read_text())
    timing = run["timing"]
    assert run["config"] == tiny().to_dict()
    assert timing["env_steps"] == lengths.sum() and timing["num_envs"] == 4
    assert timing["seconds_per_step"] == pytest.approx(timing["wall_seconds"] / timing["env_steps"])
    assert timing["pool_timing"] is None and run["machine"]["cpu_count"] >= 1
    assert list(run["bounds"]) == ["5 N", "17 N"]
    assert all(b is None or b >= n for b, n in zip(run["bounds"].values(), lengths.max(axis=(1, 2)), strict=True))
    assert (tmp_path / "tiny" / "episode_lengths.png").stat().st_size > 0
    assert (tmp_path / "episodes.csv").read_text() == (tmp_path / "tiny" / "episodes.csv").read_text()

    agent = QLearningAgent.load(tmp_path / "tiny" / "agent.npz")
    np.testing.assert_array_equal(agent.q_table, result.agent.q_table)
    assert agent.q_table.shape == (4, 10**4, 2)

    back = read_sweep(tmp_path, "tiny")
    assert back.config == tiny() and back.bounds == run["bounds"]
    np.testing.assert_array_equal(back.lengths, result.lengths)
    np.testing.assert_array_equal(back.returns, result.returns)


def test_runs_are_reproducible_and_repeats_share_seeds_across_settings(tmp_path):
    config = tiny(settings=(Setting("a", {"force": 11.0}), Setting("b", {"force": 11.0})), episodes=6)
    [first] = run_sweeps([config], tmp_path / "1", make_vec=Recorder(), progress=False, bounds_budget=0)
    [second] = run_sweeps([config], tmp_path / "2", make_vec=Recorder(), progress=False, bounds_budget=0)
    np.testing.assert_array_equal(first.lengths, second.lengths)
    np.testing.assert_array_equal(first.lengths[0], first.lengths[1])  # same options, same seeds
    assert not np.array_equal(first.lengths[0, 0], first.lengths[0, 1])  # repeats differ


def test_resume_skips_completed_sweeps_only(tmp_path):
    run_sweeps([tiny("a")], tmp_path, make_vec=Recorder(), progress=False, bounds_budget=0)
    make_vec = Recorder()
    outcomes = run_sweeps(
        [tiny("a"), tiny("b")], tmp_path, resume=True, make_vec=make_vec, progress=False, bounds_budget=0
    )
    assert outcomes[0] is None and outcomes[1] is not None
    assert len(make_vec.calls) == 1
    assert completed_sweeps(tmp_path) == ["a", "b"]
    with open(tmp_path / "episodes.csv") as f:
        assert {row["experiment"] for row in csv.DictReader(f)} == {"a", "b"}
    # A different configuration under the same name is not "complete": it runs again.
    assert not is_complete(tmp_path, tiny("a", episodes=4))
    [again] = run_sweeps(
        [tiny("a", episodes=4)], tmp_path, resume=True, make_vec=make_vec, progress=False, bounds_budget=0
    )
    assert again is not None and read_sweep(tmp_path, "a").config.episodes == 4


@pytest.mark.parametrize("damage", ["cut short", "emptied", "changed", "agent deleted"])
def test_resume_runs_again_a_sweep_whose_files_were_damaged_after_the_run(tmp_path, caplog, damage):
    """A sweep is complete only while its files are what was written: one cut short (a full disk, a
    crash while copying), emptied or changed is run again by --resume, saying so, and left out of
    the combined table until then (it used to be reported "already complete" with 44 of 1,501 lines)."""
    [first] = run_sweeps([tiny("a"), tiny("b")], tmp_path, make_vec=Recorder(), progress=False, bounds_budget=0)[:1]
    episodes = tmp_path / "a" / "episodes.csv"
    text = episodes.read_text()
    if damage == "cut short":
        episodes.write_text(text[: len(text) // 3])
    elif damage == "emptied":
        episodes.write_text("")
    elif damage == "changed":
        episodes.write_text(text.replace(",5 N,0,0,", ",5 N,0,0,9", 1))
    else:
        (tmp_path / "a" / "agent.npz").unlink()
    assert not is_complete(tmp_path, tiny("a"))
    assert completed_sweeps(tmp_path) == ["b"]
    assert "sweep 'a' left out: it is incomplete" in caplog.text
    make_vec = Recorder()
    outcomes = run_sweeps([tiny("a"), tiny("b")], tmp_path, resume=True, make_vec=make_vec, progress=False,
                          bounds_budget=0)
    assert outcomes[0] is not None and outcomes[1] is None and len(make_vec.calls) == 1
    assert "sweep 'a' in" in caplog.text and "is incomplete" in caplog.text and "running it again" in caplog.text
    assert episodes.read_text() == text
    np.testing.assert_array_equal(read_sweep(tmp_path, "a").lengths, first.lengths)
    with open(tmp_path / "episodes.csv") as f:
        assert len(list(csv.DictReader(f))) == 2 * first.lengths.size


@pytest.mark.parametrize("content, problem", [
    ("", "lacks 12 of the 12 episodes"),
    ("experiment,setting,repeat,episode,length,reward\ntiny,5 N,0,zero,3,1.0\n", "line 2: not a row .*ValueError"),
    ("experiment,setting,repeat,episode,length,reward\ntiny,99 N,0,0,3,1.0\n", "line 2: not a row .*KeyError"),
    ("experiment,setting,repeat,episode,length,reward\ntiny,5 N,0,0,3,1.0\n", "lacks 11 of the 12 episodes"),
])
def test_a_garbled_results_table_is_a_data_error_naming_the_file(tmp_path, content, problem):
    run_sweeps([tiny()], tmp_path, make_vec=Recorder(), progress=False, bounds_budget=0)
    (tmp_path / "tiny" / "episodes.csv").write_text(content)
    with pytest.raises(DataError, match=rf"tiny/episodes\.csv.*{problem}"):
        read_sweep(tmp_path, "tiny")
    write_combined_csv(tmp_path)  # the damaged sweep is left out, no traceback
    assert (tmp_path / "episodes.csv").read_text().splitlines() == [",".join(COLUMNS)]


def test_interrupted_sweep_leaves_no_files_and_keeps_finished_ones(tmp_path):
    with pytest.raises(RuntimeError, match="worker died"):
        run_sweeps([tiny("a"), tiny("b")], tmp_path, make_vec=_FailSecond(), progress=False, bounds_budget=0)
    assert completed_sweeps(tmp_path) == ["a"]
    assert not (tmp_path / "b").exists() or not any((tmp_path / "b").iterdir())
    assert not list(tmp_path.rglob("*.tmp"))


class _FailSecond(Recorder):
    def __call__(self, *args, **kwargs):
        self.fail_after_steps = 5 if self.calls else None
        return super().__call__(*args, **kwargs)


def test_atomic_write_keeps_the_old_file_on_error(tmp_path):
    target = tmp_path / "f.csv"
    with atomic_write(target) as f:
        f.write("old")
    with pytest.raises(ValueError), atomic_write(target) as f:
        f.write("half")
        raise ValueError
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["f.csv"]


def test_missing_optional_packages_only_warn(tmp_path, monkeypatch, caplog):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "tqdm", None)
    with caplog.at_level(logging.WARNING):
        run_sweeps([tiny()], tmp_path, make_vec=Recorder(), progress=True, bounds_budget=0)
    assert "matplotlib is not installed" in caplog.text and "tqdm is not installed" in caplog.text
    assert completed_sweeps(tmp_path) == ["tiny"]
    assert not (tmp_path / "tiny" / "episode_lengths.png").exists()
    assert plot_sweep(read_sweep(tmp_path, "tiny"), tmp_path / "x.png") is None


# --- report and CLI ------------------------------------------------------------------------------


@requires("plots")
def test_report_from_results(tmp_path):
    force = PAPER_SWEEPS["force"].scaled(0.1)
    other = tiny("mine")
    run_sweeps([force, other], tmp_path / "results", make_vec=Recorder(), progress=False, bounds_budget=0)
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "reproduction-notes.md").write_text("# notes\n\n## force\n\nForce prose.\n\n## summary\nSummary prose.\n")
    output = render_report(tmp_path / "results", docs, notes_path=docs / "reproduction-notes.md")
    assert output == docs / "report.md"
    text = output.read_text()
    assert (docs / "figures" / "force.png").exists() and (docs / "figures" / "mine.png").exists()
    assert "![force](figures/force.png)" in text
    assert "| 5 N | " in text and "| 9.3 | " in text  # a paper number next to ours
    assert " SE) |" in text  # ours - paper, in standard errors
    assert "5 N is too weak" in text and "Force prose." in text and "Summary prose." in text
    assert "fewer than 40" in text
    assert "add a `## mine` section" in text and "`max_episode_steps=500`" in text
    assert read_notes(docs / "reproduction-notes.md")["summary"] == "Summary prose."


def _files_under(folder) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@requires("plots")
def test_report_writes_beside_the_results_and_nowhere_else(tmp_path, monkeypatch, capsys):
    """``report --results results``, as a user types it: ``results/report.md`` and
    ``results/figures/``, nothing in the current folder (it used to rewrite ``docs/reproduction.md``
    there, a tracked file of the repository, or make a ``docs/`` folder), no discussion placeholders."""
    results, cwd = tmp_path / "results", tmp_path / "cwd"
    run_sweeps([PAPER_SWEEPS["force"].scaled(0.03)], results, make_vec=Recorder(), progress=False, bounds_budget=0)
    (cwd / "docs").mkdir(parents=True)
    (cwd / "docs" / "reproduction.md").write_text("tracked page\n")
    before = _files_under(tmp_path)
    monkeypatch.chdir(cwd)
    assert main(["report", "--results", str(results)]) == 0
    assert capsys.readouterr().out.strip() == f"report: {results / 'report.md'}"
    written = {name: data for name, data in _files_under(tmp_path).items() if name not in before}
    assert sorted(written) == ["results/figures/force.png", "results/report.md"]
    assert all(_files_under(tmp_path)[name] == data for name, data in before.items())  # nothing else changed
    text = written["results/report.md"].decode()
    assert "![force](figures/force.png)" in text and "5 N is too weak" in text
    assert "Discussion not written" not in text and "discussion paragraphs" not in text

    assert main(["report", "--results", str(results), "--out", str(tmp_path / "elsewhere")]) == 0
    assert sorted(_files_under(tmp_path / "elsewhere")) == ["figures/force.png", "report.md"]


def test_cli_reproduce_and_report(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(modelicagym, "make_vec", Recorder(), raising=False)
    out, docs = tmp_path / "results", tmp_path / "docs"
    argv = ["reproduce", "--out", str(out), "--sweeps", "force", "--episodes-scale", "0.03", "--no-progress"]
    argv += ["--bounds-budget", "0"]
    assert main([*argv, "--report"]) == 0
    printed = capsys.readouterr().out
    assert "5 N is too weak" in printed  # the summary printed at the end
    assert f"modelicagym report --results {out}   (writes {out / 'report.md'})" in printed
    assert completed_sweeps(out) == ["force"] and read_sweep(out, "force").config.episodes == 3
    assert (out / "report.md").exists() and not docs.exists()
    # maintainers refresh the documentation's page explicitly, with its discussion file
    assert main([*argv, "--resume", "--report", "--docs", str(docs)]) == 0
    assert "add a `## force` section to `" + (docs / "reproduction-notes.md").as_posix() in (
        docs / "reproduction.md"
    ).read_text()
    assert main(["report", "--results", str(out), "--docs", str(docs)]) == 0
    assert capsys.readouterr().out.endswith(f"report: {docs / 'reproduction.md'}\n")
    assert main([*argv, "--show-config"]) == 0
    assert json.loads(capsys.readouterr().out)[0]["episodes"] == 3
    assert main(["reproduce", "--sweeps", "nope"]) == 1
    assert main(["report", "--results", str(tmp_path / "empty")]) == 1
    assert main(["report", "--results", str(out), "--notes", str(tmp_path / "missing.md")]) == 1
    assert "--notes" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # one place for the report, not two
        main(["report", "--results", str(out), "--out", str(tmp_path / "a"), "--docs", str(docs)])


SMALLEST = ["--sweeps", "force,reward", "--episodes-scale", "0.03", "--no-progress", "--bounds-budget", "0"]


@requires("plots")
@pytest.mark.parametrize("damage", ["cut short", "garbled", "deleted", "plot deleted"])
def test_resume_leaves_the_combined_table_and_the_plots_whole(tmp_path, monkeypatch, damage):
    """``reproduce --resume`` after the combined table (or a plot) was damaged, with every sweep
    complete so nothing runs: the table is made again from the verified sweeps and equals an
    undamaged run's (it used to stay cut short, with exit status 0)."""
    monkeypatch.setattr(modelicagym, "make_vec", Recorder(), raising=False)
    undamaged, out = tmp_path / "undamaged", tmp_path / "results"
    assert main(["reproduce", "--out", str(undamaged), *SMALLEST]) == 0
    assert main(["reproduce", "--out", str(out), *SMALLEST]) == 0
    combined, plot = out / "episodes.csv", out / "reward" / "episode_lengths.png"
    text = combined.read_text()
    assert text == (undamaged / "episodes.csv").read_text()
    if damage == "cut short":
        combined.write_text(text[: len(text) // 2])
    elif damage == "garbled":
        combined.write_text(text.replace("force,", "f\x00rce;", 7))
    elif damage == "deleted":
        combined.unlink()
    else:
        plot.unlink()
    recorder = Recorder()
    monkeypatch.setattr(modelicagym, "make_vec", recorder, raising=False)
    assert main(["reproduce", "--out", str(out), "--resume", *SMALLEST]) == 0
    assert recorder.calls == []  # both sweeps were complete: nothing ran
    assert combined.read_text() == (undamaged / "episodes.csv").read_text()
    with open(combined, newline="") as f:
        assert len(list(csv.DictReader(f))) == 3 * 5 * 3 + 3 * 5 * 6
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.rglob("*.tmp"))


@pytest.mark.processes
def test_tiny_sweep_on_the_real_cartpole_pool(tmp_path):
    """The default ``make_vec`` (the FMU env in the multi-process pool), end to end."""
    config = tiny(settings=(Setting("0.05 s", {}), Setting("0.5 s", {"time_step": 0.5})), episodes=2)
    [result] = run_sweeps([config], tmp_path, progress=False, bounds_budget=20_000)
    assert result.lengths.shape == (2, 2, 2) and (result.lengths >= 1).all()
    assert (result.lengths[1] < result.lengths[0]).all()  # 0.5 s steps: the pole falls within a few steps
    timing = json.loads((tmp_path / "tiny" / "run.json").read_text())["timing"]
    # the pool's default plan: a worker per usable core beside the calling process, none on one core
    assert 0 < timing["pool_timing"]["steps"] <= timing["vector_steps"]
    assert (timing["num_workers"] >= 1) == (usable_cores() > 1), timing["num_workers"]
    # finished envs are not stepped: beyond the learned steps only the autoresets between episodes
    assert timing["env_steps_stepped"] == timing["env_steps"] + 4 * (2 - 1)
    per_setting = timing["per_setting"]
    assert all(entry["fmu_seconds_per_step"] > 0 for entry in per_setting.values())
    assert sum(entry["env_steps_stepped"] for entry in per_setting.values()) == timing["env_steps_stepped"]
    assert result.bounds == {"0.05 s": None, "0.5 s": 4}  # 0.05 s: long episodes exist, the search gives up
    assert result.lengths[1].max() <= 4


def test_longest_episode_by_exhaustive_search():
    assert longest_episode(drift()) == 5  # always action 0
    assert longest_episode(drift(), budget=10) is None
    with pytest.raises(TypeError, match="Discrete"):
        longest_episode(gym.make("Pendulum-v1"))


def test_sweep_bounds_per_setting_without_the_step_limit():
    config = SweepConfig(
        "c", (Setting("a", {"length": 2}), Setting("b", {"length": 4})), 1, base_options={"max_episode_steps": 3}
    )
    assert sweep_bounds(config, make=lambda env_id, **o: counter(**o)) == {"a": 2, "b": 4}
