"""The native library's structs and constants are checked against their Python mirrors at load."""

from __future__ import annotations

import ctypes
import shutil
import subprocess

import pytest

from modelicagym.native.abi import NativeABIError, check_layout, expected_layout, exported_layout, layout_differences
from modelicagym.native.library import SOURCES_DIR, load_library


def test_the_loaded_library_matches_every_mirror():
    exported = exported_layout(load_library())
    assert layout_differences(exported, expected_layout()) == []
    assert exported["mg_env"] > 0 and "mg_batch.final_ready" in exported and exported["MG_FMU_ERROR"] == 8


def _build_abi_table(tmp_path, edit) -> ctypes.CDLL:
    """The layout table of a copy of our C sources changed by ``edit(folder)``."""
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        pytest.skip("no C compiler")
    sources = tmp_path / "csrc"
    shutil.copytree(SOURCES_DIR, sources)
    edit(sources)
    library = tmp_path / "abi.so"
    subprocess.run([compiler, "-shared", "-fPIC", "-std=c11", "-o", str(library), str(sources / "abi.c")], check=True)
    table = ctypes.CDLL(str(library))
    table.mg_abi.restype, table.mg_abi.argtypes = ctypes.c_int64, (ctypes.c_void_p,)
    return table


@pytest.mark.processes
def test_a_header_changed_without_its_mirror_is_a_clear_error(tmp_path):
    def add_a_field(sources):
        header = sources / "step.h"
        text = header.read_text()
        header.write_text(text.replace("    int32_t discrete;", "    int32_t discrete;\n    int32_t added;", 1))

    table = _build_abi_table(tmp_path, add_a_field)
    with pytest.raises(NativeABIError) as error:
        check_layout(table, "the-test-library.so")
    message = str(error.value)
    assert "the-test-library.so" in message and "native/abi.py" in message
    assert "mg_env: size" in message and "mg_env.component: offset" in message
    assert "mg_batch" not in message  # only what changed


@pytest.mark.processes
def test_a_changed_constant_is_named(tmp_path):
    def renumber(sources):
        header = sources / "step.h"
        header.write_text(header.read_text().replace("MG_BAD_ACTION = 64", "MG_BAD_ACTION = 128"))

    table = _build_abi_table(tmp_path, renumber)
    with pytest.raises(NativeABIError, match=r"MG_BAD_ACTION: value 128 in C, 64 in Python"):
        check_layout(table, "x.so")
