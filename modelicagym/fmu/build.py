"""Build source FMUs from our C framework and a model folder, cached by content hash.

A *model folder* holds a model's C sources (``model.c``, ``config.h``, any other
``*.c``/``*.h``) and its model descriptions ``modelDescription_fmi2.xml`` and/or
``modelDescription_fmi3.xml`` (see ``modelicagym/models/csrc/model.h`` for the C
contract). :func:`build_source_fmu` assembles a source FMU (model description,
``sources/`` = framework + model + generated ``build_config.h`` +
``buildDescription.xml``), compiles it with fmpy's CMake project and zips it into a
``.fmu`` that keeps its sources.

FMUs are cached in :func:`cache_dir` under a hash of every input (sources, model
description, preprocessor definitions, this builder, fmpy version, platform): a cache
hit only hashes a few files. Concurrent builders are serialized by an ``fcntl`` lock
per hash; each builds in a temporary folder and publishes with an atomic rename, so
a reader never sees a partial FMU.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union
from xml.etree import ElementTree

import fmpy

from modelicagym.errors import ArgumentError, BuildError, NotFoundError
from modelicagym.fmu.cache import cache_dir, locked
from modelicagym.fmu.errors import FMUError

__all__ = [
    "FMUBuildError",
    "FRAMEWORK_DIR",
    "MODELS_DIR",
    "build_all_models",
    "build_source_fmu",
    "cache_dir",
]

logger = logging.getLogger(__name__)

DefineValue = Union[str, int, float, bool, None]

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
FRAMEWORK_DIR = MODELS_DIR / "csrc"
_FRAMEWORK_FILES = ("model.h", "fmu_instance.h", "fmu_internal.h", "fmu_instance.c", "fmu_solver.c")
_ADAPTERS = {2: "fmi2Functions.c", 3: "fmi3Functions.c"}
_GENERATED_HEADER = "build_config.h"
_BUILD_DESCRIPTION = "buildDescription.xml"
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class FMUBuildError(FMUError, BuildError):
    """A source FMU could not be assembled or compiled (the message holds the compiler output)."""


def build_source_fmu(
    model_dir: str | os.PathLike,
    fmi_version: int = 2,
    *,
    model_description: str | os.PathLike | None = None,
    defines: Mapping[str, DefineValue] | None = None,
    cache: str | os.PathLike | None = None,
) -> Path:
    """Return the path of the built ``.fmu`` for a model folder, building it on a cache miss.

    Args:
        model_dir: folder with the model's ``*.c``/``*.h`` files and model descriptions.
        fmi_version: 2 or 3; selects ``modelDescription_fmi<version>.xml`` and the adapter.
        model_description: another model description file (relative to ``model_dir`` or
            absolute); its ``fmiVersion`` must match ``fmi_version``.
        defines: extra preprocessor definitions written to ``build_config.h``
            (``None`` defines a flag, ``bool`` becomes 1/0), e.g. to configure a test FMU.
        cache: cache folder, default :func:`cache_dir`.
    """
    job = _BuildJob.create(Path(model_dir), fmi_version, model_description, defines or {})
    fmus = Path(cache) if cache is not None else cache_dir()
    target = fmus / "fmus" / f"{job.identifier}-fmi{fmi_version}-{job.key}.fmu"
    if target.is_file():
        return target
    with locked(fmus / "locks" / f"{job.key}.lock"):
        if not target.is_file():
            job.build(target)
    return target


def build_all_models(cache: str | os.PathLike | None = None) -> list[Path]:
    """Build every model shipped in ``modelicagym/models`` for each FMI version it describes."""
    built = []
    for model_dir in sorted(p for p in MODELS_DIR.iterdir() if p.is_dir() and p != FRAMEWORK_DIR):
        for version in sorted(_ADAPTERS):
            if (model_dir / f"modelDescription_fmi{version}.xml").is_file():
                built.append(build_source_fmu(model_dir, version, cache=cache))
    return built


@dataclass
class _BuildJob:
    """Everything one build needs, read once; ``key`` hashes all of it."""

    description: bytes
    sources: dict[str, bytes]
    defines: dict[str, str | None]
    fmi_version: int
    identifier: str
    token: str
    key: str = field(init=False)

    def __post_init__(self) -> None:
        self.key = self._hash()

    @classmethod
    def create(cls, model_dir: Path, fmi_version: int, model_description: str | os.PathLike | None,
               defines: Mapping[str, DefineValue]) -> "_BuildJob":
        if fmi_version not in _ADAPTERS:
            raise ArgumentError(f"fmi_version must be one of {sorted(_ADAPTERS)}, not {fmi_version!r}")
        md_path = model_dir / (model_description or f"modelDescription_fmi{fmi_version}.xml")
        if not md_path.is_file():
            raise NotFoundError(f"model description not found: {md_path}")
        description = md_path.read_bytes()
        identifier, token = _read_description(description, fmi_version, md_path)
        sources = _read_sources(model_dir, fmi_version)
        return cls(description, sources, _normalize_defines(defines), fmi_version, identifier, token)

    def _hash(self) -> str:
        h = hashlib.sha256()
        for part in (fmpy.__version__, fmpy.platform_tuple, sys.platform, Path(__file__).read_bytes(),
                     self.description, repr(sorted(self.defines.items()))):
            h.update(part if isinstance(part, bytes) else part.encode())
            h.update(b"\0")
        for name in sorted(self.sources):
            h.update(name.encode() + b"\0" + self.sources[name] + b"\0")
        return h.hexdigest()[:16]

    def build(self, target: Path) -> None:
        """Assemble, compile and zip into ``target`` (atomically)."""
        logger.info("building %s (FMI %d) -> %s", self.identifier, self.fmi_version, target)
        tmp_root = target.parent.parent / "tmp"
        tmp_root.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=f"{self.identifier}-", dir=tmp_root))
        try:
            unzipdir = work / "fmu"
            self._assemble(unzipdir)
            _compile(unzipdir, work / "build")
            _check_binary(unzipdir, self.identifier)
            partial = work / "partial.fmu"
            _zip(unzipdir, partial)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(partial, target)
        finally:
            shutil.rmtree(work, ignore_errors=True)

    def _assemble(self, unzipdir: Path) -> None:
        sources_dir = unzipdir / "sources"
        sources_dir.mkdir(parents=True)
        for name, content in self.sources.items():
            (sources_dir / name).write_bytes(content)
        (sources_dir / _GENERATED_HEADER).write_text(_build_config_header(self.token, self.defines))
        c_files = sorted(name for name in self.sources if name.endswith(".c"))
        (sources_dir / _BUILD_DESCRIPTION).write_text(_build_description(self.identifier, c_files))
        description = self.description
        if self.fmi_version == 2:
            description = _with_fmi2_source_files(description, c_files)
        (unzipdir / "modelDescription.xml").write_bytes(description)


def _read_description(description: bytes, fmi_version: int, path: Path) -> tuple[str, str]:
    """Check the FMI version; return the model identifier and the guid / instantiation token."""
    try:
        root = ElementTree.fromstring(description)
    except ElementTree.ParseError as e:
        raise FMUBuildError(f"{path}: {e}") from e
    if not root.get("fmiVersion", "").startswith(f"{fmi_version}."):
        raise FMUBuildError(f"{path}: fmiVersion is {root.get('fmiVersion')!r}, expected FMI {fmi_version}")
    identifiers = {e.get("modelIdentifier") for e in root if e.tag in ("CoSimulation", "ModelExchange")}
    if len(identifiers) != 1 or None in identifiers:
        raise FMUBuildError(f"{path}: CoSimulation and ModelExchange need one common modelIdentifier, "
                            f"found {sorted(map(str, identifiers))}")
    token = root.get("guid" if fmi_version == 2 else "instantiationToken") or ""
    return identifiers.pop(), token


def _read_sources(model_dir: Path, fmi_version: int) -> dict[str, bytes]:
    """Framework files + the adapter + the model's top-level ``*.c``/``*.h``, by file name."""
    sources = {name: (FRAMEWORK_DIR / name).read_bytes()
               for name in (*_FRAMEWORK_FILES, _ADAPTERS[fmi_version])}
    model_files = sorted(p for p in model_dir.iterdir() if p.suffix in (".c", ".h") and p.is_file())
    if not any(p.name == "model.c" for p in model_files):
        raise FMUBuildError(f"{model_dir} has no model.c")
    reserved = set(sources) | set(_ADAPTERS.values()) | {_GENERATED_HEADER}
    for path in model_files:
        if path.name in reserved:
            raise FMUBuildError(f"{path}: the file name {path.name!r} is reserved by the framework")
        sources[path.name] = path.read_bytes()
    return sources


