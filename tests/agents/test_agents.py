"""Tests of the tabular Q-learning agent: binning, the update rule, randomness, batching, resets."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from toy_envs import chain, counter

from modelicagym.agents import Discretizer, QLearningAgent, QLearningConfig, train
from modelicagym.models.cartpole.env import CARTPOLE_INTERVALS
from modelicagym.vector import PoolVectorEnv


def unit_discretizer(n_states: int) -> Discretizer:
    """Observation k in [0, n_states) -> state k."""
    return Discretizer([(0.0, float(n_states))], n_states)


# --- binning -------------------------------------------------------------------------------------


def test_paper_cartpole_edges():
    d = Discretizer(CARTPOLE_INTERVALS, 10)
    assert d.n_states == 10**4
    assert [len(e) for e in d.edges] == [9, 9, 9, 9]
    np.testing.assert_allclose(d.edges[0], np.linspace(-2.4, 2.4, 11)[1:-1])
    np.testing.assert_allclose(d.edges[2][[0, -1]], np.deg2rad([80.4, 99.6]))


def test_outermost_bins_are_open():
    d = Discretizer(CARTPOLE_INTERVALS, 10)
    assert d.bins(np.array([-1e9, -np.inf, -10.0, -3.0])).tolist() == [0, 0, 0, 0]
    assert d.bins(np.array([1e9, np.inf, 10.0, 3.0])).tolist() == [9, 9, 9, 9]
    # The interval ends themselves are in the outermost bins.
    assert d.bins(np.array([-2.4, -1.0, np.deg2rad(78), -2.0])).tolist() == [0, 0, 0, 0]
    assert d.bins(np.array([2.4, 1.0, np.deg2rad(102), 2.0])).tolist() == [9, 9, 9, 9]


def test_value_on_an_edge_belongs_to_the_bin_above():
    d = Discretizer([(-2.4, 2.4)], 10)
    for k, edge in enumerate(d.edges[0]):
        assert d.bins(np.array([edge]))[0] == k + 1
        assert d.bins(np.array([np.nextafter(edge, -np.inf)]))[0] == k


def test_state_index_concatenates_bin_digits():
    d = Discretizer(CARTPOLE_INTERVALS, 10)
    centres = [(lo + (np.arange(10) + 0.5) * (hi - lo) / 10) for lo, hi in CARTPOLE_INTERVALS]
    obs = np.array([centres[0][3], centres[1][0], centres[2][7], centres[3][9]])
    assert d.bins(obs).tolist() == [3, 0, 7, 9]
    assert d.states(obs) == 3079
    batch = np.stack([obs, [c[9] for c in centres]])
    assert d.states(batch).tolist() == [3079, 9999]


def test_mixed_bin_counts_index_every_state_once():
    d = Discretizer([(0.0, 2.0), (0.0, 3.0)], [2, 3])
    grid = np.array([[i + 0.5, j + 0.5] for i in range(2) for j in range(3)])
    assert d.states(grid).tolist() == list(range(6))


def test_discretizer_from_box_and_errors():
    box = gym.spaces.Box(np.array([0.0, -1.0]), np.array([1.0, 1.0]), dtype=np.float64)
    d = Discretizer.for_box(box, 4)
    np.testing.assert_allclose(d.edges[1], [-0.5, 0.0, 0.5])
    with pytest.raises(ValueError, match="infinite bounds"):
        Discretizer.for_box(gym.spaces.Box(-np.inf, np.inf, (2,), np.float64))
    with pytest.raises(ValueError, match="1 intervals for an observation of 2"):
        Discretizer.for_box(box, intervals=[(0, 1)])
    with pytest.raises(TypeError, match="Box"):
        Discretizer.for_box(gym.spaces.Discrete(3))
    with pytest.raises(ValueError, match="low < high"):
        Discretizer([(1.0, 1.0)])
    with pytest.raises(ValueError, match="2 variables"):
        Discretizer([(0, 1), (0, 1)]).states(np.zeros(3))


# --- the update rule -----------------------------------------------------------------------------


def one_step_agent(**config) -> QLearningAgent:
    agent = QLearningAgent(unit_discretizer(2), 2, config=QLearningConfig(**config), seeds=0)
    agent.q_table = np.array([[[0.1, 0.2], [0.4, -0.6]]])
    return agent


@pytest.mark.parametrize(
    ("terminated", "truncated", "bootstrap_on_truncation", "expected"),
    [
        (False, False, True, 0.78),  # 0.2 + 0.5 * (1 + 0.9 * 0.4 - 0.2)
        (True, False, True, 0.6),  # 0.2 + 0.5 * (1 - 0.2): no bootstrap from a terminal state
        (False, True, True, 0.78),  # truncation bootstraps ...
        (False, True, False, 0.6),  # ... unless told not to
        (True, True, True, 0.6),
    ],
)
def test_update_rule_hand_computed(terminated, truncated, bootstrap_on_truncation, expected):
    agent = one_step_agent(learning_rate=0.5, discount=0.9, bootstrap_on_truncation=bootstrap_on_truncation)
    agent.learn(
        np.array([0]), np.array([1]), np.array([1.0]), np.array([1]), np.array([terminated]), np.array([truncated])
    )
    np.testing.assert_allclose(agent.q_table[0], [[0.1, expected], [0.4, -0.6]])


def test_epsilon_decays_once_per_learned_step_and_only_where_masked():
    agent = QLearningAgent(unit_discretizer(2), 2, n_envs=2, seeds=0)
    zeros, flags = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=bool)
    for _ in range(5):
        agent.learn(zeros, zeros, np.zeros(2), zeros, flags, flags, mask=np.array([True, False]))
    np.testing.assert_allclose(agent.epsilon, [0.5 * 0.99**5, 0.5])


def test_greedy_actions_and_exploration_frequency():
    agent = QLearningAgent(unit_discretizer(1), 2, n_envs=2000, config=QLearningConfig(exploration_rate=0.3), seeds=1)
    agent.q_table = np.tile([[[0.0, 1.0]]], (2000, 1, 1))
    states = np.zeros(2000, dtype=np.int64)
    assert (agent.act(states, greedy=True) == 1).all()
    # Explore with probability 0.3, then pick uniformly: action 0 appears ~15% of the time.
    assert abs((agent.act(states) == 0).mean() - 0.15) < 0.03


# --- randomness and batching ---------------------------------------------------------------------


def drive(agents: list[QLearningAgent], steps: int, seed: int) -> list[np.ndarray]:
    """Feed identical random transitions to a batched agent (one element) or to single agents."""
    rng = np.random.default_rng(seed)
    n_envs = sum(a.n_envs for a in agents)
    n_states = agents[0].discretizer.n_states
    actions_taken = []
    states = rng.integers(0, n_states, n_envs)
    for _ in range(steps):
        next_states = rng.integers(0, n_states, n_envs)
        rewards = rng.normal(size=n_envs)
        terminated, truncated, mask = rng.random((3, n_envs)) < [[0.1], [0.05], [0.8]]
        acts, start = [], 0
        for agent in agents:
            part = slice(start, start + agent.n_envs)
            a = agent.act(states[part])
            agent.learn(
                states[part], a, rewards[part], next_states[part], terminated[part], truncated[part], mask[part]
            )
            acts.append(a)
            start += agent.n_envs
        actions_taken.append(np.concatenate(acts))
        states = next_states
    return actions_taken


def test_same_seed_same_run_and_different_seed_different_run():
    runs = [QLearningAgent(unit_discretizer(5), 3, n_envs=2, seeds=s) for s in (7, 7, 8)]
    actions = [drive([agent], 300, seed=0) for agent in runs]
    np.testing.assert_array_equal(actions[0], actions[1])
    np.testing.assert_array_equal(runs[0].q_table, runs[1].q_table)
    assert not np.array_equal(runs[0].q_table, runs[2].q_table)


def test_batched_agent_equals_independent_single_agents():
    seeds = [11, 12, 13]
    batched = QLearningAgent(unit_discretizer(6), 3, n_envs=3, seeds=seeds)
    singles = [QLearningAgent(unit_discretizer(6), 3, seeds=[s]) for s in seeds]
    # 600 steps cross the random-draw block boundary twice.
    np.testing.assert_array_equal(drive([batched], 600, seed=3), drive(singles, 600, seed=3))
    np.testing.assert_array_equal(batched.q_table, np.concatenate([s.q_table for s in singles]))
    np.testing.assert_array_equal(batched.epsilon, np.concatenate([s.epsilon for s in singles]))


@pytest.mark.parametrize("bootstrap_on_truncation", [True, False])
def test_the_native_agent_equals_the_numpy_agent_bit_for_bit(bootstrap_on_truncation):
    """Q-tables, epsilons, actions and states: the C hot path evaluates what numpy does."""
    config = QLearningConfig(bootstrap_on_truncation=bootstrap_on_truncation, learning_rate=0.3, discount=0.9)
    discretizer = Discretizer([(-1.0, 1.0), (-2.0, 3.0), (0.0, 1.0)], [3, 4, 2])
    native, plain = (QLearningAgent(discretizer, 3, n_envs=7, config=config, seeds=5, native=flag)
                     for flag in (True, False))
    assert native._native is not None and plain._native is None
    np.testing.assert_array_equal(drive([native], 700, seed=4), drive([plain], 700, seed=4))
    np.testing.assert_array_equal(native.q_table, plain.q_table)
    np.testing.assert_array_equal(native.epsilon, plain.epsilon)
    observations = np.random.default_rng(1).normal(size=(7, 3)) * 2
    observations[0, 1] = np.nan
    np.testing.assert_array_equal(native.states(observations), plain.states(observations))


def test_wrong_number_of_seeds():
    with pytest.raises(ValueError, match="2 seeds for 3 envs"):
        QLearningAgent(unit_discretizer(2), 2, n_envs=3, seeds=[1, 2])


# --- training on vector envs ---------------------------------------------------------------------


def test_next_step_reset_step_is_not_learned_from():
    lengths = [2, 3, 4]
    envs = SyncVectorEnv([lambda n=n: counter(n) for n in lengths], autoreset_mode=AutoresetMode.NEXT_STEP)
    agent = QLearningAgent(unit_discretizer(6), 2, n_envs=3, seeds=0)
    initial = agent.q_table.copy()
    log = train(envs, agent, 7)
    assert log.lengths.tolist() == [[n] * 7 for n in lengths]
    assert log.returns.tolist() == [[float(n)] * 7 for n in lengths]
    assert log.env_steps.tolist() == [7 * n for n in lengths]
    # One decay per learned step, none for the reset steps.
    np.testing.assert_allclose(agent.epsilon, 0.5 * 0.99 ** (7 * np.array(lengths)))
    for i, n in enumerate(lengths):
        # The terminal state n is only ever the source of reset transitions: never updated.
        np.testing.assert_array_equal(agent.q_table[i, n], initial[i, n])
        assert not np.array_equal(agent.q_table[i, n - 1], initial[i, n - 1])


def test_reset_step_after_truncation_is_not_learned_from():
    envs = SyncVectorEnv([lambda: gym.wrappers.TimeLimit(counter(10), 3)])
    agent = QLearningAgent(unit_discretizer(11), 2, seeds=0)
    initial = agent.q_table.copy()
    log = train(envs, agent, 4)
    assert log.lengths.tolist() == [[3] * 4]
    np.testing.assert_array_equal(agent.q_table[0, 3], initial[0, 3])


def test_finished_envs_are_ignored_while_others_continue():
    envs = SyncVectorEnv([lambda: counter(1), lambda: counter(5)])
    agent = QLearningAgent(unit_discretizer(6), 2, n_envs=2, seeds=0)
    episodes = []
    log = train(envs, agent, 3, on_episodes=episodes.append)
    assert log.lengths.tolist() == [[1, 1, 1], [5, 5, 5]]
    assert sum(episodes) == 6
    assert log.vector_steps == 3 * 5 + 2  # the long env's episodes plus its two reset steps
    np.testing.assert_allclose(agent.epsilon, 0.5 * 0.99 ** np.array([3, 15]))


@pytest.mark.processes
def test_a_pool_steps_only_unfinished_envs_and_the_episodes_stay_the_same():
    """On the pool (which can step a subset of its envs) finished envs cost nothing, and every
    env's episodes and Q-table are those of the SyncVectorEnv run, which steps every env."""
    fns = [lambda: counter(1), lambda: counter(5), chain, chain]
    runs = []
    for envs in (SyncVectorEnv(fns), PoolVectorEnv(fns, num_workers=2)):
        agent = QLearningAgent(unit_discretizer(6), 2, n_envs=4, seeds=3)
        runs.append((train(envs, agent, 4, seed=9), agent.q_table.copy()))
        envs.close()
    (sync_log, sync_q), (pool_log, pool_q) = runs
    np.testing.assert_array_equal(pool_log.lengths, sync_log.lengths)
    np.testing.assert_array_equal(pool_q, sync_q)
    assert (sync_log.env_steps_stepped == sync_log.vector_steps).all()
    np.testing.assert_array_equal(pool_log.env_steps_stepped, pool_log.env_steps + 4 - 1)


