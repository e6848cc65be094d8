"""Render one episode of each bundled environment as a GIF for its page (docs/images/<env>.gif).

A maintainers' script, not part of the site: run it from the repository's root after an env's
picture changes, with the ``plots`` extra installed (the pendulum draws a strip chart), and commit
the GIFs: ``python docs/make_env_gifs.py [--out docs/images]``. Each env is made with
``render_mode="rgb_array"`` and driven by a simple controller, so the GIF shows the task being done.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

import modelicagym
from modelicagym.models.pendulum.env import EnergySwingUp

#: frames kept from the episode (every k-th step) and the longest side of a frame, in pixels,
#: so that each GIF stays well under 300 KB (the pendulum's strip chart needs room for its labels)
FRAME_EVERY = {"cartpole": 2, "cartpole-continuous": 2, "pendulum": 5}
SIZE = {"cartpole": 320, "cartpole-continuous": 320, "pendulum": 480}
STEPS = 200


def lean(observation: np.ndarray) -> int:
    """Push the cart under the pole: right when the pole leans or falls right (theta below 90 deg),
    with a little of the cart's position and speed so that it stays on the track."""
    x, x_dot, theta, theta_dot = observation
    return int((np.pi / 2 - theta) - 0.3 * theta_dot + 0.01 * x + 0.1 * x_dot > 0)


def pd_force(observation: np.ndarray) -> np.ndarray:
    """The same as a force within ±15 N: a linear law on the pole's lean and the cart's motion."""
    x, x_dot, theta, theta_dot = observation
    force = 200.0 * (np.pi / 2 - theta) - 50.0 * theta_dot + 3.0 * x + 8.0 * x_dot
    return np.clip(np.array([force]), -15.0, 15.0)


POLICIES: dict[str, Callable[[np.ndarray], object]] = {
    "cartpole": lean,
    "cartpole-continuous": pd_force,
    "pendulum": EnergySwingUp(),
}


def episode_frames(name: str) -> list[Image.Image]:
    """One episode of ``name`` under its policy, every k-th rendered frame, scaled down."""
    env = modelicagym.make(name, render_mode="rgb_array")
    policy = POLICIES[name]
    observation, _ = env.reset(seed=0)
    frames = []
    for step in range(STEPS):
        if step % FRAME_EVERY[name] == 0:
            frames.append(_scaled(env.render(), SIZE[name]))
        observation, _, terminated, truncated, _ = env.step(policy(observation))
        if terminated or truncated:
            break
    frames.append(_scaled(env.render(), SIZE[name]))
    env.close()
    return frames


def _scaled(image: np.ndarray, size: int) -> Image.Image:
    frame = Image.fromarray(np.ascontiguousarray(image[..., :3]))
    frame.thumbnail((size, size))
    return frame.convert("P", palette=Image.Palette.ADAPTIVE, colors=32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "images")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in POLICIES:
        frames = episode_frames(name)
        path = args.out / f"{name}.gif"
        milliseconds = round(1000 * 0.05 * FRAME_EVERY[name])
        frames[0].save(path, save_all=True, append_images=frames[1:], duration=milliseconds, loop=0, optimize=True)
        print(f"{path}: {len(frames)} frames, {path.stat().st_size / 1024:.0f} KB")


if __name__ == "__main__":
    main()
