"""`edited_description`: a model folder's description with capabilities changed (what each edit
declares is checked on every variant of the test family, ``test_fmu_family.test_declared_capabilities``)."""

from __future__ import annotations

import pytest
from fmu_family import BALL_DIR, FMUS_DIR

from modelicagym.errors import ArgumentError
from modelicagym.fmu.description_edits import edited_description

MOODY_DESCRIPTION = FMUS_DIR / "moody" / "modelDescription_fmi2.xml"


def test_an_edit_is_written_once_by_content_and_leaves_the_model_folder_alone(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("MODELICAGYM_CACHE", str(tmp_path))
    before = MOODY_DESCRIPTION.read_bytes()
    once = edited_description(MOODY_DESCRIPTION, once_per_process=True)
    assert edited_description(MOODY_DESCRIPTION, once_per_process=True) == once
    assert edited_description(MOODY_DESCRIPTION, snapshots=False) != once
    assert once.parent == tmp_path / "descriptions" and 'canBeInstantiatedOnlyOncePerProcess="true"' in once.read_text()
    assert MOODY_DESCRIPTION.read_bytes() == before
    assert sorted(p.name for p in once.parent.iterdir()) == sorted(  # no temporary file left
        {once.name, edited_description(MOODY_DESCRIPTION, snapshots=False).name})


def test_an_fmi1_description_is_refused_in_one_line() -> None:
    path = BALL_DIR / "modelDescription_fmi1_me.xml"
    with pytest.raises(ArgumentError, match=r"^\S*modelDescription_fmi1_me.xml: only FMI 2.0 and 3.0 model "
                                            r"descriptions can be edited, not fmiVersion '1.0'$"):
        edited_description(path, once_per_process=True)