def test_learns_the_chain():
    agent = QLearningAgent(unit_discretizer(6), 2, n_envs=4, seeds=0)
    envs = SyncVectorEnv([lambda: gym.wrappers.TimeLimit(chain(), 50)] * 4)
    log = train(envs, agent, 60)
    assert (log.lengths[:, -10:] == 5).all()
    assert all(agent.predict(np.array([float(p)]), env_index=i) == 1 for p in range(5) for i in range(4))


def test_train_accepts_a_single_env_and_checks_its_arguments():
    agent = QLearningAgent(unit_discretizer(6), 2, seeds=0)
    assert train(counter(2), agent, 3).lengths.tolist() == [[2, 2, 2]]
    with pytest.raises(ValueError, match="1 Q-tables for 2 envs"):
        train(SyncVectorEnv([lambda: counter(2)] * 2), agent, 1)
    same_step = SyncVectorEnv([lambda: counter(2)], autoreset_mode=AutoresetMode.SAME_STEP)
    with pytest.raises(ValueError, match="NEXT_STEP"):
        train(same_step, agent, 1)


# --- saving --------------------------------------------------------------------------------------


def test_save_load_roundtrip_gives_the_same_greedy_policy(tmp_path):
    config = QLearningConfig(learning_rate=0.3, discount=0.95, bootstrap_on_truncation=False)
    agent = QLearningAgent(Discretizer(CARTPOLE_INTERVALS, [10, 5, 10, 4]), 2, n_envs=2, config=config, seeds=4)
    drive([agent], 50, seed=0)
    path = tmp_path / "agent"  # written as given, no suffix added
    agent.save(path)
    loaded = QLearningAgent.load(path)
    np.testing.assert_array_equal(loaded.q_table, agent.q_table)
    np.testing.assert_array_equal(loaded.epsilon, agent.epsilon)
    np.testing.assert_array_equal(loaded.discretizer.n_bins, [10, 5, 10, 4])
    assert loaded.config == config
    obs = np.random.default_rng(0).normal([0, 0, np.pi / 2, 0], 0.5, (100, 4))
    for i in range(2):
        assert [loaded.predict(o, env_index=i) for o in obs] == [agent.predict(o, env_index=i) for o in obs]
    with pytest.raises(ValueError, match="one observation"):
        loaded.predict(obs)
