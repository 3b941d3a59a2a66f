"""One vocabulary (issue 10): every copy of the friction element's parameter table agrees with
``vibrofriction.vocabulary.FRICTION_TERMS`` -- names, MJCF keys, C++ fields and defaults."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from vibrofriction import rig
from vibrofriction._native import _LawParameters
from vibrofriction.params import LIMITS, FrictionParameters
from vibrofriction.vocabulary import FRICTION_TERMS, LAW_STRUCT_FIELDS

ROOT = Path(__file__).resolve().parents[1]
CPP = ROOT / "plugin" / "cpp"


def _cpp(name: str) -> str:
    path = CPP / name
    if not path.is_file():
        pytest.skip(f"C++ sources not found at {CPP} (an installed package without them)")
    return path.read_text()


def _number(text: str) -> float:
    return float(text.rstrip("f"))


def test_friction_parameters_are_the_table() -> None:
    fields = {f.name: f.default for f in dataclasses.fields(FrictionParameters) if f.name != "law"}
    assert fields == {term.name: term.default for term in FRICTION_TERMS}
    assert rig.MJCF_KEYS == {term.name: term.mjcf_key for term in FRICTION_TERMS}
    for term in FRICTION_TERMS:
        assert LIMITS.get(term.name) == term.limits, term.name


def test_the_cpp_law_parameters_have_the_tables_defaults() -> None:
    struct = re.search(r"struct LawParameters \{(.*?)\};", _cpp("friction_law.h"), re.S).group(1)
    defaults = {name: _number(value) for name, value in
                re.findall(r"double (\w+) = ([-+0-9.eE]+);", struct)}
    for term in FRICTION_TERMS:
        if term.law_field:
            assert defaults[term.law_field] == pytest.approx(term.default, rel=1e-12), term.name


def test_the_config_readers_read_each_key_into_its_field_with_the_tables_default() -> None:
    """element_config.cc and friction_element.cc read {kKey, &field, default}; the keys'
    strings are the constants of element_config.h and friction_element.cc."""
    sources = _cpp("element_config.h") + _cpp("element_config.cc") + _cpp("friction_element.cc")
    constants = dict(re.findall(r'constexpr char (k\w+)\[\] = "(\w+)";', sources))
    read = {constants[key]: (field, _number(value)) for key, field, value in re.findall(
        r"\{(k\w+), &\w+\.(\w+), ([-+0-9.eE]+)\}", sources)}
    for term in FRICTION_TERMS:
        assert term.mjcf_key in read, f"{term.mjcf_key} is not read by the friction element"
        field, default = read[term.mjcf_key]
        assert default == pytest.approx(term.default, rel=1e-12), term.name
        if term.law_field:
            assert field == term.law_field, term.name
    attributes = re.search(r"kAttributes\[\] = \{(.*?)\};", _cpp("friction_element.cc"),
                           re.S).group(1)
    listed = {constants[k] for k in re.findall(r"k\w+", attributes)}
    assert {term.mjcf_key for term in FRICTION_TERMS} <= listed


def test_the_c_api_struct_and_the_ctypes_layout_are_the_tables() -> None:
    struct = re.search(r"typedef struct vf_law_parameters \{(.*?)\}", _cpp("c_api.h"),
                       re.S).group(1)
    struct = re.sub(r"//[^\n]*", "", struct)
    doubles = re.search(r"double (.*?);", struct, re.S).group(1)
    fields = [name.strip() for name in doubles.split(",")]
    assert tuple(fields) == LAW_STRUCT_FIELDS
    assert [name for name, _ in _LawParameters._fields_] == ["law", *LAW_STRUCT_FIELDS]


def test_the_docs_parameter_table_names_each_key_and_default() -> None:
    rows = {}
    for line in (ROOT / "docs" / "simulation.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 5 and cells[0].startswith("`") and cells[1].startswith("`"):
            rows[cells[0].strip("`")] = cells
    for term in FRICTION_TERMS:
        cells = rows[term.name]
        assert cells[1] == f"`{term.mjcf_key}`", term.name
        documented = re.match(r"[-+0-9.e]+", cells[4])
        assert documented and float(documented.group(0)) == pytest.approx(term.default), \
            term.name
