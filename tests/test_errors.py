"""One error hierarchy: everything modelicagym raises is a ModelicaGymError and the built-in type a
caller would catch; the command line prints them as one line and exits 1."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import modelicagym
from modelicagym import errors
from modelicagym.fmu import errors as fmu_errors
from modelicagym.fmu.build import FMUBuildError
from modelicagym.vector import errors as pool_errors


@pytest.mark.parametrize(
    "error, builtin",
    [
        (errors.ConfigError, ValueError),
        (errors.ConfigTypeError, TypeError),
        (errors.ArgumentError, ValueError),
        (errors.ArgumentTypeError, TypeError),
        (errors.ActionError, ValueError),
        (errors.ActionTypeError, TypeError),
        (errors.NotFoundError, FileNotFoundError),
        (errors.DataError, ValueError),
        (errors.BuildError, RuntimeError),
        (errors.NativeBuildError, RuntimeError),
        (errors.ExtraNotInstalledError, ImportError),
        (errors.LoopDivergedError, ArithmeticError),
        (FMUBuildError, RuntimeError),
        (fmu_errors.FMUNotFoundError, FileNotFoundError),
        (fmu_errors.InvalidFMUError, ValueError),
        (fmu_errors.VariableError, KeyError),
        (pool_errors.PoolError, RuntimeError),
        (pool_errors.WorkerDiedError, RuntimeError),
    ],
)
def test_every_family_is_ours_and_the_builtin_a_caller_expects(error: type, builtin: type) -> None:
    assert issubclass(error, errors.ModelicaGymError) and issubclass(error, builtin)


def test_fmu_errors_and_build_errors_share_their_roots() -> None:
    assert issubclass(FMUBuildError, fmu_errors.FMUError) and issubclass(FMUBuildError, errors.BuildError)
    assert issubclass(fmu_errors.FMUCallError, errors.ModelicaGymError)


def test_real_mistakes_raise_the_right_class(tmp_path: Path) -> None:
    with pytest.raises(errors.ConfigTypeError, match="unknown FMUEnv config key 'time_stepp'.*time_step"):
        modelicagym.make("cartpole", time_stepp=0.1)
    with pytest.raises(fmu_errors.FMUNotFoundError):
        modelicagym.FMUEnv(fmu=tmp_path / "missing.fmu", outputs=["x"])
    with pytest.raises(fmu_errors.VariableError, match="Did you mean 'theta'"):
        modelicagym.FMUEnv(fmu=modelicagym.models.cartpole.cartpole_fmu(2), outputs=["thetta"])
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    with pytest.raises(errors.ActionError, match="out of range"):
        env.step(3)
    with pytest.raises(errors.ArgumentError):
        modelicagym.make_vec("cartpole", n=0)


@pytest.mark.processes
def test_a_native_build_without_a_working_compiler_is_a_build_error(tmp_path: Path) -> None:
    code = (
        "from modelicagym.errors import BuildError\n"
        "from modelicagym.native.library import load_library\n"
        "try:\n    load_library()\nexcept BuildError as error:\n    print(type(error).__name__)\n"
    )
    env = {**os.environ, "CC": "false", "MODELICAGYM_CACHE": str(tmp_path)}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert result.stdout.strip() == "NativeBuildError", result.stderr


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "modelicagym.cli", *args], capture_output=True, text=True, timeout=120)


@pytest.mark.processes
def test_the_cli_prints_an_error_as_one_line_and_exits_1(tmp_path: Path) -> None:
    result = _cli("info", str(tmp_path / "missing.fmu"))
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "missing.fmu" in lines[0]


@pytest.mark.processes
def test_the_cli_shows_the_traceback_with_debug(tmp_path: Path) -> None:
    result = _cli("--debug", "info", str(tmp_path / "missing.fmu"))
    assert result.returncode == 1
    assert "Traceback" in result.stderr and "FMUNotFoundError" in result.stderr


@pytest.mark.processes
def test_errors_of_the_pool_keep_gymnasiums_types() -> None:
    from gymnasium.error import ClosedEnvironmentError

    pool = modelicagym.make_vec("cartpole", n=2)
    pool.close()
    with pytest.raises(ClosedEnvironmentError) as info:
        pool.step(np.zeros(2, dtype=np.int64))
    assert isinstance(info.value, errors.ModelicaGymError)


def test_the_error_root_is_where_users_look_for_it():
    """``except modelicagym.ModelicaGymError`` catches a pool's, the FMU runtime's and a config's errors."""
    import modelicagym

    assert modelicagym.ModelicaGymError is errors.ModelicaGymError
    with pytest.raises(modelicagym.ModelicaGymError, match="no modelicagym environment named 'cartpol'"):
        modelicagym.make_vec("cartpol", n=2)
