"""Shared fixtures: FMUs built once per session (from the content-hashed build cache)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Mapping

import pytest

from modelicagym.fmu.build import DefineValue, build_source_fmu
from modelicagym.models.cartpole import cartpole_fmu

TEST_FMUS_DIR = Path(__file__).resolve().parent / "fmus"


@pytest.fixture(scope="session")
def cartpole_fmu2() -> Path:
    """The Cart-Pole FMU, FMI 2.0 (co-simulation + model exchange)."""
    return cartpole_fmu(2)


@pytest.fixture(scope="session")
def cartpole_fmu3() -> Path:
    """The Cart-Pole FMU, FMI 3.0 (co-simulation + model exchange)."""
    return cartpole_fmu(3)


@pytest.fixture(scope="session")
def build_test_fmu() -> Callable[..., Path]:
    """Build a test FMU from ``tests/fmus/<name>/``: ``build_test_fmu(name, fmi_version=2, defines=None)``.

    Results are memoized for the session (and cached on disk by content hash).
    """
    built: dict[tuple, Path] = {}

    def build(name: str, fmi_version: int = 2, defines: Mapping[str, DefineValue] | None = None) -> Path:
        key = (name, fmi_version, tuple(sorted((defines or {}).items())))
        if key not in built:
            built[key] = build_source_fmu(TEST_FMUS_DIR / name, fmi_version, defines=defines)
        return built[key]

    return build
