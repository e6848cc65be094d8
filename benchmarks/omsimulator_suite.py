"""OMSimulator's test-suite systems through modelicagym: which load and run, and whether they give the
values OMSimulator's test scripts print for them.

It takes OMSimulator's ``testsuite/`` folder (from a clone of github.com/OpenModelica/OMSimulator),
finds every system there (a folder holding ``SystemStructure.ssd``, as the suite stores its SSPs
unpacked, or an ``.ssp``) and for each: reads it (the invalid ones must be refused for the defect
OMSimulator names), skips it where an FMU it names is missing or has no Linux binary (saying
which), opens it and runs it as the scripts do (`modelicagym.simulate`), and compares the values the
scripts print (`benchmarks.omsimulator_cases`): a variable's from the run, a system connector's (a
parameter connector, or a system of connectors alone, which has nothing to run) from the SSP
reader. A value the script sets itself, or that no parameter set gives, is "not given".
``--as-ssp`` zips each system folder into an ``.ssp`` first, as a user's archive.
"""

from __future__ import annotations

import argparse
import math
import platform
import re
import shutil
import tempfile
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from benchmarks.omsimulator_cases import REFUSALS, RUNS, SCRIPTS, Script
from modelicagym.bench import format_table, write_json

#: a value matches OMSimulator's printed one to this relative tolerance (it prints 15 digits)
RELATIVE_TOLERANCE = 1e-9
#: the folders of an FMU's binaries for this machine (FMI 2, FMI 3)
LINUX_BINARIES = ("binaries/linux64/", "binaries/x86_64-linux/")


@dataclass
class Outcome:
    """What became of one system."""

    system: str
    read: bool = False
    loads: bool | None = None  # None: not tried (skipped, refused, or no component)
    runs: bool | None = None
    matched: int = 0
    stated: int = 0
    #: the stated values not compared, each with why
    not_given: list[str] = field(default_factory=list)
    mismatches: list[str] = field(default_factory=list)
    why: str = ""
    scripts: list[str] = field(default_factory=list)


def find_systems(suite: Path) -> list[Path]:
    """Every system of the test suite: a folder holding ``SystemStructure.ssd``, or an ``.ssp``."""
    resources = suite / "tests" / "resources" if (suite / "tests" / "resources").is_dir() else suite
    found = {ssd.parent for ssd in resources.rglob("SystemStructure.ssd")}
    found |= set(resources.rglob("*.ssp"))
    return sorted(found, key=lambda path: path.name)


def missing_binaries(components: dict[str, Any]) -> list[str]:
    """Each component FMU that is absent or has no Linux binary, with why."""
    missing = []
    for name, source in components.items():
        path = Path(source["fmu"] if isinstance(source, dict) else source)
        if not path.exists():
            missing.append(f"{name}: {path.name} is not in the SSP")
        elif path.suffix == ".fmu" and path.is_file():
            with zipfile.ZipFile(path) as archive:
                if not any(entry.startswith(LINUX_BINARIES) for entry in archive.namelist()):
                    platforms = sorted({e.split("/")[1] for e in archive.namelist() if e.startswith("binaries/")
                                        and e.count("/") > 1})
                    missing.append(f"{name}: {path.name} has binaries for {', '.join(platforms) or 'no platform'}")
    return missing


