"""The family of test FMUs in ``tests/fmus/``, built once per session.

Two C models (see each folder's ``config.h``), compiled with the framework in
``modelicagym/models/csrc`` by `modelicagym.fmu.build.build_source_fmu` (cached on disk by content
hash, so only the first session pays for compilation):

``probe``
    integer / enumeration / boolean inputs and outputs, FMI 3.0 arrays and Float32 / Int8 / UInt16 /
    (U)Int64 variables, a time-dependent output, fault injection in ``doStep`` (parameters ``fault`` and ``fault_after``). Build-time
    variants reproduce FMUs in the wild: once per process, no state snapshots, a non-zero start
    time, a buggy ``fmiReset``, inexact snapshots. A variant is the same C code with preprocessor
    definitions (which switch on lifecycle hooks of the C framework) plus a model description derived from ``modelDescription_fmi<v>.xml`` by
    `derive_description`.
``ball``
    a bouncing ball with a state event and a time event, model exchange and co-simulation.

Use the session fixture ``fmus`` (``fmus["probe2"]`` is a path) by importing it into a test
module: ``from fmu_family import fmus``.
"""

from __future__ import annotations

import hashlib
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from lxml import etree

from modelicagym.fmu.build import build_source_fmu, cache_dir

FMUS_DIR = Path(__file__).resolve().parent / "fmus"
PROBE_DIR = FMUS_DIR / "probe"
BALL_DIR = FMUS_DIR / "ball"

# Names of the probe's variables, per FMI version.
PROBE_INPUTS = ("gear", "mode", "enable", "boost", "force")
PROBE_OUTPUTS = ("position", "clock", "speed", "mode_out", "moving", "steps")
PROBE3_INPUTS = (*PROBE_INPUTS, "u", "trim", "tag")
PROBE3_OUTPUTS = (*PROBE_OUTPUTS, "y", "positive", "ticks", "thrust", "level", "tag_out")
FAULTS = {"none": 0, "terminate": 1, "error": 2, "crash": 3}
MODES = {"off": 1, "heat": 2, "cool": 3}


@dataclass(frozen=True)
class Variant:
    """One member of the family: a model folder built for an FMI version with some options."""

    model_dir: Path
    fmi_version: int
    defines: dict[str, object] = field(default_factory=dict)
    once_per_process: bool = False
    snapshots: bool = True
    start_time: float | None = None


def _probe(fmi_version: int, *flags: str, **options: object) -> Variant:
    defines: dict[str, object] = {flag: None for flag in flags}
    return Variant(PROBE_DIR, fmi_version, defines, **options)  # type: ignore[arg-type]


FAMILY: dict[str, Variant] = {
    # plain probe: every capability declared, snapshots work
    "probe2": _probe(2),
    "probe3": _probe(3),
    # canBeInstantiatedOnlyOncePerProcess, and the C side refuses a second live instance
    "probe2_once": _probe(2, "ONCE_PER_PROCESS", once_per_process=True),
    "probe3_once": _probe(3, "ONCE_PER_PROCESS", once_per_process=True),
    # canGetAndSetFMUstate="false" (and getFMUstate really fails), startTime="10"
    "probe2_late": _probe(2, "NO_SNAPSHOTS", snapshots=False, start_time=10.0),
    "probe3_late": _probe(3, "NO_SNAPSHOTS", snapshots=False, start_time=10.0),
    # fmiReset forgets to reset the step counter; no snapshots, so "auto" starts at "reset"
    "probe2_buggy": _probe(2, "BUGGY_RESET", "NO_SNAPSHOTS", snapshots=False),
    "probe3_buggy": _probe(3, "BUGGY_RESET", "NO_SNAPSHOTS", snapshots=False),
    # setFMUstate restores the position with a small error: "auto" starts at "snapshot"
    "probe2_inexact": _probe(2, "INEXACT_SNAPSHOTS"),
    "probe3_inexact": _probe(3, "INEXACT_SNAPSHOTS"),
    # bouncing ball, model exchange + co-simulation
    "ball2": Variant(BALL_DIR, 2),
    "ball3": Variant(BALL_DIR, 3),
}


def derive_description(variant: Variant) -> Path | None:
    """The variant's model description (written to the cache, named by content), or None for the base."""
    if not variant.once_per_process and variant.snapshots and variant.start_time is None:
        return None
    base = variant.model_dir / f"modelDescription_fmi{variant.fmi_version}.xml"
    root = etree.fromstring(base.read_bytes())
    state = "canGetAndSetFMUstate" if variant.fmi_version == 2 else "canGetAndSetFMUState"
    serialize = "canSerializeFMUstate" if variant.fmi_version == 2 else "canSerializeFMUState"
    for interface in root:
        if interface.tag not in ("CoSimulation", "ModelExchange"):
            continue
        if variant.once_per_process:
            interface.set("canBeInstantiatedOnlyOncePerProcess", "true")
        if not variant.snapshots:
            interface.set(state, "false")
            interface.set(serialize, "false")
    if variant.start_time is not None:
        root.find("DefaultExperiment").set("startTime", repr(variant.start_time))
    text = etree.tostring(root, xml_declaration=True, encoding="UTF-8")
    folder = cache_dir() / "test-descriptions"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{hashlib.sha256(text).hexdigest()[:16]}.xml"
    if not path.is_file():
        tmp = path.with_suffix(f".{id(text)}.tmp")
        tmp.write_bytes(text)
        tmp.replace(path)
    return path


def build(name: str) -> Path:
    """Build (or fetch from the cache) the family member ``name``."""
    variant = FAMILY[name]
    return build_source_fmu(
        variant.model_dir,
        variant.fmi_version,
        model_description=derive_description(variant),
        defines=variant.defines,
    )


def build_family() -> dict[str, Path]:
    """Every member, one after the other (about 1.5 s each on a cache miss).

    Not in threads: fmpy validates model descriptions with lxml, whose first XML-schema parse in a
    process races with a concurrent one ("XMLSchemaParseError: Internal error").
    """
    return {name: build(name) for name in FAMILY}


def rewrite(source: Path, target: Path, rename=lambda name: name, edit_description=lambda text: text) -> Path:
    """A copy of the FMU ``source`` with entries renamed (None drops one) and the model description edited."""
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w") as new:
        for item in old.infolist():
            name = rename(item.filename)
            if name is None:
                continue
            data = old.read(item)
            if name == "modelDescription.xml":
                data = edit_description(data.decode()).encode()
            new.writestr(name, data)
    return target


@pytest.fixture(scope="session")
def fmus() -> dict[str, Path]:
    """``{name: path of the built .fmu}`` for every member of `FAMILY`."""
    return build_family()
