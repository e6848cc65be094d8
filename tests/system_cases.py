"""The systems of the system tests (tests/system): the Motor (FMI 2.0) driving the Inertia
(FMI 3.0), fed back its speed (rad/s into rpm), as a config and as an SSP archive; and the
reference they are held to, a co-simulation loop written by hand over FMPy's own FMU classes."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

#: rpm in rad/s, as the Motor's unit definition gives it
RPM = 0.10471975511965977
CONNECTIONS = [("motor.tau", "plant.tau"), ("plant.w", "motor.w")]
OUTPUTS = ["plant.w", "plant.phi", "plant.a", "motor.tau", "motor.tau_set"]
TIME_STEP = 0.01


def system_config(motor: Path, inertia: Path, **options: Any) -> dict[str, Any]:
    """The motor and the shaft connected both ways; the agent drives the motor's command."""
    return {"fmus": {"motor": str(motor), "plant": str(inertia)}, "connections": CONNECTIONS,
            "inputs": ["motor.u"], "outputs": OUTPUTS, "time_step": TIME_STEP, **options}


class _Slave:
    """One FMU in the hand-written loop: FMPy's class, its variables by name."""

    def __init__(self, path: Path, name: str, parameters: dict[str, float]):
        md = read_model_description(str(path))
        self.refs = {v.name: v.valueReference for v in md.modelVariables}
        unzipped = extract(str(path))
        self.fmi3 = md.fmiVersion.startswith("3")
        if self.fmi3:
            self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                                 instanceName=name)
            self.fmu.instantiate()
            self.set(parameters)
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                                 instanceName=name)
            self.fmu.instantiate()
            self.set(parameters)
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def set(self, values: dict[str, float]) -> None:
        for name, value in values.items():
            (self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal)([self.refs[name]], [value])

    def get(self, name: str) -> float:
        return (self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal)([self.refs[name]])[0]

    def step(self, t: float, h: float) -> None:
        self.fmu.doStep(t, h) if self.fmi3 else self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


def hand_loop(motor: Path, inertia: Path, actions: np.ndarray, master: str, parameters: dict[str, float] | None = None,
              load: Any = None) -> np.ndarray:
    """The system's observations (`OUTPUTS`, after the reset and after each action), computed by a
    fixed-step co-simulation written out here: Gauss-Seidel steps the motor, then the shaft, each
    taking the other's latest values; Jacobi steps both on the values at the step's start. ``load``
    (a function of time) drives the shaft's load torque as a table would, at the end of the step."""
    parameters = parameters or {}
    m = _Slave(motor, "motor", {k[6:]: v for k, v in parameters.items() if k.startswith("motor.")})
    p = _Slave(inertia, "plant", {k[6:]: v for k, v in parameters.items() if k.startswith("plant.")})

    def observe() -> list[float]:
        return [p.get("w"), p.get("phi"), p.get("a"), m.get("tau"), m.get("tau_set")]

    m.set({"w": p.get("w") / RPM})  # the connections settled once after the initialization
    p.set({"tau": m.get("tau"), **({} if load is None else {"tau_load": load(0.0)})})
    rows = [observe()]
    for k, action in enumerate(actions):
        t, h = k * TIME_STEP, (k + 1) * TIME_STEP - k * TIME_STEP
        m.set({"u": float(action)})
        if load is not None:  # a table steps first: Gauss-Seidel passes on its value at the step's end
            p.set({"tau_load": load(t if master == "jacobi" else (k + 1) * TIME_STEP)})
        if master == "jacobi":
            w, tau = p.get("w"), m.get("tau")
            m.set({"w": w / RPM})
            p.set({"tau": tau})
            m.step(t, h)
            p.step(t, h)
        else:
            m.set({"w": p.get("w") / RPM})
            m.step(t, h)
            p.set({"tau": m.get("tau")})
            p.step(t, h)
        rows.append(observe())
    m.close()
    p.close()
    return np.array(rows)


