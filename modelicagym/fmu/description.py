"""Open an FMU once: check it, extract it once, read its model description.

`open_fmu` is the entry point. It accepts a ``.fmu`` file or an already extracted folder, fails
with a clear message on anything that is not a usable FMU, and extracts each FMU file once into
a cache folder keyed by the file's path, size and modification time, so every instance in every
process reuses the same extraction (docs/design.md: never re-extract).
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import re
import shutil
import tempfile
import zipfile
from collections.abc import Collection
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import fmpy
from fmpy.model_description import ModelDescription, ValidationError, read_model_description
from lxml import etree

from modelicagym.cache import cache_dir, ensure, file_digest, write_manifest
from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import (
    FMUNotFoundError,
    FMUValidationError,
    InvalidFMUError,
    PlatformNotSupportedError,
    UnsupportedFeatureError,
    VariableError,
    unknown_variable,
)
from modelicagym.fmu.variables import Variable, from_fmpy

logger = logging.getLogger(__name__)

MODES = ("cs", "me")
_MODE_NAMES = {"cs": "co-simulation", "me": "model exchange"}


@dataclass(frozen=True)
class DefaultExperiment:
    start_time: float = 0.0
    stop_time: float | None = None
    step_size: float | None = None
    tolerance: float | None = None


class FMUDescription:
    """What an FMU declares: variables by name, interface types, capabilities, platforms.

    Reading it never loads the FMU's binary, so it is cheap and safe in any process (the pool
    reads spaces from it in the parent).
    """

    def __init__(self, path: Path, unzip_dir: Path, model_description: Any):
        self.path = path
        self.unzip_dir = unzip_dir
        self.raw = model_description
        self.name = path.name
        self.variables: dict[str, Variable] = {
            v.name: from_fmpy(v, self.fmi_version) for v in model_description.modelVariables
        }

    def __repr__(self) -> str:
        return f"FMUDescription({str(self.path)!r}, fmi={self.fmi_version}, modes={self.modes})"

    @property
    def fmi_version(self) -> int:
        """1, 2 or 3."""
        return int(self.raw.fmiVersion.split(".")[0])

    @property
    def model_name(self) -> str:
        return self.raw.modelName

    @property
    def guid(self) -> str:
        return self.raw.guid

    @property
    def modes(self) -> tuple[str, ...]:
        """The interface types this FMU supports: ``"cs"`` (co-simulation), ``"me"`` (model exchange)."""
        return tuple(m for m in MODES if self._interface_or_none(m) is not None)

    def _interface_or_none(self, mode: str) -> Any:
        return self.raw.coSimulation if mode == "cs" else self.raw.modelExchange

    def interface(self, mode: str) -> Any:
        """fmpy's interface-type record for ``mode``; a clear error if the FMU does not support it."""
        if mode not in MODES:
            raise ConfigError(f"mode must be one of {MODES}, got {mode!r}")
        interface = self._interface_or_none(mode)
        if interface is None:
            raise UnsupportedFeatureError(
                f"{self.name} does not support {_MODE_NAMES[mode]} (mode={mode!r}); it supports: "
                + (", ".join(f"{_MODE_NAMES[m]} ({m!r})" for m in self.modes) or "nothing")
            )
        return interface

    def default_mode(self) -> str:
        """Co-simulation when available (one call per step), else model exchange."""
        if not self.modes:
            raise UnsupportedFeatureError(f"{self.name} supports neither co-simulation nor model exchange")
        return self.modes[0]

    def can_snapshot(self, mode: str) -> bool:
        """Whether the FMU can save and restore its state (``canGetAndSetFMUstate``; never in FMI 1.0)."""
        return self.fmi_version > 1 and bool(self.interface(mode).canGetAndSetFMUstate)

    def can_serialize(self, mode: str) -> bool:
        """Whether the FMU can turn its state into bytes and back (``canSerializeFMUstate``, which
        needs ``canGetAndSetFMUstate`` too; never in FMI 1.0): what `FMUInstance.save_state` needs."""
        return self.can_snapshot(mode) and bool(self.interface(mode).canSerializeFMUstate)  # fmpy's name in 3.0 too

    def serialize_refusal(self, mode: str) -> str | None:
        """Why this FMU's state cannot be saved as a value in ``mode`` (one line), or ``None``."""
        if self.fmi_version == 1:
            return f"{self.name} cannot save its state as a value: FMI 1.0 has no FMU state"
        if not self.can_snapshot(mode):
            return f"{self.name} cannot save its state as a value: canGetAndSetFMUstate is false"
        if not self.can_serialize(mode):
            return f"{self.name} cannot save its state as a value: canSerializeFMUstate is false"
        return None

    def content_hash(self, mode: str) -> str:
        """What a saved state is tied to: the model's GUID (instantiation token) and the SHA-256
        of the binary for ``mode``, hashed together; the same FMU anywhere gives the same hash, a
        rebuilt or another one a different hash."""
        library = self.library_path(mode)
        stat = library.stat()
        return _content_hash(self.guid, str(library.resolve()), stat.st_size, stat.st_mtime_ns)

    def can_reset(self, mode: str) -> bool:
        """Whether the FMU has a reset function for ``mode``: FMI 1.0 model exchange has none
        (co-simulation has ``fmiResetSlave``)."""
        self.interface(mode)
        return not (self.fmi_version == 1 and mode == "me")

    def needs_completed_integrator_step(self) -> bool:
        """Model exchange: whether ``fmiCompletedIntegratorStep`` must be called (always in FMI 1.0)."""
        return self.fmi_version == 1 or bool(self.interface("me").needsCompletedIntegratorStep)

    def once_per_process(self, mode: str | None = None) -> bool:
        """Whether only one instance may live in a process (``canBeInstantiatedOnlyOncePerProcess``;
        FMI 1.0 declares it for co-simulation only, in ``Implementation``, which fmpy does not read)."""
        modes = [mode] if mode else self.modes
        interfaces = {m: self.interface(m) for m in modes}
        if self.fmi_version == 1:
            return "cs" in interfaces and self._fmi1_once_per_process
        return any(interface.canBeInstantiatedOnlyOncePerProcess for interface in interfaces.values())

    @cached_property
    def _fmi1_once_per_process(self) -> bool:
        root = etree.parse(str(self.unzip_dir / "modelDescription.xml")).getroot()
        flags = root.xpath("Implementation/*/Capabilities/@canBeInstantiatedOnlyOncePerProcess")
        return any(flag in ("true", "1") for flag in flags)

    @property
    def default_experiment(self) -> DefaultExperiment:
        d = self.raw.defaultExperiment
        if d is None:
            return DefaultExperiment()

        def num(x: Any) -> float | None:
            return None if x is None else float(x)

        return DefaultExperiment(num(d.startTime) or 0.0, num(d.stopTime), num(d.stepSize), num(d.tolerance))

    @property
    def number_of_states(self) -> int:
        return int(self.raw.numberOfContinuousStates)

    @property
    def number_of_event_indicators(self) -> int:
        return int(self.raw.numberOfEventIndicators)

    @property
    def platform_dir(self) -> str:
        """The ``binaries/`` sub-folder this machine needs (``linux64`` / ``x86_64-linux`` ...)."""
        return fmpy.platform if self.fmi_version < 3 else fmpy.platform_tuple

    @cached_property
    def platforms(self) -> tuple[str, ...]:
        """Platforms the FMU ships binaries for (folder names under ``binaries/``)."""
        binaries = self.unzip_dir / "binaries"
        if not binaries.is_dir():
            return ()
        return tuple(sorted(p.name for p in binaries.iterdir() if p.is_dir() and any(p.iterdir())))

    @property
    def has_sources(self) -> bool:
        return (self.unzip_dir / "sources").is_dir()

    def library_path(self, mode: str) -> Path:
        """The shared library for ``mode`` on this platform; a clear error when it is missing."""
        identifier = self.interface(mode).modelIdentifier
        library = self.unzip_dir / "binaries" / self.platform_dir / (identifier + fmpy.sharedLibraryExtension)
        if not library.is_file():
            others = sorted(p.name for p in library.parent.glob(f"*{fmpy.sharedLibraryExtension}*") if p.is_file())
            if others:
                raise InvalidFMUError(
                    f"{self.name}: its model identifier {identifier!r} (modelDescription.xml, {_MODE_NAMES[mode]}) "
                    f"matches no binary: expected binaries/{self.platform_dir}/{library.name}, but that folder holds "
                    f"only {', '.join(others)}. The model identifier must be the library's name without "
                    f"{fmpy.sharedLibraryExtension}: fix one or the other"
                )
            hint = (
                " It contains C sources: build a binary with `modelicagym build "
                f"{self.path}` (or fmpy.util.compile_platform_binary)." if self.has_sources else ""
            )
            raise PlatformNotSupportedError(
                f"{self.name} has no binary for this platform ({self.platform_dir}): expected "
                f"binaries/{self.platform_dir}/{library.name}. It has binaries for: "
                f"{', '.join(self.platforms) or 'no platform'}.{hint}"
            )
        return library

    # -- variables -------------------------------------------------------------------------------

    def variable(self, name: str, candidates: list[Variable] | None = None, role: str = "variable") -> Variable:
        """The variable called ``name``; a `VariableError` suggesting close matches if there is none.

        ``candidates`` (e.g. the inputs, when looking for an action) are listed in the message.
        """
        try:
            return self.variables[name]
        except KeyError:
            error = unknown_variable(name, self.variables, self.name, role)
            if candidates is not None and len(candidates) <= 30:
                names = ", ".join(v.name for v in candidates) or "none"
                error = VariableError(f"{error} This FMU's {role}s: {names}")
            raise error from None

    def _with_causality(self, *causalities: str) -> list[Variable]:
        return [v for v in self.variables.values() if v.causality in causalities]

    @cached_property
    def inputs(self) -> list[Variable]:
        return self._with_causality("input")

    @cached_property
    def outputs(self) -> list[Variable]:
        return self._with_causality("output")

    @cached_property
    def parameters(self) -> list[Variable]:
        return [v for v in self._with_causality("parameter", "structuralParameter") if v.settable]

    @cached_property
    def state_variables(self) -> list[Variable]:
        """The continuous states, as the model structure declares them (the variables whose
        derivatives it lists; FMI 1.0 declares none)."""
        states = (getattr(u.variable.derivative, "name", None) for u in self.raw.derivatives)
        return [self.variables[name] for name in states if name in self.variables]

    def input_variable(self, name: str) -> Variable:
        """``name`` checked to be driveable by an action: an input, or a tunable parameter (which
        FMI lets a master change between steps)."""
        tunable = [v for v in self.parameters if v.is_tunable_parameter]
        variable = self.variable(name, self.inputs + tunable, "input")
        if not (variable.is_input or variable.is_tunable_parameter):
            raise VariableError(
                f"{self.name}: {name!r} cannot be an action: it has causality {variable.causality!r} and "
                f"variability {variable.variability!r}; actions drive inputs and tunable parameters. Inputs: "
                f"{', '.join(v.name for v in self.inputs) or 'none'}; tunable parameters: "
                f"{', '.join(v.name for v in tunable) or 'none'}"
            )
        if variable.kind in ("binary", "clock", "string"):
            raise VariableError(f"{self.name}: {name!r} is of type {variable.fmi_type}, which cannot be an action "
                                "(actions set numbers)")
        return variable

    def observable_variable(self, name: str) -> Variable:
        """``name`` checked to be readable while the model runs (anything but an independent variable)."""
        variable = self.variable(name, self.outputs, "output")
        if variable.kind in ("binary", "clock", "string"):
            raise VariableError(f"{self.name}: {name!r} is of type {variable.fmi_type}, which cannot be an observation")
        return variable

    def settable_variable(self, name: str) -> Variable:
        """``name`` checked to be settable as a parameter or start value."""
        variable = self.variable(name, self.parameters, "parameter")
        if not variable.settable:
            raise VariableError(
                f"{self.name}: {name!r} cannot be set (causality {variable.causality!r}, variability "
                f"{variable.variability!r}, initial {variable.initial!r}). Settable parameters: "
                f"{', '.join(v.name for v in self.parameters) or 'none'}"
            )
        return variable


