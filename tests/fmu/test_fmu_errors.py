"""Bad FMU files and unsupported requests fail early with a clear error, before any FMI call."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from fmu_family import rewrite
from lxml import etree

from modelicagym import FMUEnv
from modelicagym.fmu import (
    FMUError,
    FMUInstance,
    FMUNotFoundError,
    InvalidFMUError,
    PlatformNotSupportedError,
    UnsupportedFeatureError,
    open_fmu,
)


def test_missing_file(tmp_path):
    missing = tmp_path / "nowhere" / "Model.fmu"
    with pytest.raises(FMUNotFoundError, match="FMU not found: .*nowhere/Model.fmu"):
        open_fmu(missing)
    with pytest.raises(FileNotFoundError):  # also the builtin kind
        FMUEnv(fmu=missing, inputs=["u"], outputs=["y"])


def test_not_a_zip(tmp_path):
    path = tmp_path / "Model.fmu"
    path.write_text("this is not an FMU")
    with pytest.raises(InvalidFMUError, match="is not an FMU: an FMU is a zip archive"):
        open_fmu(path)


def test_zip_without_model_description(tmp_path, family_fmu):
    path = rewrite(family_fmu("probe", 2), tmp_path / "Probe.fmu", rename=lambda n: None if n == "modelDescription.xml" else n)
    with pytest.raises(InvalidFMUError, match="no modelDescription.xml"):
        open_fmu(path)
    folder = tmp_path / "folder"
    folder.mkdir()
    with pytest.raises(InvalidFMUError, match="no modelDescription.xml"):
        open_fmu(folder)


def test_unreadable_model_description(tmp_path, family_fmu):
    path = rewrite(family_fmu("probe", 2), tmp_path / "Probe.fmu", edit_description=lambda t: t.replace("</ModelVariables>", ""))
    with pytest.raises(InvalidFMUError, match="cannot read modelDescription.xml"):
        open_fmu(path)


def test_schema_validation_can_be_skipped(tmp_path, family_fmu):
    path = rewrite(family_fmu("probe", 2), tmp_path / "Probe.fmu",
                   edit_description=lambda t: t.replace('modelName="Probe"', 'modelName="Probe" madeUpAttribute="1"'))
    with pytest.raises(InvalidFMUError, match="pass validate=False"):
        open_fmu(path)
    env = FMUEnv(fmu=path, inputs=["force"], outputs=["position"], validate=False)
    env.reset()
    observation, *_ = env.step(np.array([2.0]))
    assert observation[0] == pytest.approx(0.2, abs=1e-12)
    env.close()


def test_no_binary_for_this_platform(tmp_path, family_fmu, fmi_version):
    source = family_fmu("probe", fmi_version)
    here = open_fmu(source).platform_dir
    others = ("darwin64", "win64") if fmi_version == 2 else ("aarch64-darwin", "x86_64-windows")

    no_binaries = rewrite(source, tmp_path / "none.fmu", rename=lambda n: None if n.startswith("binaries/") else n)
    assert open_fmu(no_binaries).platforms == ()
    with pytest.raises(PlatformNotSupportedError) as raised:
        FMUEnv(fmu=no_binaries, inputs=["force"], outputs=["position"])
    message = str(raised.value)
    assert f"no binary for this platform ({here})" in message
    assert "It has binaries for: no platform" in message
    assert "modelicagym build" in message  # the FMU has sources: say how to build one

    moved = tmp_path / "elsewhere.fmu"
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(moved, "w") as new:
        for item in old.infolist():
            data = old.read(item)
            if item.filename.startswith(f"binaries/{here}/"):
                for platform in others:
                    new.writestr(item.filename.replace(here, platform, 1), data)
            else:
                new.writestr(item.filename, data)
    assert open_fmu(moved).platforms == tuple(sorted(others))
    with pytest.raises(PlatformNotSupportedError, match=f"It has binaries for: {', '.join(sorted(others))}"):
        FMUInstance(moved)


def test_interface_type_the_fmu_lacks(tmp_path, family_fmu):
    def drop_model_exchange(text: str) -> str:
        root = etree.fromstring(text.encode())
        root.remove(root.find("ModelExchange"))
        return etree.tostring(root, encoding="unicode")

    path = rewrite(family_fmu("probe", 2), tmp_path / "ProbeCS.fmu", edit_description=drop_model_exchange)
    assert open_fmu(path).modes == ("cs",)
    with pytest.raises(UnsupportedFeatureError, match=r"does not support model exchange \(mode='me'\); it supports: co-simulation \('cs'\)"):
        FMUEnv(fmu=path, inputs=["force"], outputs=["position"], mode="me")
    env = FMUEnv(fmu=path, inputs=["force"], outputs=["position"])  # co-simulation by default
    assert env.fmu.mode == "cs"
    env.close()


def test_an_extracted_folder_is_an_fmu_too(tmp_path, family_fmu):
    folder = tmp_path / "probe"
    with zipfile.ZipFile(family_fmu("probe", 3)) as archive:
        archive.extractall(folder)
    env = FMUEnv(fmu=folder, inputs=["u"], outputs=["y"])
    env.reset()
    observation, *_ = env.step(np.array([0.5, 0.0, -0.5]))
    np.testing.assert_allclose(observation, [[0.0, 0.0, 0.0], [0.6, 0.1, -0.4]], atol=1e-15)
    env.close()


def test_instantiation_refused_by_the_fmu_shows_its_reason(tmp_path, family_fmu, fmi_version):
    """A model description edited without rebuilding the binary: the FMU rejects the guid /
    instantiation token, and the error carries the FMU's own message."""
    token = "guid" if fmi_version == 2 else "instantiationToken"

    def new_token(text: str) -> str:
        root = etree.fromstring(text.encode())
        root.set(token, "{00000000-0000-0000-0000-000000000000}")
        return etree.tostring(root, encoding="unicode")

    path = rewrite(family_fmu("probe", fmi_version), tmp_path / "Probe.fmu", edit_description=new_token)
    with pytest.raises(FMUError, match=r"Instantiate failed: \[Error\] instantiation token .*00000000.* does not match"):
        FMUEnv(fmu=path, inputs=["force"], outputs=["position"])


