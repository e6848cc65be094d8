"""Write a sample: its FMUs built from the package's C sources, its task file and data, into a folder.

Each sample folder beside this module holds a model's C sources and model descriptions (built by
`modelicagym.fmu.build.build_source_fmu`, cached as the bundled models are) and what is copied as
it is: a task file, a table. The ``system`` sample also gets an SSP archive, zipped here from its
``SystemStructure.ssd`` and the files the SSD names: an SSP holds FMUs, and those are built, so
the archive is assembled when the sample is written.

Nothing a user has is overwritten unless asked: a file that is already there with other content is
a refusal naming it (``force=True`` replaces it); a file already there with the same content is
left as it is, so writing a sample twice is harmless.
"""

from __future__ import annotations

import difflib
import io
import logging
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

from modelicagym.disk import atomic_write
from modelicagym.errors import ArgumentError, ModelicaGymError

__all__ = ["SAMPLES", "Sample", "SampleExistsError", "sample_files", "write_sample"]

logger = logging.getLogger(__name__)

SAMPLES_DIR = Path(__file__).resolve().parent
#: a fixed date for the SSP's entries, so the same sample gives the same archive, byte for byte
_ZIP_DATE = (2026, 1, 1, 0, 0, 0)


class SampleExistsError(ModelicaGymError, FileExistsError):
    """A file the sample would write is already there, with other content."""


@dataclass(frozen=True)
class Built:
    """An FMU built from the model folder ``model`` (beside this module) for FMI ``fmi_version``."""

    model: str
    fmi_version: int

    def content(self) -> bytes:
        from modelicagym.fmu.build import build_source_fmu  # here: fmpy is imported only to build

        return build_source_fmu(SAMPLES_DIR / self.model, self.fmi_version).read_bytes()


@dataclass(frozen=True)
class Copied:
    """A file beside this module, copied as it is."""

    path: str

    def content(self) -> bytes:
        return (SAMPLES_DIR / self.path).read_bytes()


@dataclass(frozen=True)
class Archive:
    """An SSP archive: the SSD ``ssd`` (beside this module) as ``SystemStructure.ssd``, and the
    sample's other files ``resources`` under ``resources/`` (where the SSD's sources point)."""

    ssd: str
    resources: tuple[str, ...]


@dataclass(frozen=True)
class Sample:
    """A sample: what it is (one line), the files it writes (name -> where the content comes from),
    and the commands to try next on them."""

    name: str
    summary: str
    files: dict[str, Built | Copied | Archive]
    next_steps: tuple[str, ...]


SAMPLES: dict[str, Sample] = {sample.name: sample for sample in (
    Sample("heater", "a room heated by an electric heater (FMI 2.0); task: hold 21 degC",
           {"heater.fmu": Built("heater", 2), "heater_task.py": Copied("heater/heater_task.py")},
           ("modelicagym info heater.fmu", "modelicagym try heater_task.py", "modelicagym bench fmu heater.fmu",
            "python examples/train_own_fmu.py heater_task.py   (the script is in the repository's examples/)")),
    Sample("drive", "a motor turning a load through an elastic shaft (FMI 2.0); task: a speed setpoint under a "
                    "random load, with a PI to compare with",
           {"drive.fmu": Built("drive", 2), "drive_task.py": Copied("drive/drive_task.py")},
           ("modelicagym info drive.fmu", "modelicagym try drive_task.py", "modelicagym bench fmu drive.fmu",
            "modelicagym try drive_task.py --policy baseline",
            "python examples/train_own_fmu.py drive_task.py   (the script is in the repository's examples/)")),
    Sample("system", "a motor (FMI 2.0) and a shaft (FMI 3.0) that connect as a system, a load table, "
                     "and the system as an SSP",
           {"motor.fmu": Built("motor", 2), "inertia.fmu": Built("inertia", 3), "load.csv": Copied("system/load.csv"),
            "drive.ssp": Archive("system/SystemStructure.ssd", ("motor.fmu", "inertia.fmu", "load.csv")),
            "system_task.py": Copied("system/system_task.py")},
           ("modelicagym info drive.ssp", "modelicagym try system_task.py", "modelicagym bench fmu drive.ssp")),
    Sample("loop", "a controller (FMI 2.0) and a plant (FMI 3.0) that close a loop through direct feedthrough",
           {"controller.fmu": Built("pcontrol", 2), "plant.fmu": Built("feedplant", 3),
            "loop_task.py": Copied("loop/loop_task.py")},
           ("modelicagym info plant.fmu", "modelicagym try loop_task.py")),
)}


def sample_files(name: str) -> dict[str, bytes]:
    """The files the sample ``name`` writes, by file name, with their content (FMUs built, or taken
    from the cache, on the way)."""
    sample = _sample(name)
    contents: dict[str, bytes] = {}
    for file_name, source in sample.files.items():
        if isinstance(source, Archive):
            contents[file_name] = _ssp(source, contents)
        else:
            contents[file_name] = source.content()
    return contents


def write_sample(name: str, out: str | os.PathLike[str] = ".", *, force: bool = False) -> list[Path]:
    """Write the sample ``name`` (one of `SAMPLES`) into the folder ``out`` (made if missing) and
    return the paths of its files, in the sample's order (the FMUs first).

    A file already in ``out`` with other content is a `SampleExistsError` naming it, before
    anything is written, unless ``force``; one with the same content is left as it is.
    """
    contents = sample_files(name)
    folder = Path(out).expanduser()
    if folder.exists() and not folder.is_dir():
        raise ArgumentError(f"--out {folder}: not a folder (a sample is several files: give a folder)")
    targets = {folder / file_name: content for file_name, content in contents.items()}
    clashes = [path for path, content in targets.items() if path.exists() and not _same(path, content)]
    if clashes and not force:
        raise SampleExistsError(f"{', '.join(map(str, clashes))}: already there, with other content; the sample "
                                f"{name!r} leaves it alone (move it away, write the sample elsewhere with --out DIR, "
                                "or replace it with --force)")
    for path, content in targets.items():
        if path.exists() and _same(path, content):
            logger.debug("%s is already there, the same", path)
            continue
        with atomic_write(path, "wb", elsewhere="write the sample elsewhere with --out DIR") as target:
            target.write(content)
        path.chmod(0o644)  # a user's file, readable as any other (the temporary file it was is private)
    return list(targets)


def _sample(name: str) -> Sample:
    if name in SAMPLES:
        return SAMPLES[name]
    close = difflib.get_close_matches(name, list(SAMPLES), n=2, cutoff=0.5)
    hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    raise ArgumentError(f"no sample named {name!r}.{hint} Samples: {', '.join(SAMPLES)}")


def _same(path: Path, content: bytes) -> bool:
    return path.is_file() and path.stat().st_size == len(content) and path.read_bytes() == content


def _ssp(archive: Archive, written: dict[str, bytes]) -> bytes:
    """The SSP archive's bytes: its SSD and, under ``resources/``, the sample's files it names."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as ssp:
        _add(ssp, "SystemStructure.ssd", Copied(archive.ssd).content())
        for name in archive.resources:
            _add(ssp, f"resources/{name}", written[name])
    return buffer.getvalue()


def _add(ssp: zipfile.ZipFile, entry: str, content: bytes) -> None:
    info = zipfile.ZipInfo(entry, _ZIP_DATE)
    info.external_attr = 0o644 << 16  # -rw-r--r-- where unzip restores permissions
    ssp.writestr(info, content, zipfile.ZIP_DEFLATED)