SSD = """<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription version="1.0" name="drive"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription">
  <ssd:System name="drive">
    <ssd:ParameterBindings>
      <ssd:ParameterBinding source="resources/drive.ssv">
        <ssd:ParameterMapping source="resources/drive.ssm"/>
      </ssd:ParameterBinding>
    </ssd:ParameterBindings>
    <ssd:Elements>
      <ssd:Component name="motor" type="application/x-fmu-sharedlibrary" source="resources/motor.fmu"
          implementation="CoSimulation">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="w" kind="input"><ssc:Real unit="rpm"/></ssd:Connector>
          <ssd:Connector name="tau" kind="output"><ssc:Real unit="N.m"/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding>
            <ssd:ParameterValues>
              <ssv:ParameterSet version="1.0" name="motor" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">
                <ssv:Parameters>
                  <ssv:Parameter name="k"><ssv:Real value="0.8"/></ssv:Parameter>
                </ssv:Parameters>
              </ssv:ParameterSet>
            </ssd:ParameterValues>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="plant" type="application/x-fmu-sharedlibrary" source="resources/plant.fmu">
        <ssd:Connectors>
          <ssd:Connector name="tau" kind="input"><ssc:Real unit="N.m"/></ssd:Connector>
          <ssd:Connector name="w" kind="output"><ssc:Real unit="rad/s"/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="motor" startConnector="tau" endElement="plant" endConnector="tau"/>
      <ssd:Connection startElement="plant" startConnector="w" endElement="motor" endConnector="w"/>
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="2"/>
</ssd:SystemStructureDescription>
"""

# the initial speed in rpm, a unit the set defines: converted to the FMU's rad/s
SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet version="1.0" name="drive" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">
  <ssv:Parameters>
    <ssv:Parameter name="inertia_g_m2"><ssv:Real value="20"/></ssv:Parameter>
    <ssv:Parameter name="plant.d"><ssv:Real value="0.002"/></ssv:Parameter>
    <ssv:Parameter name="plant.w_0"><ssv:Real value="60" unit="rpm"/></ssv:Parameter>
  </ssv:Parameters>
  <ssv:Units>
    <ssc:Unit name="rpm"><ssc:BaseUnit rad="1" s="-1" factor="0.10471975511965977"/></ssc:Unit>
  </ssv:Units>
</ssv:ParameterSet>
"""

# the parameter set's inertia is in g.m2: the mapping names it and scales it to the FMU's kg.m2
SSM = """<?xml version="1.0" encoding="UTF-8"?>
<ssm:ParameterMapping version="1.0" xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">
  <ssm:MappingEntry source="inertia_g_m2" target="plant.J">
    <ssc:LinearTransformation factor="0.001" offset="0"/>
  </ssm:MappingEntry>
</ssm:ParameterMapping>
"""

#: what the SSP's parameter sets and mapping amount to
SSP_PARAMETERS = {"motor.k": 0.8, "plant.J": 20 * 0.001 + 0.0, "plant.d": 0.002, "plant.w_0": 60 * RPM}


#: a load table as a third component of the SSP (`write_ssp`'s ``table``)
TABLE_COMPONENT = """      <ssd:Component name="load" type="text/csv" source="resources/load.csv"/>
    </ssd:Elements>"""
TABLE_CONNECTION = """      <ssd:Connection startElement="load" startConnector="torque" endElement="plant" endConnector="tau_load"/>
    </ssd:Connections>"""


def write_ssp(target: Path, motor: Path, inertia: Path, table: str | None = None) -> Path:
    """An SSP archive of the system: SystemStructure.ssd, the two FMUs, a parameter set and its
    mapping; with ``table`` (a CSV's text), a table component driving the shaft's load too."""
    ssd = SSD
    if table is not None:
        ssd = ssd.replace("    </ssd:Elements>", TABLE_COMPONENT).replace("    </ssd:Connections>", TABLE_CONNECTION)
    with zipfile.ZipFile(target, "w") as archive:
        archive.writestr("SystemStructure.ssd", ssd)
        if table is not None:
            archive.writestr("resources/load.csv", table)
        archive.write(motor, "resources/motor.fmu")
        archive.write(inertia, "resources/plant.fmu")
        archive.writestr("resources/drive.ssv", SSV)
        archive.writestr("resources/drive.ssm", SSM)
    return target
