"""What OMSimulator's test scripts say of the systems of its test suite (``testsuite/tests/resources``):
the values they print, how each script runs its system, and the defects they refuse a system for.

The Python scripts are those at OMSimulator's head (``tests/...``); the Lua ones were removed in
March 2025 and are quoted from the commit before (``lua: ...``). A value is named as modelicagym
names it: OMSimulator's ``model.root.addP.k1`` (or ``CRef('root', 'addP', 'k1')``) is ``addP.k1``.
Only the values a script prints after initialization (``start``) or after its run (``end``) are
here: those it prints before (after ``instantiate``, or of the model being edited) describe
OMSimulator's editing API, which has no counterpart in a run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

#: the commit of OMSimulator's repository whose Lua scripts are quoted (the parent of 3420839f,
#: "Replace python api with version 3.x", which removed them)
LUA_COMMIT = "3420839f^"
#: OMSimulator's default communication step, where a script sets none
DEFAULT_STEP = 1e-3


@dataclass(frozen=True)
class Script:
    """One of OMSimulator's test scripts, run on ``system`` (a folder of ``tests/resources``) as
    modelicagym runs it: to ``stop_time`` (None: the system's default experiment's) at ``time_step``,
    with what the script sets that holds through initialization (``inputs`` held, ``parameters``)
    and the script's own edits of ``SystemStructure.ssd`` (``edits``: text replaced, in a copy)."""

    script: str
    system: str
    start: dict[str, float] = field(default_factory=dict)
    end: dict[str, float] = field(default_factory=dict)
    stop_time: float | None = None
    time_step: float = DEFAULT_STEP
    inputs: dict[str, Any] = field(default_factory=dict)
    parameters: dict[str, Any] = field(default_factory=dict)
    edits: tuple[tuple[str, str], ...] = ()
    #: the system's inputs the script sets itself: the values it prints of them are its own, not the SSP's
    own: tuple[str, ...] = ()

    @property
    def stated(self) -> int:
        return len(self.start) + len(self.end)


#: import_export_parameters{1,2,3}.lua after initialization and after the run: the script sets
#: Input_cref to -3.7 and Input1 to -1000 (its other settings, of connected variables, the connections override)
_IMPORT_EXPORT = {"addP.k1": 30.0, "addP.k2": -1.0, "addP.u1": -3.7, "addP.y": -111.0, "addI.k2": 20.0,
                  "addI.k3": 1.0, "Input_cref": -3.7, "Input1": -1000.0, "T_cref": 20.0, "k_cref": 30.0,
                  "Output_cref": -111.0}
#: import_parameter_mapping_from_ssm.lua and _inline.lua, after initialization and after the run:
#: the values of the system's connectors (parameter_2 of System1 and System2 bound by no set: 0.0)
_MAPPING = {"Input_1": 20.0, "Input_2": 20.0, "Input_3": 50.0, "parameter_1": -30.0, "parameter_2": -40.0,
            "System1.Input_1": 20.0, "System1.Input_2": 20.0, "System1.parameter_1": -30.0,
            "System1.parameter_2": 0.0, "System2.Input_1": 20.0, "System2.Input_2": 20.0,
            "System2.parameter_1": -30.0, "System2.parameter_2": 0.0}
_MAPPING_INLINE = {**{name: value for name, value in _MAPPING.items() if "." not in name},
                   "System1.Input_1": -100.0, "System1.Input_2": -100.0, "System1.parameter_1": -50.0,
                   "System1.parameter_2": -50.0, "System2.Input_1": 70.0, "System2.Input_2": 70.0,
                   "System2.parameter_1": 70.0, "System2.parameter_2": 70.0}
#: referenceResources2.lua, once it has bound the external set and mapping in place of the system's own
_EXTERNAL = {"Input_1": -200.0, "Input_2": -200.0, "Input_3": -300.0, "parameter_1": -400.0, "parameter_2": -500.0,
             "System1.Input_1": -200.0, "System1.Input_2": -200.0, "System1.parameter_1": -400.0,
             "System1.parameter_2": 0.0, "System2.Input_1": -200.0, "System2.Input_2": -200.0,
             "System2.parameter_1": -400.0, "System2.parameter_2": 0.0}
_HIERARCHICAL = {"System1.Input_1": -10.0, "System1.parameter_1": -20.0, "System2.Input_1": -30.0,
                 "System2.Input_2": -100.0, "System2.parameter_1": -40.0, "System3.Input_1": -70.0,
                 "System3.parameter_1": -70.0}
#: embrace1.py and embrace2.py set these before they initialize
_EMBRACE_SETTINGS = {"ECS_HW.eCS.MaxCoolPower.k": 5.0, "ECS_HW.coolinPackAir.looptype": 2,
                     "ECS_HW.phSrc.looptype": 2, "ECS_HW.pipeB.looptype": 2, "ECS_HW.pipeA.looptype": 2}

