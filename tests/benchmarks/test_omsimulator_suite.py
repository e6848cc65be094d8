"""``python -m benchmarks omsimulator-suite``: OMSimulator's test-suite systems through modelicagym.

On a suite of our own (systems built from our C FMUs, laid out as OMSimulator's ``testsuite/``),
the run says which systems load and run, skips the one whose FMU has no Linux binary, tells a
refusal for another defect from the one OMSimulator names, and says the same of the systems zipped
into ``.ssp`` archives. Where ``MODELICAGYM_OMSIMULATOR_TESTSUITE``
names OMSimulator's own ``testsuite/`` folder (a clone of github.com/OpenModelica/OMSimulator has it;
CI has not), the acceptance runs on it: every system whose FMUs have Linux binaries loads and runs,
every value its scripts print that modelicagym has a variable for matches, and the invalid systems
are refused for their own defects.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import pytest
from bench_runs import own_bench, run_bench
from ssp_cases import bindings, component, connect, connectors, system, write_ssp_folder

from benchmarks.omsimulator_cases import REFUSALS, SCRIPTS
from benchmarks.omsimulator_suite import acceptance

SUITE = os.environ.get("MODELICAGYM_OMSIMULATOR_TESTSUITE")


def windows_only(fmu: Path, into: Path) -> Path:
    """A copy of ``fmu`` whose binaries are filed for win64 alone."""
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(into, "w") as copy:
        for entry in source.infolist():
            copy.writestr(entry.filename.replace("binaries/linux64/", "binaries/win64/"), source.read(entry))
    return into


def test_a_suite_of_our_own_systems_is_tabled_loaded_skipped_and_refused(family_fmu, tmp_path):
    gain = family_fmu("gain", 2)
    resources = tmp_path / "testsuite" / "tests" / "resources"
    top = system("top", [component("a", "gain", bindings({"k": 2.0})), component("b", "gain")],
                 [connect(".u", "a.u"), connect("a.y", "b.u"), connect("b.y", ".y")], connectors(u="input", y="output"))
    write_ssp_folder(resources / "ours", top, {"gain": gain})
    write_ssp_folder(resources / "windows", top, {"gain": windows_only(gain, tmp_path / "windows.fmu")})
    # named as OMSimulator's invalidSSD, refused for another defect than the one OMSimulator names
    write_ssp_folder(resources / "invalidSSD", top.replace('kind="input"', 'kind="sideways"'), {"gain": gain})
    out = run_bench(own_bench("omsimulator-suite"), ["--suite", str(tmp_path / "testsuite")], tmp_path / "result.json")
    result = json.loads((tmp_path / "result.json").read_text())
    outcomes = {o["system"]: o for o in result["outcomes"]}
    assert list(outcomes) == ["invalidSSD", "ours", "windows"]
    assert (outcomes["ours"]["loads"], outcomes["ours"]["runs"]) == (True, True)
    assert outcomes["windows"]["loads"] is None
    assert outcomes["windows"]["why"] == ("skipped: a: gain.fmu has binaries for win64; "
                                          "b: gain.fmu has binaries for win64")
    assert outcomes["invalidSSD"]["why"].startswith("refused, not for its defect: ")
    assert "kind 'sideways' is none of input" in outcomes["invalidSSD"]["why"]
    assert (result["systems"], result["with_linux_fmus"], result["load"], result["run"]) == (3, 1, 1, 1)
    assert result["refused_for_their_defect"] == []
    assert "3 systems; 1 with every FMU's Linux binary: 1 load, 1 run" in out
    zipped = run_bench(own_bench("omsimulator-suite"), ["--suite", str(tmp_path / "testsuite"), "--as-ssp"],
                       tmp_path / "zipped.json")  # each folder zipped into an .ssp, read as a user's archive
    assert zipped.splitlines()[-3] == out.splitlines()[-3]
    assert json.loads((tmp_path / "zipped.json").read_text())["as_archives"] is True


@pytest.mark.skipif(not SUITE, reason="MODELICAGYM_OMSIMULATOR_TESTSUITE names no OMSimulator testsuite/ folder "
                                      "(github.com/OpenModelica/OMSimulator has it)")
def test_omsimulators_test_suite_loads_gives_its_values_and_refuses_its_invalid_systems():
    result = acceptance(Path(SUITE))
    outcomes = {o["system"]: o for o in result["outcomes"]}
    runnable = [o for o in outcomes.values() if o["loads"] is not None]
    assert runnable
    for outcome in runnable:
        assert outcome["loads"] and outcome["runs"], f"{outcome['system']}: {outcome['why']}"
    for outcome in outcomes.values():
        assert not outcome["mismatches"], f"{outcome['system']}: {outcome['mismatches']}"
    for script in SCRIPTS:  # every script's system is in the suite, read, and gives values
        assert outcomes[script.system]["read"] and outcomes[script.system]["matched"] > 0, script.system
    assert result["values_matched"] + result["values_not_given"] == result["values_stated"]
    for name in REFUSALS:
        assert outcomes[name]["why"].startswith("refused for its defect: "), outcomes[name]["why"]
