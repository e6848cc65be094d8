"""``render_mode="rgb_array"`` on any `FMUEnv`: the strip chart of the episode's actions and
observations, recorded only when rendering, the same steps either way, drawable in a video and in a
pool; the cart-pole keeps its own picture; without matplotlib, one line naming the extra."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import warnings
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from extras import requires
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import RecordVideo

import modelicagym
from modelicagym import FMUEnv
from modelicagym.env.strip_chart import LINES_PER_PANEL, MAX_PANELS, panels_of
from modelicagym.fmu import open_fmu
from modelicagym.info import suggest
from modelicagym.try_fmu import try_config
from modelicagym.vector import PoolVectorEnv

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(params=["probe-fmi2", "probe-fmi3", "cartpole"])
def config(request, family_fmu, cartpole_fmu) -> dict:
    """``modelicagym info``'s config for a real FMU, episodes of 40 steps."""
    fmu = cartpole_fmu(2) if request.param == "cartpole" else family_fmu("probe", int(request.param[-1]))
    return {**try_config(fmu), "max_episode_steps": 40}


def run(env: FMUEnv, steps: int, seed: int = 0) -> list[tuple]:
    """Reset with ``seed`` and take ``steps`` seeded random actions; the step results."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    return [env.step(env.action_space.sample()) for _ in range(steps)]


@requires("plots")
def test_render_returns_an_image_that_follows_the_episode(config):
    env = FMUEnv(config, render_mode="rgb_array")
    run(env, 1)
    first = env.render()
    run_on = [env.step(env.action_space.sample()) for _ in range(19)]
    assert not any(terminated or truncated for _, _, terminated, truncated, _ in run_on)
    twentieth = env.render()
    env.close()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    assert twentieth.shape == first.shape  # a video's frames share their size
    assert (first != twentieth).any(axis=2).mean() > 0.01  # the lines grew: more than 1% of the pixels


@requires("plots")
def test_a_charting_env_passes_gymnasiums_checks_render_included(family_fmu):
    env = FMUEnv(suggest(open_fmu(family_fmu("probe", 2))).config, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation spaces; no spec to make the env again
        check_env(env, skip_render_check=False)
    env.close()


@requires("plots")
def test_the_chart_holds_every_step_s_actions_and_observations(cartpole_fmu):
    config = {**try_config(cartpole_fmu(2)), "max_episode_steps": 40}
    env = FMUEnv(config, render_mode="rgb_array")
    observation, _ = env.reset(seed=3)
    env.action_space.seed(3)
    actions, observations = [], [observation]
    for _ in range(10):
        actions.append(env.action_space.sample())
        observations.append(env.step(actions[-1])[0])
    chart = env.strip_chart
    assert [s.role for s in chart.series] == ["action"] + ["observation"] * 4
    assert [s.label for s in chart.series] == ["f [N]", "x [m]", "x_dot [m/s]", "theta [rad]", "theta_dot [rad/s]"]
    np.testing.assert_allclose(chart.times, np.arange(11) * env.time_step, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(chart.values[1:, 0], np.concatenate(actions))  # row k: the action of step k
    np.testing.assert_array_equal(chart.values[:, 1:], np.array(observations))
    env.reset(seed=4)
    assert chart.length == 1  # a new episode, a new chart
    env.close()


@requires("plots")
def test_recording_changes_no_result_and_costs_nothing_without_rendering(cartpole_fmu):
    config = {**try_config(cartpole_fmu(2)), "max_episode_steps": 40}
    plain, rendering = FMUEnv(config), FMUEnv(config, render_mode="rgb_array")
    # without a render mode: no chart, no per-instance step or reset, the native path
    assert plain.strip_chart is None and plain.render() is None
    assert "step" not in vars(plain) and "reset" not in vars(plain)
    assert plain.step_path == "native"
    # rendering records in Python, so the env (and a pool of it) steps through its Python step
    assert rendering.step_path == "python" and "strip chart" in rendering.step_path_reason
    for (observation, *rest), (rendered_observation, *rendered_rest) in zip(run(plain, 30), run(rendering, 30)):
        np.testing.assert_array_equal(observation, rendered_observation)
        assert rest == rendered_rest
    plain.close()
    rendering.close()


@requires("plots")
def test_render_fps_is_real_time(family_fmu):
    env = FMUEnv(suggest(open_fmu(family_fmu("probe", 2))).config, time_step=0.25, render_mode="rgb_array")
    assert env.metadata["render_fps"] == 4.0
    assert FMUEnv.metadata == {"render_modes": ["rgb_array"]}  # set on the instance, not the class
    env.close()


def test_the_cartpole_keeps_its_own_picture():
    env = modelicagym.make("cartpole", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(1)
    frame = env.render()
    assert env.strip_chart is None and env.step_path == "native"
    assert frame.shape == (400, 600, 3)
    env.close()


@requires("plots")
def test_many_variables_are_grouped_by_role_unit_and_kind(family_fmu):
    env = FMUEnv(suggest(open_fmu(family_fmu("probe", 3))).config, render_mode="rgb_array")
    series = env.strip_chart.series
    assert len(series) > MAX_PANELS  # the FMI 3.0 probe's arrays count one line per element
    panels, left_out = panels_of(series)
    assert left_out == [] and len(panels) <= MAX_PANELS
    assert sorted(i for panel in panels for i in panel) == list(range(len(series)))
    for panel in panels:
        assert len(panel) <= LINES_PER_PANEL
        assert len({(series[i].role, series[i].unit, series[i].kind) for i in panel}) == 1
    run(env, 5)
    assert env.render().shape[0] >= 100 * len(panels)
    env.close()


@requires("plots")
@pytest.mark.processes
def test_a_pool_of_charting_envs_draws_what_a_single_env_draws(cartpole_fmu):
    # the cart-pole's config would step natively, a whole slice in one C call, skipping the recording
    config = {**try_config(cartpole_fmu(2)), "max_episode_steps": 40}
    make = partial(FMUEnv, config, render_mode="rgb_array")
    with PoolVectorEnv([make] * 2, num_workers=2) as pool:
        pool.reset(seed=0)  # env 0 gets seed 0
        pool.action_space.seed(0)
        actions = [pool.action_space.sample() for _ in range(15)]
        for action in actions:
            pool.step(action)
        frames = pool.render()
    single = make()
    single.reset(seed=0)
    for action in actions:
        single.step(action[0])
    # the same chart, pixel for pixel: every step was recorded in the worker
    np.testing.assert_array_equal(frames[0], single.render())
    single.close()


@requires("plots")
def test_record_video_writes_a_video_of_any_fmu(family_fmu, tmp_path: Path):
    moviepy = pytest.importorskip("moviepy", reason="RecordVideo needs moviepy (pip install moviepy)")
    config = {**suggest(open_fmu(family_fmu("probe", 2))).config, "max_episode_steps": 20}
    env = RecordVideo(FMUEnv(config, render_mode="rgb_array"), str(tmp_path / "videos"),
                      episode_trigger=lambda _: True, disable_logger=True)
    run(env, 20)
    frame = env.render()
    env.close()
    (video,) = (tmp_path / "videos").glob("*.mp4")
    with moviepy.VideoFileClip(str(video)) as clip:
        assert clip.fps == env.metadata["render_fps"] == 10  # the probe's 0.1 s step, in real time
        assert clip.n_frames == 21  # the reset and 20 steps
        assert tuple(clip.size) == (frame.shape[1], frame.shape[0])


@pytest.mark.processes
def test_without_matplotlib_rendering_is_one_line_naming_the_extra(family_fmu):
    fmu = family_fmu("probe", 2)
    code = textwrap.dedent(f"""
        import sys
        sys.modules["matplotlib"] = None  # as if the plots extra were not installed
        from modelicagym import FMUEnv, ModelicaGymError
        from modelicagym.fmu import open_fmu
        from modelicagym.info import suggest
        config = suggest(open_fmu({str(fmu)!r})).config
        env = FMUEnv(config)  # no render mode: no matplotlib needed
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
        try:
            FMUEnv(config, render_mode="rgb_array")
        except ImportError as error:
            assert isinstance(error, ModelicaGymError)
            print(error)
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines() == [
        "the strip chart (render_mode='rgb_array', modelicagym try) needs matplotlib: pip install 'modelicagym[plots]'"
    ]