SCRIPTS = (
    Script("tests/simulation/LinearTransformation1.py", "LinearTransformation",
           end={"Gain1.y": 0.0, "Add1.u1": 3.0}),
    Script("tests/simulation/LinearTransformation2.py", "LinearTransformation",
           end={"Gain1.y": 0.0, "Add1.u1": 3.0}),
    Script("tests/simulation/LinearTransformation3.py", "LinearTransformation3",
           end={"Gain1.k": 13.0, "Gain1.u": 14.0, "Gain1.y": 182.0, "Add1.u1": 182.0}),
    Script("lua: testsuite/simulation/toplevelparameter1.lua", "toplevelparameter1",
           end={"addP.k1": -200.0, "addP.k2": -300.0, "Input_cref": -20.0}),
    Script("lua: testsuite/simulation/toplevelparameter2.lua", "toplevelparameter2",
           end={"addP.k1": -200.0, "addP.k2": -400.0, "Input_cref": -20.0}),
    # the script sets foo.F_cref to -55 too, which holds in 2 alone (1 and 3 print the set's 40)
    *(Script(f"lua: testsuite/simulation/import_export_parameters{k}.lua", f"import_export_parameters{k}",
             start=values, end=values, inputs={"Input_cref": -3.7}, own=("Input_cref", "Input1", "foo.F_cref")[:own])
      for k, values, own in ((1, {**_IMPORT_EXPORT, "foo.F_cref": 40.0}, 2),
                             (2, {**_IMPORT_EXPORT, "foo.F_cref": -55.0}, 3),
                             (3, {**_IMPORT_EXPORT, "foo.F_cref": 40.0}, 2))),
    Script("lua: testsuite/simulation/import_parameter_mapping_from_ssm.lua", "importParameterMapping",
           start=_MAPPING, end=_MAPPING),
    Script("lua: testsuite/simulation/import_parameter_mapping_inline.lua", "importParameterMappingInline",
           start=_MAPPING_INLINE, end=_MAPPING_INLINE),
    Script("lua: testsuite/simulation/referenceResources2.lua", "importExportAllResources", start=_EXTERNAL,
           end=_EXTERNAL,
           edits=(('"resources/import_parameter_mapping.ss', '"resources/external_import_parameter_mapping.ss'),)),
    *(Script(f"lua: testsuite/simulation/{name}.lua", "import_hierarchical_ssv_sources", start=_HIERARCHICAL,
             end=_HIERARCHICAL) for name in ("import_hierarchical_ssv_sources", "import_hierarchical_ssv_sources1")),
    Script("tests/AircraftVehicleDemonstrator/embrace1.py", "embrace", parameters=_EMBRACE_SETTINGS,
           start={"ECS_HW.coolinPackAir.looptype": 2, "ECS_HW.eCS.MaxCoolPower.k": 5.0, "ECS_HW.pipeC.L": 1.0,
                  "ECS_HW.pipeB.L": 0.976535328081166, "ECS_HW.pipeA.L": 0.976535328081166}),
    Script("tests/AircraftVehicleDemonstrator/embrace2.py", "embrace_TwoConf", parameters=_EMBRACE_SETTINGS,
           edits=(('source="resources/ECS_Conf2.ssv"', 'source="resources/ECS_Conf1.ssv"'),),
           start={"ECS_HW.coolinPackAir.looptype": 2, "ECS_HW.eCS.MaxCoolPower.k": 5.0, "ECS_HW.pipeC.L": 1.0,
                  "ECS_HW.pipeB.L": 7.41248272578546, "ECS_HW.pipeA.L": 7.39290438403619}),
)

#: the systems no script prints a value of, run as a script runs them: system -> (script, stop time, step)
RUNS = {
    "acvs_compositeModel": ("tests/AircraftVehicleDemonstrator/acvs_simulate.py", 1.0, 0.01),
    "dcmotor": ("tests/dcmotor/dcmotor.py", 10.0, DEFAULT_STEP),
}

#: the systems OMSimulator refuses, and the defect it names: system -> (script, the file, line,
#: element and attribute, as a pattern of modelicagym's message)
REFUSALS = {
    "invalidSSD": ("tests/api/invalidSSD.py",
                   r"SystemStructure\.ssd, line 16: Connector 'C1': unknown attribute 'type'"),
    "invalidSSV": ("tests/api/invalidSSV.py",
                   r"resources/System1\.ssv, line 4: Parameter 'System1\.C2': unknown attribute 'type'"),
    # no script at the head runs it; it is importParameterMapping with one entry's 'target' spelled 'destination'
    "invalidSSM": ("(none: importParameterMapping with an entry's target spelled 'destination')",
                   r"resources/import_parameter_mapping\.ssm, line 12: MappingEntry: unknown attribute 'destination'"),
}
