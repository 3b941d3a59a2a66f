"""One vocabulary (issue 10): every copy of the friction element's parameter table agrees with
``vibrofriction.vocabulary.FRICTION_TERMS`` -- names, MJCF keys, C++ fields and defaults."""
from __future__ import annotations

import ctypes
import dataclasses
import re
from pathlib import Path

import pytest

from vibrofriction import rig
from vibrofriction._native import _LawParameters
from vibrofriction.params import LAWS, LIMITS, FrictionParameters
from vibrofriction.vocabulary import ALL_LAWS, FRICTION_TERMS, LAW_STRUCT_FIELDS

ROOT = Path(__file__).resolve().parents[1]
CPP = ROOT / "plugin" / "cpp"


def _cpp(name: str) -> str:
    if not (ROOT / "pyproject.toml").is_file():
        pytest.skip(f"not a source checkout ({ROOT}): the C++ sources are not here")
    return (CPP / name).read_text()  # (in a checkout a missing file is a failure)


def _number(text: str) -> float:
    return float(text.rstrip("f"))


def test_friction_parameters_are_the_table() -> None:
    fields = {f.name: f.default for f in dataclasses.fields(FrictionParameters) if f.name != "law"}
    assert fields == {term.name: term.default for term in FRICTION_TERMS}
    assert rig.MJCF_KEYS == {term.name: term.mjcf_key for term in FRICTION_TERMS}
    for term in FRICTION_TERMS:
        assert LIMITS.get(term.name) == term.limits, term.name


def test_the_cpp_law_parameters_have_the_tables_defaults() -> None:
    header = _cpp("friction_law.h")
    struct = re.search(r"struct LawParameters \{(.*?)\};", header, re.S).group(1)
    struct = re.sub(r"//[^\n]*", "", struct)
    declared = re.findall(r"\b(\w+) (\w+) = ([^;]+);", struct)
    assert declared[0][:2] == ("Law", "law")
    defaults = {name: _number(value) for kind, name, value in declared[1:]
                if kind == "double"}
    assert len(defaults) == len(declared) - 1  # every field but the law is a double
    fields = {term.law_field: term for term in FRICTION_TERMS if term.law_field}
    assert set(defaults) == set(fields) | {"normal_force"}
    for field, term in fields.items():
        assert defaults[field] == pytest.approx(term.default, rel=1e-12), term.name
    enum = re.search(r"enum class Law : int \{(.*?)\};", header).group(1)
    values = {name.lower(): int(value) for name, value in re.findall(r"k(\w+) = (\d+)", enum)}
    assert values == {law: index for index, law in enumerate(ALL_LAWS)}
    assert LAWS == ALL_LAWS


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
    declared = [(kind, name.strip()) for kind, names in
                re.findall(r"\b(int|double)\s+([^;]+);", struct) for name in names.split(",")]
    assert len(declared) == struct.count(",") + struct.count(";")  # nothing else declared
    assert declared == [("int", "law"), *(("double", f) for f in LAW_STRUCT_FIELDS)]
    kinds = {ctypes.c_int: "int", ctypes.c_double: "double"}
    assert [(kinds[t], n) for n, t in _LawParameters._fields_] == declared
    assert set(LAW_STRUCT_FIELDS) == {t.law_field for t in FRICTION_TERMS if t.law_field} | \
        {"normal_force"}


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