def open_fmu(
    path: str | os.PathLike[str] | FMUDescription, validate: bool = True, used: Collection[str] | None = None
) -> FMUDescription:
    """Check and open an FMU (a ``.fmu`` file or an extracted folder), extracting it once.

    ``validate=False`` skips fmpy's schema validation: some FMUs in the wild fail it and run fine.
    With ``used`` (the names of the variables the caller will use), an FMU whose validation
    problems all concern other variables is loaded with a warning that names the rules broken
    (exporters often break a rule on a variable nobody drives); a problem on a used variable, or
    one that cannot be tied to a variable, still refuses it.
    """
    if isinstance(path, FMUDescription):
        return path
    path = Path(path).expanduser()
    if not path.exists():
        raise FMUNotFoundError(f"FMU not found: {path} (resolved to {path.resolve()})")
    unzip_dir = path if path.is_dir() else _extract(path)
    if not (unzip_dir / "modelDescription.xml").is_file():
        raise InvalidFMUError(f"{path} is not an FMU: it has no modelDescription.xml at its top level")
    try:
        model_description = read_model_description(str(unzip_dir), validate=validate)
    except ValidationError as error:
        model_description = _tolerate(path, unzip_dir, error, used)
    except Exception as error:  # not well-formed XML, an unknown FMI version: validate=False would not help
        raise InvalidFMUError(f"{path}: cannot read modelDescription.xml: {error}") from error
    return FMUDescription(path, unzip_dir, model_description)


