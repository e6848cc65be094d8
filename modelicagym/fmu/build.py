"""Build source FMUs from our C framework and a model folder, cached by content hash.

A *model folder* holds a model's C sources (``model.c``, ``config.h``, any other
``*.c``/``*.h``) and its model descriptions ``modelDescription_fmi2.xml``,
``modelDescription_fmi3.xml`` and/or ``modelDescription_fmi1_cs.xml`` /
``modelDescription_fmi1_me.xml`` (see ``modelicagym/models/csrc/model.h`` for the C
contract). FMI 2.0 and 3.0 FMUs offer co-simulation and model exchange in one binary;
an FMI 1.0 FMU is one or the other, so FMI 1.0 is built per mode. :func:`build_source_fmu` assembles a source FMU (model description,
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

import functools
import hashlib
import logging
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union
from xml.etree import ElementTree

import fmpy

from modelicagym.cache import cache_dir, ensure, write_manifest
from modelicagym.disk import atomic_write, build_ran_out_of_room, disk_full
from modelicagym.errors import ArgumentError, BuildError, NotFoundError
from modelicagym.fmu.errors import FMUError

__all__ = [
    "FMI_VERSIONS",
    "FMUBuildError",
    "FRAMEWORK_DIR",
    "MODELS_DIR",
    "build_all_models",
    "build_model_folder",
    "build_source_fmu",
    "bundled_fmus",
    "cache_dir",
    "compile_sources",
    "description_name",
]

logger = logging.getLogger(__name__)

DefineValue = Union[str, int, float, bool, None]

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
FRAMEWORK_DIR = MODELS_DIR / "csrc"
_FRAMEWORK_FILES = ("model.h", "fmu_instance.h", "fmu_internal.h", "fmu_instance.c", "fmu_solver.c")
_ADAPTERS = {1: "fmi1Functions.c", 2: "fmi2Functions.c", 3: "fmi3Functions.c"}
#: The FMI versions a source FMU can be built for.
FMI_VERSIONS = tuple(sorted(_ADAPTERS))
_MODES = ("cs", "me")
#: What build_config.h defines to choose the API of an FMI 1.0 binary.
_FMI1_DEFINES = {"cs": "FMI1_CO_SIMULATION", "me": "FMI1_MODEL_EXCHANGE"}
_GENERATED_HEADER = "build_config.h"
_BUILD_DESCRIPTION = "buildDescription.xml"
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class FMUBuildError(FMUError, BuildError):
    """A source FMU could not be assembled or compiled (the message holds the compiler output)."""


def description_name(fmi_version: int, mode: str | None = None) -> str:
    """The file name of a model folder's model description for ``fmi_version`` (and, for FMI 1.0,
    ``mode``): ``modelDescription_fmi2.xml``, ``modelDescription_fmi1_cs.xml``, ..."""
    return f"modelDescription_fmi{fmi_version}_{mode}.xml" if fmi_version == 1 else f"modelDescription_fmi{fmi_version}.xml"


def build_source_fmu(
    model_dir: str | os.PathLike,
    fmi_version: int = 2,
    mode: str | None = None,
    *,
    model_description: str | os.PathLike | None = None,
    defines: Mapping[str, DefineValue] | None = None,
    cache: str | os.PathLike | None = None,
) -> Path:
    """Return the path of the built ``.fmu`` for a model folder, building it on a cache miss.

    Args:
        model_dir: folder with the model's ``*.c``/``*.h`` files and model descriptions.
        fmi_version: 1, 2 or 3; selects the model description (:func:`description_name`) and
            the adapter.
        mode: FMI 1.0 only (an FMI 1.0 FMU is either co-simulation or model exchange):
            ``"cs"`` (default) or ``"me"``. FMI 2.0/3.0 FMUs offer both in one binary and
            ignore it.
        model_description: another model description file (relative to ``model_dir`` or
            absolute); its ``fmiVersion`` (and for FMI 1.0 its interface type) must match.
        defines: extra preprocessor definitions written to ``build_config.h``
            (``None`` defines a flag, ``bool`` becomes 1/0), e.g. to configure a test FMU.
        cache: cache folder, default :func:`cache_dir`.
    """
    job = _BuildJob.create(Path(model_dir), fmi_version, mode, model_description, defines or {})
    target = job.target(cache)
    return ensure(target, lambda: job.build(target), f"the built FMU {target.name}")


def build_model_folder(folder: str | os.PathLike, fmi_versions: Sequence[int] | None = None, *,
                       out: str | os.PathLike | None = None) -> Path:
    """``modelicagym build FOLDER [--out MY.fmu]``: build one model folder (a test FMU of
    ``tests/fmus``, or a model of your own written with our C framework) for one FMI version
    (default 2.0), and copy the ``.fmu`` to ``out`` when given (else return its cache path)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise NotFoundError(f"model folder not found: {folder}")
    versions = list(fmi_versions or [2])
    if len(versions) != 1:
        raise ArgumentError(f"a model folder is built for one FMI version at a time, not {versions} (--fmi-version N)")
    built = build_source_fmu(folder, versions[0])
    if out is None:
        return built
    with open(built, "rb") as source, atomic_write(out, "wb", elsewhere="choose another --out") as target:
        shutil.copyfileobj(source, target)
    return Path(out)


