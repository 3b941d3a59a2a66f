"""One vocabulary (issue 10): every copy of the friction element's parameter table agrees with
``vibrofriction.vocabulary.FRICTION_TERMS`` -- names, MJCF keys, C++ fields and defaults, the
keys each element takes, and the docs' units and laws."""
from __future__ import annotations

import ctypes
import dataclasses
import fnmatch
import re
from pathlib import Path

import pytest

from vibrofriction.laws._native import _LawParameters
from vibrofriction.params import LAWS, LIMITS, FrictionParameters
from vibrofriction.rigs import planar, rig
from vibrofriction.robots import averaged
from vibrofriction.vocabulary import (ALL_ELEMENTS, ALL_LAWS, FRICTION_TERMS, LAW_STRUCT_FIELDS,
                                      MAX_GMS_ELEMENTS, MAX_MAP_KNOTS, PAPER_LAWS, TERMS_BY_NAME, element_keys)

ROOT = Path(__file__).resolve().parents[1]
CPP = ROOT / "plugin" / "cpp"

# Each element's source and its keys that are no friction term: written out here, so that a
# friction key the C++ adds or drops and the table does not is a failure, not an own key.
ELEMENT_SOURCES = {"friction": "plugins/friction_element.cc",
                   "planar": "plugins/planar_friction.cc",
                   "contact": "plugins/contact_friction.cc",
                   "averaged": "plugins/averaged_friction.cc",
                   "contact_averaged": "plugins/contact_friction.cc",
                   "contact_feeder": "plugins/contact_friction.cc"}
# The name of each element's attribute array in its source (two plugins share contact's).
ATTRIBUTE_ARRAYS = {"contact_averaged": "kAveragedAttributes",
                    "contact_feeder": "kFeederAttributes"}
NORMAL_LOAD_KEYS = {"normal", "normal_sensor", "normal_gain", "normal_component",
                    "contact_geom1", "contact_geom2"}
OWN_KEYS = {
    "friction": {"law", "normal_from_ctrl", *NORMAL_LOAD_KEYS},
    "planar": {"law", *NORMAL_LOAD_KEYS},
    "contact": {"law", "support", "support_geom", "torsion_radius"},  # the load: MuJoCo's contacts
    "averaged": {*NORMAL_LOAD_KEYS, "velocity_amplitude", "axis_angle", "use_ctrl", "table_xi",
                 "table_angle", "table_along", "table_across", "table_checksum"},
    "contact_averaged": {"support", "support_geom", "torsion_radius", "velocity_amplitude", "axis",
                         "table_xi", "table_angle", "table_along", "table_across",
                         "table_checksum"},
    "contact_feeder": {"support", "support_geom", "torsion_radius", "axis", "helix_pitch",
                       "map_velocity", "map_force"},
}
TABLE_KEYS = {term.mjcf_key for term in FRICTION_TERMS}


def _cpp(name: str) -> str:
    if not (ROOT / "pyproject.toml").is_file():
        pytest.skip(f"not a source checkout ({ROOT}): the C++ sources are not here")
    return (CPP / name).read_text()  # (in a checkout a missing file is a failure)


def _number(text: str) -> float:
    return float(text.rstrip("f"))


def _key_constants(sources: str) -> dict[str, str]:
    return dict(re.findall(r'constexpr char (k\w+)\[\] = "(\w+)";', sources))


def _table_rows(text: str, header: str) -> list[list[str]]:
    """The cells of each row of the markdown table whose header line starts with ``header``."""
    lines = text[text.index(header):].splitlines()
    rows = []
    for line in lines[2:]:  # past the header and its |---| line
        if not line.startswith("|"):
            break
        cells = re.split(r"(?<!\\)\|", line.strip().strip("|"))  # not at an escaped \|
        rows.append([cell.strip() for cell in cells])
    return rows


def _backticked(text: str) -> list[str]:
    return re.findall(r"`([\w*]+)`", text)