def _tolerate(path: Path, unzip_dir: Path, error: ValidationError, used: Collection[str] | None) -> ModelDescription:
    """The model description despite validation ``error``, if every problem concerns a variable
    outside ``used``; else the `InvalidFMUError`."""
    concerned = _variables_of(unzip_dir / "modelDescription.xml", error.problems)
    if used is None or None in concerned or concerned & set(used):
        raise _validation_error(path, unzip_dir, error.problems, concerned) from error
    logger.warning("%s breaks rules of the FMI standard only for variables this env does not use (%s); loading "
                   "it anyway: %s", path.name, ", ".join(sorted(concerned)), " | ".join(error.problems))
    return read_model_description(str(unzip_dir), validate=False)


#: how many of the rules broken a message quotes (exports in the wild break dozens)
_QUOTED_PROBLEMS = 3


def _validation_error(
    path: Path, unzip_dir: Path, problems: list[str], concerned: set[str | None]
) -> FMUValidationError:
    """One line: the rules broken, the variables they concern, and whether ``validate=False`` helps."""
    names = sorted(name for name in concerned if name is not None)
    about = f" (variables concerned: {', '.join(names)})" if names else ""
    quoted = " | ".join(" ".join(problem.split()) for problem in problems[:_QUOTED_PROBLEMS])
    more = f" | and {len(problems) - _QUOTED_PROBLEMS} more" if len(problems) > _QUOTED_PROBLEMS else ""
    try:
        read_model_description(str(unzip_dir), validate=False)
        skippable = True
    except Exception:
        skippable = False
    summary = f"{path}: cannot read modelDescription.xml: it fails validation{about}: {quoted}{more}"
    return FMUValidationError(summary, list(problems), names, skippable)


