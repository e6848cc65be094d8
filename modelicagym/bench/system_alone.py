"""``bench fmu`` on a system: its step against its FMUs stepped alone.

A system of light FMUs should cost about the sum of their steps: each FMU is stepped once per
communication step, and what the system adds (the copies along the connections, the master's
loop) is small. To show it, each FMU of the system becomes an env of its own (`alone_configs`: the
inputs the system writes into it as its actions, the float ones held at their start values; the
outputs the system reads as its observations; its parameters; a step of one communication step),
and a single env of the system and one of each FMU are timed in interleaved rounds (`measure`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from modelicagym.bench import median
from modelicagym.bench.throughput import interleaved_rates
from modelicagym.env import FMUEnv
from modelicagym.system import SystemDescription

__all__ = ["alone_configs", "measure", "report_lines"]

#: steps a round's calibration starts from
_FIRST_STEPS = 256


def alone_configs(config: Mapping[str, Any], system: SystemDescription) -> dict[str, dict[str, Any]]:
    """``{component: FMUEnv config}``: each FMU of ``system`` (as ``config`` runs it) as an env of its own."""
    probe = FMUEnv(dict(config))
    try:
        instance, time_step = probe.fmu, probe.time_step
        parameters = {**system.parameter_values,
                      **{k: v for k, v in config.get("parameters", {}).items() if not callable(v)}}
        configs = {}
        for name, component in system.components.items():
            fmu = instance.components[name]
            if component.description is None:
                continue  # a table: no FMU to step alone
            inputs = [v.name for v in fmu.input_variables]
            held = {v.name: (float(v.start or 0.0),) * 2 for v in fmu.input_variables
                    if v.kind == "float" and not v.shape}
            configs[name] = {
                "fmu": str(component.source), "mode": fmu.mode, "inputs": inputs,
                "outputs": [v.name for v in fmu.output_variables] or [component.outputs[0].name],
                "parameters": {k[len(name) + 1:]: v for k, v in parameters.items() if system.split(k)[0] == name},
                "time_step": time_step / instance.substeps, "action_bounds": held or None,
                "max_episode_steps": config.get("max_episode_steps"),
            }
    finally:
        probe.close()
    return configs


def measure(config: Mapping[str, Any], system: SystemDescription, repeats: int, seconds: float,
            loop: Callable[[FMUEnv, int], Any], progress: Callable[[str], None]) -> dict[str, Any]:
    """Microseconds per step of the system (a single env of ``config``) and of each FMU alone
    (``loop`` steps an env with sampled actions), medians of interleaved rounds."""
    envs = {"system": FMUEnv(dict(config))}
    try:
        for name, alone in alone_configs(config, system).items():
            envs[name] = FMUEnv(alone)
        runs = {name: loop(env, 1) for name, env in envs.items()}
        samples, _ = interleaved_rates(runs, repeats, seconds, _FIRST_STEPS, progress=progress)
        paths = {name: env.step_path for name, env in envs.items()}
    finally:
        for env in envs.values():
            env.close()
    us = {name: 1e6 / median(values) for name, values in samples.items()}
    substeps = envs["system"].fmu.substeps
    alone = sum(value for name, value in us.items() if name != "system") * substeps
    return {"us_per_step": us, "step_paths": paths, "substeps": substeps, "sum_alone_us": alone}


def report_lines(result: Mapping[str, Any]) -> list[str]:
    """The comparison as lines of the report."""
    us, paths = result["us_per_step"], result["step_paths"]
    times = "" if result["substeps"] == 1 else f" x {result['substeps']} substeps"
    lines = ["a system's step against its FMUs stepped alone (each a single env of its own; wall us a step):"]
    lines += [f"  {name} alone: {value:.1f} us ({paths[name]} step path)" for name, value in us.items()
              if name != "system"]
    lines.append(f"  sum of the FMUs alone{times}: {result['sum_alone_us']:.1f} us")
    lines.append(f"  the system: {us['system']:.1f} us ({paths['system']} step path), "
                 f"{us['system'] / result['sum_alone_us']:.2f}x the sum")
    return lines