def build_all_models(cache: str | os.PathLike | None = None,
                     fmi_versions: Sequence[int] | None = None) -> list[Path]:
    """Build every model shipped in ``modelicagym/models`` for each FMI version (and, for FMI 1.0,
    each interface type) it describes; ``fmi_versions`` restricts the versions."""
    versions = sorted(_ADAPTERS) if fmi_versions is None else sorted(set(fmi_versions))
    for version in versions:
        _check_version(version)
    return [build_source_fmu(model_dir, version, mode, cache=cache) for model_dir, version, mode in _bundled(versions)]


def bundled_fmus(cache: str | os.PathLike | None = None) -> frozenset[Path]:
    """Where `build_source_fmu` puts (or would put) each model shipped in ``modelicagym/models``:
    FMUs built from our own sources, which need no first-load trial (`modelicagym.fmu.trial`).
    Computed once per process and cache folder (it hashes the models' sources)."""
    return _bundled_targets(Path(cache) if cache is not None else cache_dir())


@functools.cache
def _bundled_targets(cache: Path) -> frozenset[Path]:
    return frozenset(_BuildJob.create(model_dir, version, mode, None, {}).target(cache)
                     for model_dir, version, mode in _bundled(FMI_VERSIONS))


def _bundled(versions: Sequence[int]) -> Iterator[tuple[Path, int, str | None]]:
    """``(model folder, FMI version, mode)`` of every build of a shipped model in ``versions``."""
    for model_dir in sorted(p for p in MODELS_DIR.iterdir() if p.is_dir() and p != FRAMEWORK_DIR):
        for version in versions:
            for mode in _MODES if version == 1 else (None,):
                if (model_dir / description_name(version, mode)).is_file():
                    yield model_dir, version, mode


def _check_version(fmi_version: object) -> None:
    if isinstance(fmi_version, bool) or fmi_version not in _ADAPTERS:
        raise ArgumentError(f"fmi_version must be one of {', '.join(map(str, FMI_VERSIONS))}, not {fmi_version!r}")


def compile_sources(unzipdir: str | os.PathLike, build_dir: str | os.PathLike | None = None) -> Path:
    """Compile an extracted source FMU's ``sources/`` into its ``binaries/<platform>`` folder with
    fmpy's CMake project; returns the binary.

    FMI 2.0 and 3.0 FMUs list their sources (``<SourceFiles>``, ``buildDescription.xml``) and fmpy
    reads the list; FMI 1.0 model descriptions list none, so every ``sources/*.c`` is compiled.
    """
    unzipdir = Path(unzipdir)
    root = ElementTree.parse(unzipdir / "modelDescription.xml").getroot()
    version = root.get("fmiVersion", "")
    if version.startswith("1."):
        identifier = root.get("modelIdentifier") or ""
        c_files = sorted(p.name for p in (unzipdir / "sources").glob("*.c"))
    else:
        identifier = next((e.get("modelIdentifier") for e in root if e.tag in ("CoSimulation", "ModelExchange")), "")
        c_files = None
    with tempfile.TemporaryDirectory(prefix="modelicagym-build-") as tmp:
        _compile(unzipdir, Path(build_dir) if build_dir else Path(tmp) / "build", identifier, c_files)
    return _check_binary(unzipdir, identifier)