def _normalize_defines(defines: Mapping[str, DefineValue]) -> dict[str, str | None]:
    normalized: dict[str, str | None] = {}
    for name, value in defines.items():
        if not _IDENTIFIER.match(name):
            raise ArgumentError(f"preprocessor definition name {name!r} is not a C identifier")
        if isinstance(value, bool):
            value = int(value)
        text = None if value is None else str(value)
        if text is not None and ("\n" in text or "\r" in text):
            raise ArgumentError(f"preprocessor definition {name} contains a line break")
        normalized[name] = text
    return normalized


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _build_config_header(token: str, defines: Mapping[str, str | None]) -> str:
    lines = [
        "/* Generated by modelicagym.fmu.build -- do not edit. */",
        "#ifndef MODELICAGYM_BUILD_CONFIG_H",
        "#define MODELICAGYM_BUILD_CONFIG_H",
        f"#define FMU_INSTANTIATION_TOKEN {_c_string(token)}",
    ]
    lines += [f"#define {name}" + ("" if value is None else f" {value}") for name, value in defines.items()]
    lines.append("#endif")
    return "\n".join(lines) + "\n"


def _build_description(identifier: str, c_files: list[str]) -> str:
    files = "\n".join(f'      <SourceFile name="{name}"/>' for name in c_files)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="3.0">
  <BuildConfiguration modelIdentifier="{identifier}">
    <SourceFileSet language="C99">
{files}
    </SourceFileSet>
  </BuildConfiguration>
