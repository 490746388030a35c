"""Lenient, honest loading: what urdfdom, Gazebo and PyBullet load, the harness loads, saying
what it changed; ``strict=True`` refuses the same files with one line naming the defect."""

from __future__ import annotations

import warnings

import pytest

from harness.errors import HarnessError
from harness.models import load_robot
from harness.models.errors import ModelStructureError, ModelWarning, XMLError

from .conftest import DATA

LENIENT = DATA / "lenient"


def _load(path, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loaded = load_robot(path, **options)
    return loaded, [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]


def test_wrong_xml_declaration_is_read_as_xml_1_0():
    loaded, messages = _load(LENIENT / "bad_declaration.urdf")
    assert loaded.actuated == ("j1",)
    assert any('version="0.0"; read as XML 1.0' in m for m in messages)
    assert any("XML 1.0" in n for n in loaded.notes)
    with pytest.raises(XMLError, match=r"bad_declaration\.urdf:1: malformed XML"):
        load_robot(LENIENT / "bad_declaration.urdf", strict=True)


def test_trailing_content_equal_limits_unknown_mimic_and_bad_inertia_are_recovered():
    path = LENIENT / "trailing_content.urdf"
    loaded, messages = _load(path)
    text = "\n".join(messages)
    assert "content after the root element </robot> (line 28) ignored" in text
    assert '<joint name="locked">: lower and upper limits are both 0: read as a fixed' in text
    assert "mimics unknown joint 'no_such_joint': <mimic> ignored" in text
    assert "repaired mass/inertia of" in text
    assert "pad: inertia" in text
    # the locked joint is fixed, the orphan mimic moves on its own
    assert loaded.description.joint("locked").type == "fixed"
    assert loaded.actuated == ("j1", "finger")
    assert [r for r in loaded.repairs if r.startswith("pad:")] == [
        "pad: inertia [0.0001, 0.0001, 0.0005] -> [0.000233333, 0.000233333, 0.000233333] "
        "(balanceinertia)"
    ]


def test_strict_refuses_each_defect_with_one_line(tmp_path):
    source = (LENIENT / "trailing_content.urdf").read_text()
    with pytest.raises(XMLError, match="Extra content at the end of the document"):
        load_robot(LENIENT / "trailing_content.urdf", strict=True)
    clean = source[: source.index("</robot>") + len("</robot>")]
    path = tmp_path / "clean.urdf"
    path.write_text(clean)
    with pytest.raises(ModelStructureError, match=r'<joint name="locked">: lower and upper'):
        load_robot(path, strict=True)
    path.write_text(clean.replace('upper="0" effort="10"', 'upper="0.5" effort="10"'))
    with pytest.raises(ModelStructureError, match="mimics unknown joint 'no_such_joint'"):
        load_robot(path, strict=True)
    path.write_text(
        clean.replace('upper="0" effort="10"', 'upper="0.5" effort="10"').replace(
            '<mimic joint="no_such_joint"/>', ""
        )
    )
    with pytest.raises(HarnessError, match=r'<link name="pad">: inertia violates the triangle'):
        load_robot(path, strict=True)
    assert load_robot(path).repairs  # the same file loads by default


def test_unexpanded_xacro_is_an_error_saying_so():
    with pytest.raises(ModelStructureError) as info:
        load_robot(LENIENT / "unexpanded_xacro.urdf")
    message = str(info.value)
    assert "unexpanded_xacro.urdf" in message
    assert "'${width}'" in message
    assert "expand the file first" in message
    assert "\n" not in message


def test_sdf_zero_mass_on_a_static_model_is_accepted():
    loaded, _ = _load(LENIENT / "zero_mass_static.sdf")
    assert loaded.model.body("base").id > 0
    assert loaded.base == "fixed"
