"""Sweep configurations: which env, which settings, how many repeats and episodes, which agent.

A sweep runs every setting ``repeats`` times, each for ``episodes`` episodes. A setting is a label
plus env option overrides applied on top of ``base_options``. Configs come from Python, from a dict,
or from a TOML/JSON file of the same shape::

    name = "force"                      # used in file names: letters, digits, '_' and '-'
    env = "cartpole"                    # id for modelicagym.make_vec
    episodes = 100
    repeats = 5
    seed = 0
    base_options = { m_cart = 10.0, max_episode_steps = 500 }

    [agent]                             # optional; defaults are the paper's
    n_bins = 10
    intervals = [[-2.4, 2.4], [-1.0, 1.0], [1.3614, 1.7802], [-2.0, 2.0]]   # or omit: Box bounds
    learning_rate = 0.2

    [[settings]]
    label = "5 N"
    options = { force = 5.0 }
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from modelicagym.agents import QLearningConfig
from modelicagym.errors import ConfigError

__all__ = ["AgentSpec", "ConfigError", "Setting", "SweepConfig", "load_config"]

_NAME = re.compile(r"^[A-Za-z0-9_-]+$")


@dataclass(frozen=True)
class Setting:
    """One point of a sweep: a label for tables and plots, and env option overrides."""

    label: str
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class AgentSpec:
    """The tabular agent of a sweep: binning (``intervals=None``: the observation Box bounds) and
    Q-learning hyperparameters."""

    n_bins: int = 10
    intervals: tuple[tuple[float, float], ...] | None = None
    q_learning: QLearningConfig = field(default_factory=QLearningConfig)


@dataclass(frozen=True)
class SweepConfig:
    """A named sweep over env settings; see the module docstring for the file format."""

    name: str
    settings: tuple[Setting, ...]
    episodes: int
    env: str = "cartpole"
    repeats: int = 5
    seed: int = 0
    base_options: Mapping[str, Any] = field(default_factory=dict)
    agent: AgentSpec = field(default_factory=AgentSpec)

    def __post_init__(self) -> None:
        if not _NAME.match(self.name):
            raise ConfigError(f"sweep name {self.name!r}: use letters, digits, '_' and '-' only")
        where = f"sweep {self.name!r}"
        if not self.settings:
            raise ConfigError(f"{where}: 'settings' is empty")
        labels = [s.label for s in self.settings]
        duplicates = sorted({label for label in labels if labels.count(label) > 1})
        if duplicates:
            raise ConfigError(f"{where}: duplicate setting labels {duplicates}")
        for key in ("episodes", "repeats"):
            value = getattr(self, key)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ConfigError(f"{where}: '{key}' must be an integer >= 1, got {value!r}")

    def options_for(self, setting: Setting) -> dict[str, Any]:
        """Env options of one setting: the base options updated by the setting's overrides."""
        return {**self.base_options, **setting.options}

    def scaled(self, episodes_scale: float) -> SweepConfig:
        """The same sweep with ``episodes`` multiplied by ``episodes_scale`` (at least 1 episode)."""
        if episodes_scale <= 0:
            raise ConfigError(f"episodes scale must be > 0, got {episodes_scale}")
        return replace(self, episodes=max(1, round(self.episodes * episodes_scale)))

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready form; :meth:`from_dict` reads it back."""
        data = asdict(self)
        data["settings"] = [{"label": s.label, "options": dict(s.options)} for s in self.settings]
        data["base_options"] = dict(self.base_options)
        agent = data.pop("agent")
        data["agent"] = {"n_bins": agent["n_bins"], **agent["q_learning"]}
        if agent["intervals"] is not None:
            data["agent"]["intervals"] = [list(pair) for pair in agent["intervals"]]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SweepConfig:
        """Validate and build a config from a dict (as read from TOML or JSON)."""
        if not isinstance(data, Mapping):
            raise ConfigError(f"a sweep config must be a table/object, got {type(data).__name__}")
        where = f"sweep {data.get('name', '<unnamed>')!r}"
        _check_keys(data, {f.name for f in fields(cls)}, {"name", "settings", "episodes"}, where)
        kwargs = dict(data)
        kwargs["settings"] = tuple(
            _setting(s, i, where) for i, s in enumerate(_list(data["settings"], "settings", where))
        )
        kwargs["base_options"] = _mapping(data.get("base_options", {}), "base_options", where)
        kwargs["agent"] = _agent(data.get("agent", {}), where)
        for key, kind in (("name", str), ("env", str), ("seed", int)):
            if key in kwargs and (not isinstance(kwargs[key], kind) or isinstance(kwargs[key], bool)):
                raise ConfigError(f"{where}: '{key}' must be {kind.__name__}, got {kwargs[key]!r}")
        return cls(**kwargs)


def load_config(path: str | Path) -> SweepConfig:
    """Read a sweep config from a ``.toml`` or ``.json`` file."""
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".json":
            data = json.loads(path.read_text(encoding="utf-8"))
        elif suffix == ".toml":
            data = _toml_loads(path.read_text(encoding="utf-8"))
        else:
            raise ConfigError(f"{path}: sweep configs are .toml or .json files")
    except (ValueError, OSError) as error:  # JSON and TOML decode errors are ValueErrors
        if isinstance(error, ConfigError):
            raise
        raise ConfigError(f"{path}: {error}") from error
    try:
        return SweepConfig.from_dict(data)
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from error


def _toml_loads(text: str) -> dict[str, Any]:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError as error:
            raise ConfigError("reading TOML needs Python >= 3.11 or the 'tomli' package; use JSON") from error
    return tomllib.loads(text)


def _check_keys(data: Mapping[str, Any], allowed: set[str], required: set[str], where: str) -> None:
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ConfigError(f"{where}: unknown keys {unknown}; allowed: {sorted(allowed)}")
    missing = sorted(required - set(data))
    if missing:
        raise ConfigError(f"{where}: missing keys {missing}")


def _list(value: Any, key: str, where: str) -> Sequence[Any]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise ConfigError(f"{where}: '{key}' must be a list, got {value!r}")
    return value


def _mapping(value: Any, key: str, where: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: '{key}' must be a table/object of option values, got {value!r}")
    return dict(value)


def _setting(value: Any, index: int, where: str) -> Setting:
    where = f"{where}, settings[{index}]"
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: a setting is a table with 'label' and 'options', got {value!r}")
    _check_keys(value, {"label", "options"}, {"label"}, where)
    if not isinstance(value["label"], str) or not value["label"]:
        raise ConfigError(f"{where}: 'label' must be a non-empty string, got {value['label']!r}")
    return Setting(value["label"], _mapping(value.get("options", {}), "options", where))


def _agent(value: Any, where: str) -> AgentSpec:
    where = f"{where}, agent"
    data = _mapping(value, "agent", where)
    q_keys = {f.name for f in fields(QLearningConfig)}
    _check_keys(data, {"n_bins", "intervals"} | q_keys, set(), where)
    n_bins = data.get("n_bins", AgentSpec.n_bins)
    if not isinstance(n_bins, int) or isinstance(n_bins, bool) or n_bins < 1:
        raise ConfigError(f"{where}: 'n_bins' must be an integer >= 1, got {n_bins!r}")
    intervals = data.get("intervals")
    if intervals is not None:
        intervals = _intervals(_list(intervals, "intervals", where), where)
    try:
        q_learning = QLearningConfig(**{k: v for k, v in data.items() if k in q_keys})
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from error
    return AgentSpec(n_bins, intervals, q_learning)


def _intervals(pairs: Sequence[Any], where: str) -> tuple[tuple[float, float], ...]:
    try:
        result = tuple((float(low), float(high)) for low, high in pairs)
    except (TypeError, ValueError):
        result = ()
    if not result or any(low >= high for low, high in result):
        raise ConfigError(f"{where}: 'intervals' must be a list of [low, high] numbers with low < high, got {pairs!r}")
    return result
