"""SSP systems (modelicagym/system/ssp.py): an archive written here (SystemStructure.ssd, the FMUs
under resources/, a parameter set with a mapping, a component's inline parameter set) runs as the
same system given as a config with those parameter values; an unpacked folder too."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from system_cases import OUTPUTS, SSP_PARAMETERS, system_config, write_ssp

from modelicagym import FMUEnv
from modelicagym.fmu.errors import InvalidFMUError
from modelicagym.system import open_system

ACTIONS = np.linspace(-1.0, 1.0, 40)


@pytest.fixture
def ssp(family_fmu, tmp_path):
    return write_ssp(tmp_path / "drive.ssp", family_fmu("motor", 2), family_fmu("inertia", 3))


def trajectory(env: FMUEnv) -> np.ndarray:
    rows = [env.reset(seed=0)[0]]
    rows += [env.step(np.array([a]))[0] for a in ACTIONS]
    env.close()
    return np.array(rows)


def test_an_ssp_archive_runs_with_its_parameter_sets(ssp, family_fmu):
    system = open_system(ssp)
    assert system.model_name == "drive" and list(system.components) == ["motor", "plant"]
    assert system.parameter_values == SSP_PARAMETERS
    assert system.components["motor"].mode == "cs"
    from_ssp = trajectory(FMUEnv(fmu=ssp, inputs=["motor.u"], outputs=OUTPUTS, time_step=0.01))
    config = system_config(family_fmu("motor", 2), family_fmu("inertia", 3), parameters=SSP_PARAMETERS)
    np.testing.assert_array_equal(from_ssp, trajectory(FMUEnv(config)))
    plain = trajectory(FMUEnv(system_config(family_fmu("motor", 2), family_fmu("inertia", 3))))
    assert not np.array_equal(from_ssp, plain)  # the parameter sets changed something


def test_the_configs_parameters_override_the_ssps(ssp):
    env = FMUEnv(fmu=ssp, inputs=["motor.u"], outputs=OUTPUTS, time_step=0.01, parameters={"plant.J": 0.5})
    env.reset(seed=0)
    assert env.fmu.get_values(["plant.J", "plant.d"]) == {"plant.J": 0.5, "plant.d": 0.002}
    env.close()


def test_an_unpacked_ssp_folder_is_a_system(ssp, tmp_path):
    folder = tmp_path / "drive"
    with zipfile.ZipFile(ssp) as archive:
        archive.extractall(folder)
    assert open_system(folder).parameter_values == SSP_PARAMETERS
    env = FMUEnv(fmu=folder, inputs=["motor.u"], outputs=OUTPUTS, time_step=0.01)
    assert env.description.name == "drive"
    env.close()


def test_an_archive_without_a_system_structure_is_refused(tmp_path):
    bogus = tmp_path / "bogus.ssp"
    with zipfile.ZipFile(bogus, "w") as archive:
        archive.writestr("readme.txt", "no system here")
    with pytest.raises(InvalidFMUError, match="bogus.ssp is not an SSP archive: the zip archive has no SystemStructure.ssd"):
        open_system(bogus)


def test_an_ssp_table_component_drives_an_input(family_fmu, tmp_path):
    ssp = write_ssp(tmp_path / "loaded.ssp", family_fmu("motor", 2), family_fmu("inertia", 3),
                    table="time,torque\n0,0\n1,-0.1\n")
    system = open_system(ssp)
    assert system.order == ["load", "motor", "plant"] and system.components["load"].kind == "table"
    env = FMUEnv(fmu=ssp, inputs=["motor.u"], outputs=["load.torque", "plant.tau"], time_step=0.01)
    assert [v.name for v in env.description.inputs] == ["motor.u"]
    env.reset(seed=0)
    for _ in range(10):
        torque = env.step(np.array([0.0]))[0][0]
    assert torque == pytest.approx(-0.01, rel=1e-12)
    env.close()


def test_a_system_parameter_goes_to_what_its_connector_feeds(ssp, tmp_path):
    folder = tmp_path / "drive"
    with zipfile.ZipFile(ssp) as archive:
        archive.extractall(folder)
    ssd = (folder / "SystemStructure.ssd").read_text()
    ssd = ssd.replace('''  <ssd:System name="drive">''', '''  <ssd:System name="drive">
    <ssd:Connectors><ssd:Connector name="lag" kind="parameter"><ssc:Real unit="ms"/></ssd:Connector></ssd:Connectors>''')
    ssd = ssd.replace('''      <ssd:ParameterBinding source="resources/drive.ssv">''', '''      <ssd:ParameterBinding>
        <ssd:ParameterValues>
          <ssv:ParameterSet version="1.0" name="system" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">
            <ssv:Parameters><ssv:Parameter name="lag"><ssv:Real value="80"/></ssv:Parameter></ssv:Parameters>
          </ssv:ParameterSet>
        </ssd:ParameterValues>
      </ssd:ParameterBinding>
      <ssd:ParameterBinding source="resources/drive.ssv">''')
    ssd = ssd.replace('''    </ssd:Connections>''', '''      <ssd:Connection startConnector="lag" endElement="motor" endConnector="T_m">
        <ssc:LinearTransformation factor="0.001"/>
      </ssd:Connection>
    </ssd:Connections>''')
    (folder / "SystemStructure.ssd").write_text(ssd)
    system = open_system(folder)
    assert system.parameter_values == {**SSP_PARAMETERS, "motor.T_m": 80 * 0.001 + 0.0}
    assert [link.label for link in system.links] == ["motor.tau -> plant.tau", "plant.w -> motor.w"]
