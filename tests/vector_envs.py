"""Small deterministic envs for the pool's tests: any space, infos, a cost knob, and faults.

They are plain ``gymnasium.Env`` subclasses in an importable module, so worker processes started
with ``forkserver``/``spawn`` can unpickle env fns that refer to them.
"""

from __future__ import annotations

import copy
import ctypes
import os
import signal
import time
from functools import partial
from typing import Any, Callable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

SPACES: dict[str, gym.Space] = {
    "box": spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32),
    "box2d": spaces.Box(0, 255, shape=(2, 3), dtype=np.uint8),
    "discrete": spaces.Discrete(5, start=-2),
    "multidiscrete": spaces.MultiDiscrete([3, 4]),
    "multibinary": spaces.MultiBinary(4),
    "dict": spaces.Dict(
        {"position": spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float64), "mode": spaces.Discrete(3)}
    ),
    "tuple": spaces.Tuple((spaces.Discrete(2), spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32))),
    "text": spaces.Text(max_length=5, min_length=1),
}


def busy_wait(seconds: float) -> None:
    """Burn CPU for ``seconds`` (a stand-in for an expensive simulation step)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


class CountEnv(gym.Env):
    """A deterministic env whose episodes end at seed-dependent times.

    Observations are samples of the observation space drawn from the env's seeded generator; the
    reward is the sum of the flattened action plus the step count (so wrong actions show); episodes
    last 3..``max_len`` steps and end terminated or truncated depending on their length. Infos are
    non-empty every ``info_every`` steps and at episode ends, with ints, floats, arrays, strings and
    nested dicts. ``cost`` seconds of busy CPU per step; with ``fmu_share`` that fraction of it is
    counted in ``fmu_time_ns`` as an FMU env would.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(
        self,
        obs: str = "box",
        act: str = "discrete",
        max_len: int = 20,
        info_every: int = 3,
        cost: float = 0.0,
        fmu_share: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        # copies: the observation space is seeded per env, and envs of a SyncVectorEnv share a process
        self.observation_space = copy.deepcopy(SPACES[obs])
        self.action_space = copy.deepcopy(SPACES[act])
        self.max_len = max_len
        self.info_every = info_every
        self.cost = cost
        self.fmu_share = fmu_share
        self.render_mode = render_mode
        self.steps = 0
        self.length = max_len
        self.label = "count"
        if fmu_share is not None:
            self.fmu_time_ns = 0

    @property
    def pid(self) -> int:
        """The id of the process this env lives in."""
        return os.getpid()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.observation_space.seed(int(self.np_random.integers(2**31)))
        self.steps = 0
        self.length = int(self.np_random.integers(3, self.max_len + 1))
        info: dict[str, Any] = {"length": self.length}
        if options:
            info["options"] = dict(options)
        return self.observation_space.sample(), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        assert self.action_space.contains(action), f"{action!r} not in {self.action_space}"
        self._spend()
        self.steps += 1
        reward = float(np.sum(spaces.flatten(self.action_space, action))) + self.steps
        ended = self.steps >= self.length
        terminated, truncated = ended and self.length % 2 == 1, ended and self.length % 2 == 0
        info: dict[str, Any] = {}
        if self.info_every and self.steps % self.info_every == 0:
            info.update(step=self.steps, progress=self.steps / self.length, tag=f"s{self.steps}")
            info["stats"] = {"double": 2 * self.steps, "vector": np.full(2, self.steps, dtype=np.int32)}
        if ended:
            info["end"] = "terminated" if terminated else "truncated"
        return self.observation_space.sample(), reward, terminated, truncated, info

    def _spend(self) -> None:
        if self.cost <= 0.0:
            return
        start = time.perf_counter_ns()
        busy_wait(self.cost)
        if self.fmu_share is not None:
            self.fmu_time_ns += int((time.perf_counter_ns() - start) * self.fmu_share)

    def render(self) -> np.ndarray:
        return np.full((2, 2, 3), self.steps, dtype=np.uint8)

    def double(self, x: int) -> int:
        return 2 * x

    def fail(self) -> None:
        raise KeyError("requested failure")

    def generator(self) -> Any:
        return (x for x in range(3))


class SafeCountEnv(CountEnv):
    """A :class:`CountEnv` that says it is safe in the calling process (it runs no native code),
    as the bundled models do: the pool's default layout may step it there."""

    safe_in_caller = True


class MadeElsewhere:
    """An env fn that refuses to make its env in process ``pid`` (the test's: "never in the caller")."""

    def __init__(self, fn: Callable[[], gym.Env], pid: int) -> None:
        self.fn, self.pid = fn, pid

    def __call__(self) -> gym.Env:
        if os.getpid() == self.pid:
            raise AssertionError("this env was made in the calling process")
        return self.fn()


def count_fns(n: int, **kwargs: Any) -> list[Callable[[], CountEnv]]:
    """Env fns whose episodes end at different times (``max_len`` differs per env)."""
    return [partial(CountEnv, max_len=4 + 3 * i, **kwargs) for i in range(n)]


class FaultyEnv(CountEnv):
    """A :class:`CountEnv` that fails on purpose.

    ``fault`` is one of ``segfault`` (a real SIGSEGV from native code), ``exit`` (``os._exit(3)``),
    ``hang`` (sleeps for an hour), ``raise`` (``ValueError``), ``sigkill``; it strikes at step
    ``at_step`` of an episode (``when="step"``), in ``reset`` (``when="reset"``) or while the env is
    created (``when="init"``). With ``marker`` (a file path) it strikes only once over all
    processes: the first failure creates the file.
    """

    def __init__(
        self, fault: str, when: str = "step", at_step: int = 2, marker: str | None = None, **kwargs: Any
    ) -> None:
        super().__init__(**kwargs)
        self.fault, self.when, self.at_step, self.marker = fault, when, at_step, marker
        if when == "init":
            self._strike()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        if self.when == "reset":
            self._strike()
        return super().reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        if self.when == "step" and self.steps + 1 == self.at_step:
            self._strike()
        return super().step(action)

    def _strike(self) -> None:
        if self.marker is not None:
            if os.path.exists(self.marker):
                return
            open(self.marker, "w").close()
        if self.fault == "segfault":
            ctypes.string_at(0)
        elif self.fault == "exit":
            os._exit(3)
        elif self.fault == "sigkill":
            os.kill(os.getpid(), signal.SIGKILL)
        elif self.fault == "hang":
            time.sleep(3600)
        elif self.fault == "hang_in_c":  # blocked inside a C call, as a doStep that never returns
            ctypes.CDLL(None).pause()
        elif self.fault == "raise":
            raise ValueError(f"{self.fault} at step {self.steps + 1}")
        else:
            raise AssertionError(f"unknown fault {self.fault}")


class SpacedEnv(CountEnv):
    """A :class:`CountEnv` with a different observation space (for the space-mismatch check)."""

    def __init__(self) -> None:
        super().__init__(obs="multibinary")


class TrivialEnv(gym.Env):
    """Does nothing, as fast as possible: measures the pool's own overhead."""

    observation_space = spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)
    action_space = spaces.Discrete(2)

    def __init__(self) -> None:
        self._obs = np.zeros(4, dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        return self._obs, {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        return self._obs, 1.0, False, False, {}


class MalformedEnv(CountEnv):
    """A :class:`CountEnv` whose step returns a result that does not fit: ``bad`` is
    ``"observation"`` (wrong shape) or ``"reward"`` (not a number)."""

    def __init__(self, bad: str) -> None:
        super().__init__()
        self.bad = bad

    def step(self, action):
        observation, reward, terminated, truncated, info = super().step(action)
        if self.bad == "observation":
            return np.zeros(7), reward, terminated, truncated, info
        return observation, "a lot", terminated, truncated, info


class ActionRecorder(gym.Env):
    """Remembers the last action it was given, as given (a ``Box(shape=())`` action space)."""

    observation_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
    action_space = spaces.Box(0.0, 1.0, shape=(), dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.last_action = None
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action):
        self.last_action = action
        return np.zeros(1, dtype=np.float32), 0.0, False, False, {}


class BoundedEnv(CountEnv):
    """A :class:`CountEnv` whose observation bounds depend on ``high`` (same shape and dtype)."""

    def __init__(self, high: float) -> None:
        super().__init__()
        self.observation_space = spaces.Box(-high, high, shape=(3,), dtype=np.float32)


class WordSpace(gym.Space):
    """A custom space (Gymnasium knows no shared-memory layout for it): words over ``letters``."""

    def __init__(self, letters: str = "ab", seed: int | None = None) -> None:
        super().__init__(None, None, seed)
        self.letters = letters

    def sample(self, mask: Any = None, probability: Any = None) -> str:
        return "".join(self.np_random.choice(list(self.letters), size=int(self.np_random.integers(1, 4))))

    def contains(self, x: Any) -> bool:
        return isinstance(x, str) and set(x) <= set(self.letters)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, WordSpace) and other.letters == self.letters


class WordEnv(gym.Env):
    """Custom spaces both ways: the observation is the words received so far (variable length),
    the episode ends once ``length`` letters have been received."""

    observation_space = WordSpace("ab")
    action_space = WordSpace("ab")

    def __init__(self, length: int = 6) -> None:
        self.length = length
        self.text = ""

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[str, dict]:
        super().reset(seed=seed)
        self.text = "a" * int(self.np_random.integers(0, 3))
        return self.text, {}

    def step(self, action: str) -> tuple[str, float, bool, bool, dict]:
        if not self.action_space.contains(action):
            raise ValueError(f"not a word over 'ab': {action!r}")
        self.text += action
        return self.text, float(len(action)), len(self.text) >= self.length, False, {"last": action}


class GrowingEnv(gym.Env):
    """An observation of dynamic shape (a ``Sequence``, no static shared-memory layout) and a
    ``Dict`` action holding a ``Graph``: how many nodes the graph had, one entry per step."""

    observation_space = spaces.Sequence(spaces.Discrete(8))
    action_space = spaces.Dict({"graph": spaces.Graph(spaces.Box(-1.0, 1.0, (2,)), None), "go": spaces.Discrete(2)})

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[tuple, dict]:
        super().reset(seed=seed)
        self.seen: tuple[int, ...] = ()
        return self.seen, {}

    def step(self, action: dict) -> tuple[tuple, float, bool, bool, dict]:
        self.seen += (min(len(action["graph"].nodes), 7),)
        return self.seen, float(action["go"]), len(self.seen) >= 5, False, {}


class GatedEnv(CountEnv):
    """A :class:`CountEnv` whose steps wait until the file ``gate`` exists (a slow env whose
    slowness the test controls, with no timing in it)."""

    def __init__(self, gate: str, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.gate = gate

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        while not os.path.exists(self.gate):
            time.sleep(0.001)
        return super().step(action)


class ConcurrencyProbe(CountEnv):
    """A `CountEnv` that counts, across processes, how many envs are inside ``reset`` or ``step``
    at once: a counter file under an ``fcntl`` lock holds ``(inside now, most ever inside)``.
    Each call stays inside for ``hold`` seconds (asleep), so that calls the pool lets run together
    do overlap."""

    def __init__(self, counter: str, hold: float = 0.02, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.counter = counter
        self.hold = hold

    @staticmethod
    def most_inside(counter: str) -> int:
        """The most envs ever inside ``reset``/``step`` at once."""
        with open(counter) as file:
            return int(file.read().split()[1])

    def _inside(self, change: int) -> None:
        import fcntl

        with open(self.counter, "r+") as file:
            fcntl.flock(file, fcntl.LOCK_EX)
            now, most = (int(x) for x in (file.read().split() or ["0", "0"]))
            now += change
            file.seek(0)
            file.truncate()
            file.write(f"{now} {max(now, most)}")

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        self._inside(+1)
        try:
            time.sleep(self.hold)
            return super().reset(seed=seed, options=options)
        finally:
            self._inside(-1)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        self._inside(+1)
        try:
            time.sleep(self.hold)
            return super().step(action)
        finally:
            self._inside(-1)