def _variables_of(description: Path, problems: list[str]) -> set[str | None]:
    """The variable each validation problem concerns (``None`` for one that concerns none)."""
    tree = etree.parse(str(description))
    spans = []
    for element in tree.getroot().iterfind("ModelVariables/*"):
        last = max((e.sourceline for e in element.iter() if e.sourceline), default=element.sourceline)
        spans.append((element.sourceline, last, element.get("name")))
    concerned: set[str | None] = set()
    for problem in problems:
        named = re.search(r'[Vv]ariable "([^"]+)"', problem)
        line = re.search(r"line (\d+)", problem)
        if named:
            concerned.add(named.group(1))
        elif line:
            number = int(line.group(1))
            concerned.add(next((name for first, last, name in spans if first <= number <= last), None))
        else:
            concerned.add(None)
    return concerned


#: limits on what one FMU may expand to, raisable with these environment variables
EXTRACTION_LIMITS = {
    "MODELICAGYM_MAX_FMU_BYTES": 2 << 30,
    "MODELICAGYM_MAX_FMU_FILES": 20_000,
    "MODELICAGYM_MAX_FMU_RATIO": 200,
}


def _extraction_limit(name: str) -> int:
    value = os.environ.get(name)
    if value is None:
        return EXTRACTION_LIMITS[name]
    try:
        return int(float(value))
    except ValueError:
        raise ConfigError(f"${name}={value!r} is not a number") from None


