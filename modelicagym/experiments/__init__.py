"""The paper's cart-pole sweeps: config -> runs on the pool -> result files -> plots and report."""

from modelicagym.experiments.analysis import SettingSummary, moving_average, summarize
from modelicagym.experiments.cli import add_parsers, main
from modelicagym.experiments.config import AgentSpec, ConfigError, Setting, SweepConfig, load_config
from modelicagym.experiments.paper import PAPER_SWEEPS
from modelicagym.experiments.ray_runner import RayRunner
from modelicagym.experiments.report import render_report
from modelicagym.experiments.results import SweepResult, read_sweep, write_sweep
from modelicagym.experiments.runner import LocalRunner, SweepRunner, run_sweep, run_sweeps

__all__ = [
    "PAPER_SWEEPS",
    "AgentSpec",
    "ConfigError",
    "LocalRunner",
    "RayRunner",
    "Setting",
    "SettingSummary",
    "SweepConfig",
    "SweepResult",
    "SweepRunner",
    "add_parsers",
    "load_config",
    "main",
    "moving_average",
    "read_sweep",
    "render_report",
    "run_sweep",
    "run_sweeps",
    "summarize",
    "write_sweep",
]