def _units(cell: str) -> list[str]:
    """A docs unit cell's units ("–" or "—": dimensionless, the table's "-")."""
    return [unit.replace("–", "-").replace("—", "-") for unit in cell.split(", ")]


def _laws(cell: str) -> set[str]:
    """A docs laws cell: "all" or a list, then ':' or ';' and a remark."""
    text = re.split(r"[:;]", cell)[0].strip()
    return set(ALL_LAWS) if text == "all" else set(text.split(", "))


def _md_section(text: str, heading: str) -> str:
    start = text.index(heading) + len(heading)
    following = re.search(r"^#{2,3} ", text[start:], re.M)
    return text[start:start + following.start()] if following else text[start:]


def test_friction_parameters_are_the_table() -> None:
    fields = {f.name: f.default for f in dataclasses.fields(FrictionParameters) if f.name != "law"}
    assert fields == {term.name: term.default for term in FRICTION_TERMS}
    assert rig.MJCF_KEYS == {term.name: term.mjcf_key for term in FRICTION_TERMS}
    for term in FRICTION_TERMS:
        assert LIMITS.get(term.name) == term.limits, term.name
    assert planar.PLANAR_MJCF_KEYS == element_keys("planar")
    assert averaged.AVERAGED_MJCF_KEYS == element_keys("averaged")


def test_the_table_names_known_elements_laws_and_shaped_effects() -> None:
    assert set(ELEMENT_SOURCES) == set(OWN_KEYS) == set(ALL_ELEMENTS)
    for term in FRICTION_TERMS:
        assert term.elements and set(term.elements) <= set(ALL_ELEMENTS), term.name
        assert "friction" in term.elements, term.name  # the 1D element takes every term
        assert term.laws and set(term.laws) <= set(ALL_LAWS), term.name
        if term.shapes is not None:  # a wavelength or phase goes where its effect goes
            assert TERMS_BY_NAME[term.shapes].elements == term.elements, term.name
            assert TERMS_BY_NAME[term.shapes].shapes is None, term.name
    for keys in OWN_KEYS.values():
        assert not keys & TABLE_KEYS


def test_the_cpp_law_parameters_have_the_tables_defaults() -> None:
    header = _cpp("laws/friction_law.h")
    struct = re.search(r"struct LawParameters \{(.*?)\};", header, re.S).group(1)
    struct = re.sub(r"//[^\n]*", "", struct)
    declared = re.findall(r"\b(\w+) (\w+) = ([^;]+);", struct)
    # the lists (gms elements, level maps) are members of their own structs, checked below
    declared = [d for d in declared if d[0] != "LevelMap"]
    assert re.findall(r"\bLevelMap (\w+)", struct) == ["position_map", "velocity_map",
                                                         "time_map"]
    assert re.findall(r"\bGmsElements (\w+);", struct) == ["gms"]
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
    assert LAWS == PAPER_LAWS == ALL_LAWS[:4]  # the study's and identification's laws
    # law gms's elements: GmsElements, with the table's defaults and bound
    gms = re.search(r"struct GmsElements \{(.*?)\n\};", header, re.S).group(1)
    assert re.search(r"int count = 0;", gms)
    assert int(re.search(r"kMaxGmsElements = (\d+);", header).group(1)) == MAX_GMS_ELEMENTS
    lists = re.findall(r"double (\w+)\[kMaxGmsElements\] = \{\};", gms)
    assert lists == ["stiffness", "weight"]
    assert [t.name for t in FRICTION_TERMS if t.is_list and t.laws == ("gms",)] == [
        "gms_stiffness_N_per_m", "gms_weights"]
    relaxation = re.search(r"double relaxation_time = ([^;]+);", gms).group(1)
    assert _number(relaxation) == TERMS_BY_NAME["gms_relaxation_time_s"].default
    level_map = re.search(r"struct LevelMap \{(.*?)\n\};", header, re.S).group(1)
    assert int(re.search(r"kMaxMapKnots = (\d+);", header).group(1)) == MAX_MAP_KNOTS
    assert re.findall(r"double (\w+)\[kMaxMapKnots\] = \{\};", level_map) == [
        "knot", "factor", "curvature"]
    assert [t.name for t in FRICTION_TERMS if t.is_list and "map" in t.name] == [
        "position_map_knots_m", "position_map_factors", "velocity_map_knots_m_per_s",
        "velocity_map_factors", "time_map_knots_s", "time_map_factors"]
    assert _number(re.search(r"double period = ([^;]+);", level_map).group(1)) == \
        TERMS_BY_NAME["position_map_period_m"].default