def check_system(path: Path, scratch: Path, archive: bool = False) -> Outcome:
    """Read, open, run and compare one system (see the module docstring); ``archive``: each as an
    ``.ssp`` zipped from its folder."""
    from modelicagym.errors import DataError
    from modelicagym.system.ssp import read_ssp

    outcome = Outcome(path.stem if path.suffix == ".ssp" else path.name)
    refusal = REFUSALS.get(outcome.system)
    try:
        spec = read_ssp(prepared(path, (), scratch, archive))
    except DataError as error:
        if refusal is None:
            outcome.why = f"refused: {error}"
        else:
            outcome.scripts.append(refusal[0])
            found = re.search(refusal[1], str(error)) is not None
            outcome.why = f"refused{' for its defect' if found else ', not for its defect'}: {error}"
        return outcome
    outcome.read = True
    if refusal is not None:
        outcome.why = f"not refused; OMSimulator refuses it ({refusal[1]})"
        return outcome
    scripts = [s for s in SCRIPTS if s.system == outcome.system]
    outcome.scripts += [script.script for script in scripts]
    if not spec.components:
        outcome.why = "no component, nothing to run: its connectors' values as the SSP reader gives them"
        for script in scripts:
            values = read_ssp(prepared(path, script.edits, scratch, archive)).connector_values
            compare(outcome, script, values, values)
        return outcome
    missing = missing_binaries(spec.components)
    if missing:
        outcome.why = "skipped: " + "; ".join(missing)
        return outcome
    if not scripts and outcome.system in RUNS:
        script, stop_time, time_step = RUNS[outcome.system]
        scripts = [Script(script, outcome.system, stop_time=stop_time, time_step=time_step)]
        outcome.scripts.append(script)
    notes = []
    for script in scripts or [Script("(none)", outcome.system, stop_time=0.0)]:
        notes += run_script(prepared(path, script.edits, scratch, archive), script, outcome)
    outcome.why = "; ".join(dict.fromkeys(notes))
    return outcome


def run_script(path: Path, script: Script, outcome: Outcome) -> list[str]:
    """Run ``script`` on the system at ``path`` and compare into ``outcome``; the notes on how it ran."""
    from modelicagym.errors import ModelicaGymError
    from modelicagym.fmu.errors import FMUValidationError
    from modelicagym.simulation import simulate
    from modelicagym.system import open_system
    from modelicagym.system.ssp import read_ssp

    notes, validate = [], True
    try:
        try:
            description = open_system(path)
        except FMUValidationError as error:
            notes.append(f"loads with validate=False: {str(error).split(' (pass validate', 1)[0]}")
            validate = False
            description = open_system(path, validate=False)
    except (ModelicaGymError, FileNotFoundError) as error:
        outcome.loads = False
        outcome.stated += script.stated
        return [f"does not load: {error}"]
    outcome.loads = outcome.loads is not False
    stated = {**script.start, **script.end}
    observed = [name for name in stated if name not in script.own and not not_observable(description, name)]
    config = {"fmu": str(path), "validate": validate, "parameters": script.parameters, "time_step": script.time_step}
    stop = 0.0 if script.stop_time is None and not script.end else script.stop_time
    try:
        run = simulate(config, stop, inputs=script.inputs, outputs=observed or None)
    except (ModelicaGymError, FileNotFoundError) as error:
        outcome.runs = False
        outcome.stated += script.stated
        return [*notes, f"does not run: {error}"]
    outcome.runs = outcome.runs is not False
    connectors = read_ssp(path).connector_values
    compare(outcome, script, {**connectors, **{name: run[0][name] for name in observed}},
            {**connectors, **{name: run[-1][name] for name in observed}}, description)
    return notes


def compare(outcome: Outcome, script: Script, start: dict[str, Any], end: dict[str, Any],
            description: Any = None) -> None:
    """Count ``script``'s values against ours after initialization (``start``) and after the run
    (``end``): a variable's from the run, a system connector's from the SSP reader."""
    outcome.stated += script.stated
    for ours, stated, when in ((start, script.start, "after initialization"), (end, script.end, "after the run")):
        for name, value in stated.items():
            if name in script.own:
                outcome.not_given.append(f"{name}: the script sets it itself")
            elif name not in ours:
                outcome.not_given.append(f"{name}: {not_observable(description, name) or 'no value'}")
            elif math.isclose(float(ours[name]), value, rel_tol=RELATIVE_TOLERANCE, abs_tol=1e-12):
                outcome.matched += 1
            else:
                outcome.mismatches.append(f"{name} {when}: {float(ours[name])!r}, OMSimulator {value!r}")


def not_observable(description: Any, name: str) -> str:
    """Why a run of ``description`` records no value of ``name`` ("": it does)."""
    from modelicagym.errors import ModelicaGymError

    if description is None or name not in description.variables:
        return "no value bound to this connector of the system (OMSimulator reads 0.0)"
    try:
        description.observable_variable(name)
    except ModelicaGymError as error:
        return str(error).split(": ", 1)[-1]
    return ""