@dataclass
class _BuildJob:
    """Everything one build needs, read once; ``key`` hashes all of it."""

    description: bytes
    sources: dict[str, bytes]
    defines: dict[str, str | None]
    fmi_version: int
    mode: str | None
    identifier: str
    token: str
    key: str = field(init=False)

    def __post_init__(self) -> None:
        self.key = self._hash()

    @classmethod
    def create(cls, model_dir: Path, fmi_version: int, mode: str | None,
               model_description: str | os.PathLike | None, defines: Mapping[str, DefineValue]) -> "_BuildJob":
        _check_version(fmi_version)
        if mode is not None and mode not in _MODES:
            raise ArgumentError(f"mode must be one of {', '.join(map(repr, _MODES))}, not {mode!r}")
        mode = (mode or "cs") if fmi_version == 1 else None
        md_path = model_dir / (model_description or description_name(fmi_version, mode))
        if not md_path.is_file():
            raise NotFoundError(f"model description not found: {md_path}")
        description = md_path.read_bytes()
        identifier, token = _read_description(description, fmi_version, mode, md_path)
        sources = _read_sources(model_dir, fmi_version)
        normalized = _normalize_defines(defines)
        if fmi_version == 1:
            normalized = {"MODEL_IDENTIFIER": identifier, _FMI1_DEFINES[mode]: None, **normalized}
        return cls(description, sources, normalized, fmi_version, mode, identifier, token)

    def _hash(self) -> str:
        h = hashlib.sha256()
        for part in (fmpy.__version__, fmpy.platform_tuple, sys.platform, Path(__file__).read_bytes(),
                     self.description, repr(sorted(self.defines.items()))):
            h.update(part if isinstance(part, bytes) else part.encode())
            h.update(b"\0")
        for name in sorted(self.sources):
            h.update(name.encode() + b"\0" + self.sources[name] + b"\0")
        return h.hexdigest()[:16]

    def target(self, cache: str | os.PathLike | None) -> Path:
        """Where this build is published in the cache folder ``cache`` (default: `cache_dir`)."""
        fmus = Path(cache) if cache is not None else cache_dir()
        flavour = f"fmi1{self.mode}" if self.fmi_version == 1 else f"fmi{self.fmi_version}"
        return fmus / "fmus" / f"{self.identifier}-{flavour}-{self.key}.fmu"

    def build(self, target: Path) -> None:
        """Assemble, compile and zip into ``target`` (atomically)."""
        logger.info("building %s (FMI %d%s) -> %s", self.identifier, self.fmi_version,
                    f" {self.mode}" if self.mode else "", target)
        tmp_root = target.parent.parent / "tmp"
        tmp_root.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=f"{self.identifier}-", dir=tmp_root))
        try:
            unzipdir = work / "fmu"
            self._assemble(unzipdir)
            _compile(unzipdir, work / "build", self.identifier,
                     sorted(n for n in self.sources if n.endswith(".c")) if self.fmi_version == 1 else None)
            _check_binary(unzipdir, self.identifier)
            partial = work / "partial.fmu"
            _zip(unzipdir, partial)
            target.parent.mkdir(parents=True, exist_ok=True)
            write_manifest(partial, published_as=target)
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


def _read_description(description: bytes, fmi_version: int, mode: str | None, path: Path) -> tuple[str, str]:
    """Check the FMI version (and FMI 1.0's interface type); return the model identifier and the
    guid / instantiation token."""
    try:
        root = ElementTree.fromstring(description)
    except ElementTree.ParseError as e:
        raise FMUBuildError(f"{path}: {e}") from e
    if not root.get("fmiVersion", "").startswith(f"{fmi_version}."):
        raise FMUBuildError(f"{path}: fmiVersion is {root.get('fmiVersion')!r}, expected FMI {fmi_version}")
    if fmi_version == 1:
        # FMI 1.0: the identifier is an attribute of the root; <Implementation> makes it co-simulation.
        described = "cs" if root.find("Implementation") is not None else "me"
        if described != mode:
            raise FMUBuildError(f"{path} describes an FMI 1.0 {'co-simulation' if described == 'cs' else 'model-exchange'} "
                                f"FMU, not mode={mode!r}")
        identifier = root.get("modelIdentifier")
        if not identifier or not _IDENTIFIER.match(identifier):
            raise FMUBuildError(f"{path}: modelIdentifier {identifier!r} is not a C identifier")
        return identifier, root.get("guid") or ""
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