def test_the_config_readers_read_each_key_into_its_field_with_the_tables_default() -> None:
    """element_config.cc and friction_element.cc read {kKey, &field, default}; the keys'
    strings are the constants of element_config.h and friction_element.cc."""
    sources = (_cpp("common/element_config.h") + _cpp("common/element_config.cc")
               + _cpp("plugins/friction_element.cc"))
    constants = _key_constants(sources)
    read = {constants[key]: (field, _number(value)) for key, field, value in re.findall(
        r"\{(k\w+), &\w+\.(\w+), ([-+0-9.eE]+)\}", sources)}
    read.update({constants[key]: (field, _number(value)) for key, value, field in re.findall(
        r"ReadNumber\(m, instance, plugin, (k\w+), ([-+0-9.eE]+), &\w+\.(\w+)\)", sources)})
    # a list (law gms's elements) is read whole; its default is empty
    read.update({constants[key]: (None, ()) for key in re.findall(
        r"ReadNumberList\(m, instance, plugin, (k[A-Z]\w+),", sources)})
    # a level map: ReadLevelMap(..., knots key, factors key, period key or nullptr, ...)
    for knots, factors, period in re.findall(
            r"ReadLevelMap\(m, instance, kPlugin, (k\w+), (k\w+),\s*(k\w+|nullptr),", sources):
        read.update({constants[knots]: (None, ()), constants[factors]: (None, ())})
        if period != "nullptr":
            read[constants[period]] = (None, 0.0)
    for term in FRICTION_TERMS:
        assert term.mjcf_key in read, f"{term.mjcf_key} is not read by the friction element"
        field, default = read[term.mjcf_key]
        if term.is_list:
            assert default == term.default == (), term.name
            continue
        assert default == pytest.approx(term.default, rel=1e-12), term.name
        if term.law_field:
            assert field == term.law_field, term.name


@pytest.mark.parametrize("element", ALL_ELEMENTS)
def test_each_elements_attributes_are_the_table_keys_it_takes(element: str) -> None:
    """The kAttributes array MuJoCo checks an element's config against: its own keys and,
    beyond them, exactly the table keys whose row names the element."""
    source = _cpp(ELEMENT_SOURCES[element])
    constants = _key_constants(_cpp("common/element_config.h") + source)
    array = ATTRIBUTE_ARRAYS.get(element, "kAttributes")
    attributes = re.search(rf"\b{array}\[\] = \{{(.*?)\}};", source, re.S).group(1)
    listed = [constants[k] for k in re.findall(r"\bk\w+", attributes)]
    assert len(listed) == len(set(listed)), f"{element}: a key listed twice"
    own = OWN_KEYS[element]
    assert own <= set(listed), f"{element}: own keys not listed: {own - set(listed)}"
    friction_keys = set(listed) - own
    unknown = friction_keys - TABLE_KEYS
    assert not unknown, f"{element} lists keys neither its own nor table keys: {unknown}"
    takes = set(element_keys(element).values())
    assert friction_keys == takes, (f"{element}: listed, the table says not taken: "
                                    f"{friction_keys - takes}; taken, not listed: "
                                    f"{takes - friction_keys}")


