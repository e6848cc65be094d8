"""A model folder's model description with some declared capabilities changed, for `build_source_fmu`.

FMUs in the wild declare what our test models do not: one instance per process, no state
snapshots, a non-zero start time. The same C model built with an edited model description
reproduces them (the test family's variants, ``tests/fmu_family.py``; the ``moody`` FMU allowed
once per process in ``python -m benchmarks pool-gain``). The edit lives apart from ``build.py``
because every cached FMU's key hashes that file: editing this one rebuilds nothing.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from lxml import etree  # fmpy's own dependency; keeps comments and layout

from modelicagym.cache import ELSEWHERE, cache_dir
from modelicagym.disk import atomic_write
from modelicagym.errors import ArgumentError

#: the interfaces whose capability flags an edit sets
_INTERFACES = ("CoSimulation", "ModelExchange")


def edited_description(base: str | Path, *, once_per_process: bool = False, snapshots: bool = True,
                       start_time: float | None = None) -> Path:
    """The FMI 2.0 or 3.0 model description ``base`` with every interface declaring
    ``canBeInstantiatedOnlyOncePerProcess`` (``once_per_process``), no FMU state snapshots
    (``snapshots=False``) and the default experiment starting at ``start_time``; written to the
    cache under a name made from its content (so that it is written once), for
    ``build_source_fmu(..., model_description=...)``."""
    base = Path(base)
    root = etree.fromstring(base.read_bytes())
    version = root.get("fmiVersion", "")
    if not version.startswith(("2.", "3.")):
        raise ArgumentError(f"{base}: only FMI 2.0 and 3.0 model descriptions can be edited, "
                            f"not fmiVersion {version!r}")
    state = "canGetAndSetFMUstate" if version.startswith("2.") else "canGetAndSetFMUState"
    serialize = "canSerializeFMUstate" if version.startswith("2.") else "canSerializeFMUState"
    for interface in root:
        if interface.tag not in _INTERFACES:
            continue
        if once_per_process:
            interface.set("canBeInstantiatedOnlyOncePerProcess", "true")
        if not snapshots:
            interface.set(state, "false")
            interface.set(serialize, "false")
    if start_time is not None:
        root.find("DefaultExperiment").set("startTime", repr(start_time))
    text = etree.tostring(root, xml_declaration=True, encoding="UTF-8")
    path = cache_dir() / "descriptions" / f"{hashlib.sha256(text).hexdigest()[:16]}.xml"
    if not path.is_file():
        with atomic_write(path, "wb", elsewhere=ELSEWHERE) as handle:
            handle.write(text)
    return path