def _check_expansion(path: Path, archive: zipfile.ZipFile) -> None:
    """Refuse, before anything is written, an FMU that would expand beyond the limits: total
    size, file count, and ratio of its expanded to its compressed size (a zip bomb)."""
    members = archive.infolist()
    total = sum(member.file_size for member in members)
    compressed = max(path.stat().st_size, 1)
    checks = (
        ("MODELICAGYM_MAX_FMU_BYTES", total, f"{total:,} bytes"),
        ("MODELICAGYM_MAX_FMU_FILES", len(members), f"{len(members):,} files"),
        ("MODELICAGYM_MAX_FMU_RATIO", total // compressed, f"{total / compressed:,.0f} times its size"),
    )
    for name, amount, described in checks:
        limit = _extraction_limit(name)
        if amount > limit:
            raise InvalidFMUError(f"{path} would expand to {described}, over the limit of {limit:,} "
                                  f"(set ${name} higher to extract it anyway); nothing was extracted")


@functools.cache
def _content_key(resolved: str, size: int, mtime_ns: int) -> str:
    """The FMU's content hash, computed once per process per (file, size, mtime)."""
    return file_digest(Path(resolved))[:20]


@functools.cache
def _content_hash(guid: str, library: str, size: int, mtime_ns: int) -> str:
    """`FMUDescription.content_hash`, computed once per process per (binary, size, mtime)."""
    return hashlib.sha256(f"{guid}\n{file_digest(Path(library))}".encode()).hexdigest()[:24]


def _extract(path: Path) -> Path:
    """Extract ``path`` into the cache once per content (the same bytes anywhere are one entry),
    checked against its manifest on every open; safe across processes."""
    return extract_archive(path)


def extract_archive(path: Path, required: str = "modelDescription.xml", kind: str = "an FMU") -> Path:
    """Extract the zip archive ``path`` (``kind``, which holds ``required`` at its top: an FMU, an
    SSP archive) into the cache once per content, within the extraction limits, as FMUs are."""
    if not zipfile.is_zipfile(path):
        raise InvalidFMUError(f"{path} is not {kind}: {kind} is a zip archive, and this file is not one (or is cut short)")
    stat = path.stat()
    key = _content_key(str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    target = cache_dir() / "extracted" / key
    return ensure(target, lambda: _extract_into(path, target, required, kind), f"the extracted {path.name}")


def _extract_into(path: Path, target: Path, required: str, kind: str) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{path.stem}-", dir=target.parent))
    try:
        with zipfile.ZipFile(path) as archive:
            if required not in archive.namelist():
                raise InvalidFMUError(f"{path} is not {kind}: the zip archive has no {required}")
            _check_expansion(path, archive)
            archive.extractall(staging)
        write_manifest(staging)
        os.rename(staging, target)
        logger.debug("extracted %s to %s", path, target)
    except (zipfile.BadZipFile, EOFError) as error:
        raise InvalidFMUError(f"{path} is a damaged zip archive ({error}): extract it again from its source") from error
    finally:
        shutil.rmtree(staging, ignore_errors=True)
