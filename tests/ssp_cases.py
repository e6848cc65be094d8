"""SSP systems written here piece by piece, as other tools export them (OMSimulator, FMI Composer):
systems nested in systems, the system's own connectors, parameter sets at every level, mappings.
Each function returns a piece of ``SystemStructure.ssd``'s XML; `write_ssp_folder` writes the
folder (the SSD, the FMUs under ``resources/``, any other files)."""

from __future__ import annotations

import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path

SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
SSM_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterMapping"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"


def connectors(**kinds: str) -> str:
    """``<ssd:Connectors>``: ``name=kind`` each, of Real type."""
    rows = "".join(f'<ssd:Connector name="{name}" kind="{kind}"><ssc:Real/></ssd:Connector>'
                   for name, kind in kinds.items())
    return f"<ssd:Connectors>{rows}</ssd:Connectors>" if rows else ""


def parameter_set(values: Mapping[str, float]) -> str:
    """An ``ssv:ParameterSet`` of Real values (the root of an .ssv file, or inline)."""
    rows = "".join(f'<ssv:Parameter name="{name}"><ssv:Real value="{value}"/></ssv:Parameter>'
                   for name, value in values.items())
    return f'<ssv:ParameterSet version="1.0" name="set" xmlns:ssv="{SSV_NS}"><ssv:Parameters>{rows}' \
           f'</ssv:Parameters></ssv:ParameterSet>'


def mapping(*entries: tuple[str, str]) -> str:
    """An ``ssm:ParameterMapping`` (the root of an .ssm file): ``(source, target)`` each."""
    rows = "".join(f'<ssm:MappingEntry source="{source}" target="{target}"/>' for source, target in entries)
    return f'<ssm:ParameterMapping version="1.0" xmlns:ssm="{SSM_NS}" xmlns:ssc="{SSC_NS}">{rows}' \
           f'</ssm:ParameterMapping>'


def bindings(*sets: Mapping[str, float], source: str | None = None, ssm: str | None = None) -> str:
    """``<ssd:ParameterBindings>``: one binding per inline set (in order), then one of the .ssv
    file ``source`` (with the .ssm file ``ssm``)."""
    rows = "".join(f"<ssd:ParameterBinding><ssd:ParameterValues>{parameter_set(values)}</ssd:ParameterValues>"
                   f"</ssd:ParameterBinding>" for values in sets)
    if source is not None:
        inner = f'<ssd:ParameterMapping source="{ssm}"/>' if ssm else ""
        rows += f'<ssd:ParameterBinding source="{source}">{inner}</ssd:ParameterBinding>'
    return f"<ssd:ParameterBindings>{rows}</ssd:ParameterBindings>" if rows else ""


def component(name: str, fmu: str, parameters: str = "") -> str:
    """An FMU component, ``resources/<fmu>.fmu``."""
    return f'<ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" ' \
           f'source="resources/{fmu}.fmu">{parameters}</ssd:Component>'


def connect(start: str, end: str, factor: float | None = None, offset: float | None = None) -> str:
    """A connection ``"element.connector"`` -> ``"element.connector"`` (``".connector"``: the
    system's own, written with ``startElement=""`` as OMSimulator writes it)."""
    (start_element, start_connector), (end_element, end_connector) = start.split("."), end.split(".")
    linear = ""
    if factor is not None or offset is not None:
        linear = f'<ssc:LinearTransformation factor="{1.0 if factor is None else factor}" ' \
                 f'offset="{0.0 if offset is None else offset}"/>'
    return f'<ssd:Connection startElement="{start_element}" startConnector="{start_connector}" ' \
           f'endElement="{end_element}" endConnector="{end_connector}">{linear}</ssd:Connection>'


def system(name: str, elements: Sequence[str], connections: Sequence[str] = (), own: str = "",
           parameters: str = "") -> str:
    """An ``ssd:System``: its connectors ``own``, parameter bindings, elements and connections."""
    return f'<ssd:System name="{name}">{own}{parameters}<ssd:Elements>{"".join(elements)}</ssd:Elements>' \
           f'<ssd:Connections>{"".join(connections)}</ssd:Connections></ssd:System>'


def ssd(top: str) -> str:
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription version="1.0" name="top" ' \
           f'xmlns:ssc="{SSC_NS}" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" ' \
           f'xmlns:ssv="{SSV_NS}">\n{top}\n</ssd:SystemStructureDescription>\n'


def write_ssp_folder(folder: Path, top: str, fmus: Mapping[str, Path], files: Mapping[str, str] = ()) -> Path:
    """An unpacked SSP: ``SystemStructure.ssd`` of system ``top``, each FMU as
    ``resources/<name>.fmu``, and ``files`` (path -> text)."""
    (folder / "resources").mkdir(parents=True)
    (folder / "SystemStructure.ssd").write_text(ssd(top))
    for name, path in fmus.items():
        shutil.copy(path, folder / "resources" / f"{name}.fmu")
    for name, text in dict(files).items():
        (folder / name).write_text(text)
    return folder
