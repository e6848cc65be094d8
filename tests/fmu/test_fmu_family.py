"""The test FMUs themselves: valid model descriptions, declared capabilities, and the variables
and spaces the runtime derives from them."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu
from fmu_family import PROBE3_INPUTS, PROBE3_OUTPUTS, PROBE_INPUTS, PROBE_OUTPUTS, VARIANTS, Variant
from gymnasium import spaces

from modelicagym.env.spaces import space_for
from modelicagym.fmu import open_fmu
from modelicagym.fmu.build import FRAMEWORK_DIR
from modelicagym.models.cartpole import MODEL_DIR as CARTPOLE_DIR


@pytest.mark.parametrize("name", sorted(VARIANTS))
def test_every_member_is_a_valid_fmu_with_a_binary(family_fmu, name, fmi_version):
    skip_unless_described(name, fmi_version)
    path = family_fmu(name, fmi_version)
    assert validate_fmu(str(path)) == []
    description = open_fmu(path)
    assert description.fmi_version == fmi_version
    assert description.modes == ("cs", "me")
    assert description.library_path("cs").is_file()
    assert description.has_sources


@pytest.mark.processes
@pytest.mark.parametrize("name", ["cartpole", *sorted(VARIANTS)])
def test_sources_compile_without_warnings(name: str, tmp_path: Path) -> None:
    """The framework (both adapters) and the model, with the variant's definitions (hooks included):
    the library's cart-pole and every member of the test family."""
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("gcc not available")
    variant = Variant(CARTPOLE_DIR) if name == "cartpole" else VARIANTS[name]
    defines = "".join(f"#define {k} {'' if v is None else v}\n" for k, v in variant.defines.items())
    (tmp_path / "build_config.h").write_text(f'#define FMU_INSTANTIATION_TOKEN "x"\n{defines}')
    sources = [FRAMEWORK_DIR / f for f in ("fmu_instance.c", "fmu_solver.c", "fmi2Functions.c", "fmi3Functions.c")]
    result = subprocess.run(
        [gcc, "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-fsyntax-only", f"-I{tmp_path}",
         f"-I{FRAMEWORK_DIR}", f"-I{variant.model_dir}", f"-I{Path(fmpy.__file__).parent / 'c-code'}",
         *map(str, sources), *map(str, sorted(variant.model_dir.glob("*.c")))],
        capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("name", sorted(VARIANTS))
def test_declared_capabilities(family_fmu, name, fmi_version):
    skip_unless_described(name, fmi_version)
    variant, description = VARIANTS[name], open_fmu(family_fmu(name, fmi_version))
    for mode in ("cs", "me"):
        assert description.once_per_process(mode) is variant.once_per_process
        assert description.can_snapshot(mode) is variant.snapshots
    assert description.default_experiment.start_time == (variant.start_time or 0.0)


def test_probe_variables(family_fmu, fmi_version):
    d = open_fmu(family_fmu("probe", fmi_version))
    assert [v.name for v in d.inputs] == list(PROBE_INPUTS if fmi_version == 2 else PROBE3_INPUTS)
    assert [v.name for v in d.outputs] == list(PROBE_OUTPUTS if fmi_version == 2 else PROBE3_OUTPUTS)
    gear, mode, enable, fault = d.variable("gear"), d.variable("mode"), d.variable("enable"), d.variable("fault")
    assert (gear.kind, gear.bounds()) == ("integer", (0, 4))
    assert gear.fmi_type == ("Integer" if fmi_version == 2 else "Int32")
    assert (mode.kind, mode.bounds(), mode.start) == ("enumeration", (1, 3), 1)
    assert mode.enumeration_items == (("off", 1), ("heat", 2), ("cool", 3))
    assert (enable.kind, enable.start) == ("boolean", False)
    assert fault.kind == "enumeration" and fault.settable_before_initialization
    assert d.variable("gain").settable and not d.variable("limit").settable
    assert d.variable("steps").bounds() == (-(2**31), 2**31 - 1)
    if fmi_version == 3:
        assert d.variable("u").shape == (3,) and d.variable("u").start == [0.0, 0.0, 0.0]
        assert d.variable("y").shape == (2, 3) and d.variable("y").size == 6
        assert d.variable("positive").shape == (3,)
        trim, tag, thrust, level = (d.variable(n) for n in ("trim", "tag", "thrust", "level"))
        assert (trim.fmi_type, trim.kind, trim.bounds()) == ("Int8", "integer", (-100, 100))
        assert (tag.fmi_type, tag.kind, tag.bounds()) == ("UInt64", "integer", (0, 2**64 - 1))
        assert (thrust.fmi_type, thrust.kind) == ("Float32", "float")
        assert (level.fmi_type, level.bounds()) == ("UInt16", (0, 2**16 - 1))  # the type's limits


def test_spaces_of_each_kind(family_fmu, fmi_version):
    d = open_fmu(family_fmu("probe", fmi_version))

    def space(*names):
        return space_for([d.variable(n) for n in names])

    assert space("gear") == spaces.Discrete(5, start=0)
    assert space("mode") == spaces.Discrete(3, start=1)
    assert space("speed") == spaces.Discrete(17, start=-8)
    assert space("enable") == spaces.Discrete(2)
    assert space("enable", "boost") == spaces.MultiBinary(2)
    multi = space("gear", "mode")
    assert isinstance(multi, spaces.MultiDiscrete)
    np.testing.assert_array_equal(multi.nvec, [5, 3])
    np.testing.assert_array_equal(multi.start, [0, 1])
    force = space("force")
    assert isinstance(force, spaces.Box) and force.shape == (1,)
    np.testing.assert_array_equal([force.low, force.high], [[-10.0], [10.0]])
    steps = space("steps")
    assert isinstance(steps, spaces.Box) and steps.dtype == np.int64 and steps.shape == ()
    mixed = space("gear", "enable", "force")
    assert isinstance(mixed, spaces.Dict) and set(mixed.keys()) == {"gear", "enable", "force"}
    if fmi_version == 3:
        u, y, positive = space("u"), space("y"), space("positive")
        assert isinstance(u, spaces.Box) and u.shape == (3,) and u.low.tolist() == [-1.0] * 3
        assert isinstance(y, spaces.Box) and y.shape == (2, 3) and np.all(np.isinf(y.high))
        assert positive == spaces.MultiBinary([3])
        assert isinstance(space("u", "force"), spaces.Dict)  # an array next to a scalar
        assert space("trim") == spaces.Discrete(201, start=-100)
        assert space("trim", "gear") == spaces.MultiDiscrete([201, 5], start=[-100, 0])
        thrust, tag, level = space("thrust"), space("tag"), space("level")
        assert isinstance(thrust, spaces.Box) and (thrust.dtype, thrust.shape) == (np.float32, (1,))
        assert isinstance(tag, spaces.Box) and (tag.dtype, tag.shape) == (np.uint64, ())
        assert (int(tag.low), int(tag.high)) == (0, 2**64 - 1)
        assert isinstance(level, spaces.Box) and level.dtype == np.int64  # no declared bounds
        assert (int(level.low), int(level.high)) == (0, 2**16 - 1)
        assert isinstance(space("thrust", "position"), spaces.Dict)  # float32 next to float64


def skip_unless_described(name: str, fmi_version: int) -> None:
    """Skip a member that is written for the other FMI version only."""
    if fmi_version not in VARIANTS[name].fmi_versions:
        pytest.skip(f"{name} is an FMI {VARIANTS[name].fmi_versions[0]}.0 FMU only")