def test_the_c_api_struct_and_the_ctypes_layout_are_the_tables() -> None:
    struct = re.search(r"typedef struct vf_law_parameters \{(.*?)\}", _cpp("c_api/c_api.h"),
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


def test_the_docs_parameter_table_names_each_key_unit_default_and_laws() -> None:
    rows = {cells[0].strip("`"): cells for cells in _table_rows(
        (ROOT / "docs" / "simulation.md").read_text(),
        "| Python name | MJCF | symbol | unit | default | laws | meaning |")}
    for term in FRICTION_TERMS:
        cells = rows[term.name]
        assert cells[1] == f"`{term.mjcf_key}`", term.name
        assert _units(cells[3]) == [term.unit], term.name
        documented = re.match(r"[-+0-9.e]+", cells[4])
        if term.is_list:  # no default: required, or a rule
            assert documented is None and cells[4].startswith("—"), term.name
        else:
            assert documented and float(documented.group(0)) == pytest.approx(term.default), \
                term.name
        assert _laws(cells[5]) == set(term.laws), f"{term.name}: simulation.md says {cells[5]}"


def test_robots_docs_parameter_table_names_each_planar_key_its_unit_and_laws() -> None:
    """docs/robots.md's table of the planar element's keys: the table's keys that element takes,
    with their Python names, units and laws ("all" or a list, then ':' or ';' and a remark)."""
    rows = _table_rows((ROOT / "docs" / "robots.md").read_text(),
                       "| MJCF key | Python name (`FrictionParameters`) | unit | laws |")
    documented = set()
    for keys_cell, names_cell, units_cell, laws_cell in rows:
        keys = _backticked(keys_cell)
        if not set(keys) & TABLE_KEYS:
            assert set(keys) <= OWN_KEYS["planar"], keys
            continue
        names = _backticked(names_cell)
        units = _units(units_cell)
        laws = _laws(laws_cell)
        assert len(units) == len(keys), keys
        for index, key in enumerate(keys):
            term = next((t for t in FRICTION_TERMS if t.mjcf_key == key), None)
            assert term is not None, f"{key} is no table key"
            name_pattern = names[index] if len(names) == len(keys) else names[0]
            assert fnmatch.fnmatchcase(term.name, name_pattern), key
            assert units[index] == term.unit, key
            assert laws == set(term.laws), f"{key}: robots.md says {sorted(laws)}"
            documented.add(key)
    assert documented == set(element_keys("planar").values())


def test_robots_docs_averaged_keys_sentence_names_the_keys_the_element_takes() -> None:
    section = _md_section((ROOT / "docs" / "robots.md").read_text(),
                          "## Robot-timestep mode (`vibrofriction.averaged`)")
    sentence = re.split(r"\.\s", section[section.index("The averaged instance takes"):])[0]
    mentioned = set(_backticked(sentence)) & TABLE_KEYS.union(*OWN_KEYS.values())
    takes = OWN_KEYS["averaged"] | set(element_keys("averaged").values())
    assert mentioned == takes, f"missing: {takes - mentioned}; not taken: {mentioned - takes}"


def test_interfaces_docs_friction_key_table_gives_each_key_its_name_unit_and_default() -> None:
    """The key table of ``vibrofriction.friction``: its own keys and, one a row, each table key
    with the table's Python name, unit and default."""
    section = _md_section((ROOT / "docs" / "interfaces.md").read_text(),
                          "### `vibrofriction.friction`\n")
    listed = []
    for keys_cell, name_cell, unit_cell, default_cell, _ in _table_rows(
            section, "| key | Python name | unit | default |"):
        keys = _backticked(keys_cell)
        listed += keys
        if not set(keys) & TABLE_KEYS:
            continue
        term = next((t for t in FRICTION_TERMS if [t.mjcf_key] == keys), None)
        assert term is not None, f"{keys}: not one table key"
        assert name_cell == f"`{term.name}`", term.mjcf_key
        assert _units(unit_cell) == [term.unit], term.mjcf_key
        if term.is_list:
            assert default_cell == "—", term.mjcf_key
        else:
            assert float(default_cell) == pytest.approx(term.default), term.mjcf_key
    assert len(listed) == len(set(listed)), "a key listed twice"
    takes = OWN_KEYS["friction"] | set(element_keys("friction").values())
    assert set(listed) == takes, f"missing: {takes - set(listed)}; not taken: {set(listed) - takes}"


@pytest.mark.parametrize("element", ["planar", "contact"])
def test_interfaces_docs_key_paragraph_names_the_keys_the_element_takes(element: str) -> None:
    section = _md_section((ROOT / "docs" / "interfaces.md").read_text(),
                          f"### `vibrofriction.{element}`")
    paragraph = section[section.index("Keys:"):].split("\n\n")[0]
    known = TABLE_KEYS.union(*OWN_KEYS.values())
    mentioned = set(_backticked(paragraph)) & known
    takes = OWN_KEYS[element] | set(element_keys(element).values())
    assert mentioned == takes, f"missing: {takes - mentioned}; not taken: {mentioned - takes}"


@pytest.mark.parametrize("element", ["contact_averaged", "contact_feeder"])
def test_interfaces_docs_drop_in_paragraph_names_the_keys_the_element_takes(element: str) -> None:
    text = (ROOT / "docs" / "interfaces.md").read_text()
    start = text.index(f"`vibrofriction.{element}`: keys")
    paragraph = text[start:].split("\n\n")[0]
    known = TABLE_KEYS.union(*OWN_KEYS.values())
    mentioned = set(_backticked(paragraph)) & known
    takes = OWN_KEYS[element] | set(element_keys(element).values())
    assert mentioned == takes, f"missing: {takes - mentioned}; not taken: {mentioned - takes}"


def test_interfaces_docs_averaged_key_table_names_the_keys_the_element_takes() -> None:
    section = _md_section((ROOT / "docs" / "interfaces.md").read_text(),
                          "### `vibrofriction.averaged`")
    listed = {key for cells in _table_rows(section, "| key |") for key in _backticked(cells[0])}
    takes = OWN_KEYS["averaged"] | set(element_keys("averaged").values())
    assert listed == takes, f"missing: {takes - listed}; not taken: {listed - takes}"


def test_the_one_copy_from_the_c_struct_fills_every_field() -> None:
    """LawFromStruct (c_api.cc) is the only place that fills LawParameters from the C struct
    (vf_run_law and vf_run_planar_law both use it): every struct field, each to its own name."""
    body = re.search(r"LawParameters LawFromStruct\(const vf_law_parameters& c\) \{(.*?)\n\}",
                     _cpp("c_api/c_api.cc"), re.S).group(1)
    copied = re.findall(r"p\.(\w+) = c\.(\w+);", body)
    assert sorted(copied) == sorted((field, field) for field in LAW_STRUCT_FIELDS)
    for source in ("c_api/c_api.cc", "plugins/planar_friction.cc"):
        assert "params->friction_coefficient" not in _cpp(source), f"a second copy in {source}"


def test_normal_gain_has_one_unit_in_every_docs_table() -> None:
    """normal_gain (N per unit of the sensor value or contact force) is no friction term, so
    the vocabulary does not hold it: every docs table row that names it gives it N/unit."""
    pages = [ROOT / "docs" / name for name in ("interfaces.md", "simulation.md", "robots.md")]
    pages.append(CPP / "README.md")
    rows = [line for page in pages for line in page.read_text().splitlines()
            if line.startswith("|") and "`normal_gain`" in line
            and "as `friction`" not in line]
    assert len(rows) >= 4, rows
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        at = next(i for i, c in enumerate(cells) if "`normal_gain`" in c)
        keys = [k.strip(" `") for k in cells[at].split(",")]
        if len(keys) > 1:  # a grouped row: its units in the keys' order, in the next such cell
            unit_cell = next(c for c in cells[at + 1:] if c.count(",") == len(keys) - 1)
            units = [u.strip() for u in unit_cell.split(",")]
            assert units[keys.index("normal_gain")] == "N/unit", row
        else:
            assert "N/unit" in cells, row