</fmiBuildDescription>
"""


def _with_fmi2_source_files(description: bytes, c_files: list[str]) -> bytes:
    """FMI 2.0 lists sources in the model description: insert <SourceFiles> in each interface."""
    from lxml import etree  # fmpy's own dependency; keeps comments and layout

    root = etree.fromstring(description)
    for interface in root:
        if interface.tag in ("CoSimulation", "ModelExchange"):
            for old in interface.findall("SourceFiles"):
                interface.remove(old)
            source_files = etree.Element("SourceFiles")
            for name in c_files:
                etree.SubElement(source_files, "File", name=name)
            interface.insert(0, source_files)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8")


def _cmake() -> str:
    for candidate in (Path(sys.executable).parent / "cmake", shutil.which("cmake")):
        if candidate and Path(candidate).is_file():
            return str(candidate)
    raise FMUBuildError("cmake was not found (pip install cmake, or install it with the system)")


def _link_options() -> dict[str, str]:
    """CMake cache entries that make the binary link what it uses: fmpy's CMake project does not
    link libm, which leaves ``sin``/``cos`` unresolved for hosts that have not loaded it."""
    return {} if sys.platform == "win32" else {"CMAKE_C_STANDARD_LIBRARIES:STRING": "-lm"}


def _compile(unzipdir: Path, build_dir: Path) -> None:
    """Compile ``unzipdir/sources`` into ``unzipdir/binaries/<platform>`` with fmpy's CMake project.

    This is what ``fmpy.build.build_platform_binary`` does, with the tool output captured
    for logging and error messages instead of printed.
    """
    try:
        from fmpy.build import create_cmake_settings
    except ImportError as e:
        raise FMUBuildError(f"building source FMUs needs fmpy.build.create_cmake_settings "
                            f"(fmpy 0.3.32 has it), but fmpy is {fmpy.__version__}") from e
    build_dir.mkdir(parents=True)
    create_cmake_settings(unzipdir, build_dir, all_warnings=True, cmake_options=_link_options())
    cmake = _cmake()
    project = Path(fmpy.__file__).parent / "c-code"
    output = []
    for command in ([cmake, "-S", str(project), "-B", str(build_dir)],
                    [cmake, "--build", str(build_dir), "--target", "install", "--config", "Release"]):
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        output.append(result.stdout)
        logger.debug("%s\n%s", " ".join(command), result.stdout)
        if result.returncode != 0:
            raise FMUBuildError(f"building {unzipdir} failed ({' '.join(command)}):\n" + "".join(output))
    if "warning:" in output[-1]:
        logger.warning("compiler warnings while building %s:\n%s", unzipdir, output[-1])


def _check_binary(unzipdir: Path, identifier: str) -> None:
    binaries = list((unzipdir / "binaries").glob(f"*/{identifier}.*"))
    if not binaries:
        raise FMUBuildError(f"the build produced no binary for {identifier} in {unzipdir / 'binaries'}")


def _zip(unzipdir: Path, path: Path) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for file in sorted(p for p in unzipdir.rglob("*") if p.is_file()):
            zf.write(file, file.relative_to(unzipdir).as_posix())