def test_fmi_functions_need_declared_signatures() -> None:
    """The binding reads fmpy's declared C signatures; an undeclared or missing one is an error."""
    import ctypes

    from modelicagym.fmu.binding import FunctionTable

    table = FunctionTable(ctypes.CDLL(None), "Probe")
    with pytest.raises(FMUError, match="declared no signature for strlen"):
        table["strlen"]
    with pytest.raises(FMUError, match="does not export fmi2NoSuchFunction"):
        table["fmi2NoSuchFunction"]


@pytest.mark.parametrize(
    "variable, edit",
    [
        ("mode_out", lambda text: text.replace(
            'name="mode_out" valueReference="14" causality="output" variability="discrete"',
            'name="mode_out" valueReference="14" causality="output" variability="continuous"')),
        ("moving", lambda text: text.replace(
            '<ScalarVariable name="moving" valueReference="15"', '<ScalarVariable name="moving" valueReference="15" bogus="1"')),
    ],
    ids=["enumeration-declared-continuous", "unknown-attribute"],
)
def test_rules_broken_on_unused_variables_load_with_a_warning(tmp_path, family_fmu, caplog, variable, edit):
    path = rewrite(family_fmu("probe", 2), tmp_path / "Probe.fmu", edit_description=edit)
    with caplog.at_level("WARNING"):
        env = FMUEnv(fmu=path, inputs=["force"], outputs=["position"])
    assert f"only for variables this env does not use ({variable})" in caplog.text
    env.reset(seed=0)
    env.step(np.array([1.0]))
    with pytest.raises(InvalidFMUError, match=f"fails validation \\(variables concerned: {variable}\\)"):
        FMUEnv(fmu=path, inputs=["force"], outputs=["position", variable])
    with pytest.raises(InvalidFMUError, match="pass validate=False"):
        open_fmu(path)  # nothing said about what is used: refused as before