def prepared(path: Path, edits: tuple[tuple[str, str], ...], scratch: Path, archive: bool) -> Path:
    """The system at ``path`` as a script runs it: a copy under ``scratch`` whose SSD has ``edits``
    made (a script's own edits), zipped into an ``.ssp`` where ``archive`` (as a user's archive);
    ``path`` itself where neither is asked for or ``path`` is an archive already."""
    if path.suffix == ".ssp" or not (edits or archive):
        return path
    folder = scratch / f"{path.name}-{len(list(scratch.iterdir()))}"
    shutil.copytree(path, folder)
    ssd = folder / "SystemStructure.ssd"
    text = ssd.read_text()
    for old, new in edits:
        if old not in text:
            raise ValueError(f"{path}: SystemStructure.ssd holds no {old!r} to edit")
        text = text.replace(old, new)
    ssd.write_text(text)
    if not archive:
        return folder
    ssp = folder.with_suffix(".ssp")
    with zipfile.ZipFile(ssp, "w", zipfile.ZIP_DEFLATED) as zipped:
        for file in sorted(folder.rglob("*")):
            zipped.write(file, file.relative_to(folder).as_posix())
    return ssp


def acceptance(suite: Path, archive: bool = False) -> dict[str, Any]:
    """Every system's `Outcome` and the totals; ``archive``: each system run as an ``.ssp``."""
    if not (suite / "tests" / "resources").is_dir():
        raise FileNotFoundError(f"{suite} is not OMSimulator's testsuite/ folder: it has no tests/resources/")
    with tempfile.TemporaryDirectory(prefix="modelicagym-omsimulator-") as scratch:
        outcomes = [check_system(path, Path(scratch), archive) for path in find_systems(suite)]
    runnable = [o for o in outcomes if o.loads is not None]
    return {
        "suite": str(suite), "machine": platform.platform(), "as_archives": archive,
        "systems": len(outcomes), "with_linux_fmus": len(runnable),
        "load": sum(bool(o.loads) for o in runnable), "run": sum(bool(o.runs) for o in runnable),
        "values_stated": sum(o.stated for o in outcomes), "values_matched": sum(o.matched for o in outcomes),
        "values_not_given": sum(o.stated - o.matched - len(o.mismatches) for o in outcomes),
        "refused_for_their_defect": sorted(o.system for o in outcomes if o.why.startswith("refused for its defect")),
        "outcomes": [asdict(o) for o in outcomes],
    }


def report(result: dict[str, Any]) -> str:
    def mark(flag: bool | None) -> str:
        return "-" if flag is None else "yes" if flag else "NO"

    rows = []
    for o in result["outcomes"]:
        values = f"{o['matched']}/{o['stated']}" if o["stated"] else "-"
        why = "; ".join([*(f"not given: {n.split(': ', 1)[0]}" for n in dict.fromkeys(o["not_given"])),
                         *o["mismatches"],
                         *([o["why"]] if o["why"] else [])])
        rows.append((o["system"], mark(o["read"]), mark(o["loads"]), mark(o["runs"]), values, why[:150]))
    return (format_table(("system", "read", "loads", "runs", "values", "why not / notes"), rows)
            + f"\n\n{result['systems']} systems; {result['with_linux_fmus']} with every FMU's Linux binary: "
              f"{result['load']} load, {result['run']} run; values: {result['values_matched']} of "
              f"{result['values_stated']} match, {result['values_not_given']} not given; refused for their "
              f"defect: {', '.join(result['refused_for_their_defect']) or 'none'}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--suite", required=True, type=Path,
                        help="OMSimulator's testsuite/ folder (its tests/resources/ holds the systems)")
    parser.add_argument("--as-ssp", action="store_true",
                        help="zip each system folder into an .ssp (in a temporary folder) and run that")
    parser.add_argument("--json", default="bench-results/omsimulator_suite.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = acceptance(args.suite.expanduser(), args.as_ssp)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