def _compile(unzipdir: Path, build_dir: Path, identifier: str, c_files: list[str] | None) -> None:
    """Compile ``unzipdir/sources`` into ``unzipdir/binaries/<platform>`` with fmpy's CMake project.

    This is what ``fmpy.build.build_platform_binary`` does, with the tool output captured
    for logging and error messages instead of printed. ``c_files`` (FMI 1.0, whose model
    descriptions fmpy reads no source list from) are the sources to compile; ``None`` lets fmpy
    read them from the FMU.
    """
    build_dir.mkdir(parents=True)
    if c_files is None:
        try:
            from fmpy.build import create_cmake_settings
        except ImportError as e:
            raise FMUBuildError(f"building source FMUs needs fmpy.build.create_cmake_settings "
                                f"(fmpy 0.3.32 has it), but fmpy is {fmpy.__version__}") from e
        create_cmake_settings(unzipdir, build_dir, all_warnings=True, cmake_options=_link_options())
    else:
        _write_cmake_settings(unzipdir, build_dir, identifier, c_files)
    cmake = _cmake()
    project = Path(fmpy.__file__).parent / "c-code"
    output = []
    for command in ([cmake, "-S", str(project), "-B", str(build_dir)],
                    [cmake, "--build", str(build_dir), "--target", "install", "--config", "Release"]):
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        output.append(result.stdout)
        logger.debug("%s\n%s", " ".join(command), result.stdout)
        if result.returncode != 0 and build_ran_out_of_room(result.stdout, build_dir):
            raise disk_full(unzipdir / "binaries")
        if result.returncode != 0:
            raise FMUBuildError(f"building {unzipdir} failed ({' '.join(command)}):\n" + "".join(output))
    if "warning:" in output[-1]:
        logger.warning("compiler warnings while building %s:\n%s", unzipdir, output[-1])


def _write_cmake_settings(unzipdir: Path, build_dir: Path, identifier: str, c_files: list[str]) -> None:
    """The CMake cache ``fmpy.build.create_cmake_settings`` writes, for an FMI 1.0 source FMU
    (binaries in ``binaries/<fmpy.platform>``, as for FMI 2.0)."""
    sources = unzipdir / "sources"
    if not c_files:
        raise FMUBuildError(f"{sources} has no C sources to compile")
    entries = {
        "CMAKE_BUILD_TYPE:STRING": "Release",
        "CMAKE_C_STANDARD:STRING": "99",
        "FMI_MODEL_IDENTIFIER:STRING": identifier,
        "FMI_INCLUDE_DIRS:STRING": sources.as_posix(),
        "FMI_SOURCES:STRING": ";".join((sources / name).as_posix() for name in c_files),
        "FMI_DEFINITIONS:STRING": "",
        "FMI_TARGET_DIR:STRING": (unzipdir / "binaries" / fmpy.platform).as_posix(),
        "FMI_ALL_WARNINGS:BOOL": "ON",
        **_link_options(),
    }
    (build_dir / "CMakeCache.txt").write_text("".join(f"{name}={value}\n" for name, value in entries.items()))


def _check_binary(unzipdir: Path, identifier: str) -> Path:
    binaries = sorted((unzipdir / "binaries").glob(f"*/{identifier}.*"))
    if not binaries:
        raise FMUBuildError(f"the build produced no binary for {identifier} in {unzipdir / 'binaries'}")
    return binaries[0]


def _zip(unzipdir: Path, path: Path) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for file in sorted(p for p in unzipdir.rglob("*") if p.is_file()):
            zf.write(file, file.relative_to(unzipdir).as_posix())
