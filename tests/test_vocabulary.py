"""One vocabulary (issue 10): every copy of the friction element's parameter table agrees with
``vibrofriction.vocabulary.FRICTION_TERMS`` -- names, MJCF keys, C++ fields and defaults, the
keys each element takes, and the docs' units and laws."""
from __future__ import annotations

import ctypes
import dataclasses
import fnmatch
import importlib.util
import re
from pathlib import Path

import pytest

from vibrofriction.laws._native import LawParameters
from vibrofriction.params import LAWS, LIMITS, FrictionParameters
from vibrofriction.rigs import planar, rig
from vibrofriction.robots import averaged
from vibrofriction.commands.info import registered_plugins
from vibrofriction.vocabulary import (ALL_ELEMENTS, ALL_KEYS, ALL_LAWS, ALL_PLUGINS, ELEMENT_KEYS,
                                      FRICTION_TERMS, LAW_STRUCT_FIELDS, MAX_GMS_ELEMENTS,
                                      MAX_MAP_KNOTS, PAPER_LAWS, TERMS_BY_NAME, element_keys,
                                      plugin_keys)

ROOT = Path(__file__).resolve().parents[1]
CPP = ROOT / "plugin" / "cpp"

# Each element's keys that are no friction term: written out here, so that a key moving between
# the friction terms and an element's own keys in the table is a failure.
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
    assert set(OWN_KEYS) == set(ALL_ELEMENTS)
    for term in FRICTION_TERMS:
        assert term.elements and set(term.elements) <= set(ALL_ELEMENTS), term.name
        assert "friction" in term.elements, term.name  # the 1D element takes every term
        assert term.laws and set(term.laws) <= set(ALL_LAWS), term.name
        if term.shapes is not None:  # a wavelength or phase goes where its effect goes
            assert TERMS_BY_NAME[term.shapes].elements == term.elements, term.name
            assert TERMS_BY_NAME[term.shapes].shapes is None, term.name
    for keys in OWN_KEYS.values():
        assert not keys & TABLE_KEYS


def _generator():
    """plugin/build_hooks/vocabulary_header.py, which the build runs to write vocabulary.h."""
    _cpp("laws/friction_law.h")  # (skips outside a source checkout)
    path = ROOT / "plugin" / "build_hooks" / "vocabulary_header.py"
    spec = importlib.util.spec_from_file_location("vocabulary_header", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _generated() -> str:
    generator = _generator()
    return generator.header(generator.load_vocabulary())


def _generated_keys() -> dict[str, str]:
    """C++ constant -> MJCF key, as vocabulary.h declares them."""
    return dict(re.findall(r'inline constexpr char (k\w+)\[\] = "(\w+)";', _generated()))


def test_the_generated_header_is_the_table() -> None:
    """vocabulary.h, which every plugin includes, says what the table says: each key once, the
    defaults, the ranges, the laws of each friction key, the keys of each plugin."""
    generator = _generator()
    header = _generated()
    keys = _generated_keys()
    assert sorted(keys.values()) == sorted(row.mjcf_key for row in ALL_KEYS)
    assert len(keys) == len(ALL_KEYS)  # no key twice
    defaults = {keys[name]: _number(value) for name, value in re.findall(
        r"inline constexpr double (k\w+) = ([-+0-9.eE]+);", header)}
    expected = {row.mjcf_key: float(row.default) for row in ALL_KEYS
                if isinstance(row.default, (int, float)) and not isinstance(row.default, bool)}
    assert defaults == expected
    flags = {keys[name]: value == "true" for name, value in re.findall(
        r"inline constexpr bool (k\w+) = (true|false);", header)}
    assert flags == {row.mjcf_key: row.default for row in ALL_KEYS
                     if isinstance(row.default, bool)} and flags
    by_key = re.findall(r"\{keys::(k\w+), defaults::(k\w+)\}", header)
    assert {keys[k] for k, d in by_key} == set(expected) and all(k == d for k, d in by_key)
    ranges = {keys[name]: (_number(lo), _number(hi)) for name, lo, hi in re.findall(
        r"\{keys::(k\w+), ([-+0-9.eE]+), ([-+0-9.eE]+)\},", header)}
    assert ranges == {row.mjcf_key: row.limits for row in ALL_KEYS if row.limits is not None}
    assert ranges["mu"] == LIMITS["friction_coefficient"]
    laws = {keys[name]: int(bits, 16) for name, bits in re.findall(
        r"\{keys::(k\w+), 0x([0-9a-f]+)u\}", header)}
    assert laws == {t.mjcf_key: sum(1 << ALL_LAWS.index(law) for law in t.laws)
                    for t in FRICTION_TERMS}
    for plugin in ALL_PLUGINS:
        array = re.search(rf"const char\* {generator.constant_name(plugin)}\[\] = \{{(.*?)\}};",
                          header).group(1)
        assert [keys[k] for k in re.findall(r"keys::(k\w+)", array)] == \
            list(plugin_keys(plugin)), plugin
    assert int(re.search(r"kMaxGmsElements = (\d+);", header).group(1)) == MAX_GMS_ELEMENTS
    assert int(re.search(r"kMaxMapKnots = (\d+);", header).group(1)) == MAX_MAP_KNOTS
    assert generator.constant_name("stribeck_velocity") == "kStribeckVelocity"


def test_no_cpp_source_restates_a_key_a_default_or_an_attribute_list() -> None:
    """Keys, defaults and the plugins' attribute lists are the generated header's alone: no
    source defines a key's string, passes a table key its own default (but the feeder's mu,
    which has none: it must be given), or lists attributes itself."""
    keys = set(_generated_keys().values())
    sources = {str(p.relative_to(CPP)): p.read_text() for p in sorted(CPP.rglob("*"))
               if p.suffix in (".h", ".cc") and "tests" not in p.parts}
    own_default = []
    for name, text in sources.items():
        for key in re.findall(r'constexpr char k\w+\[\] = "(\w+)";', text):
            assert key not in keys, f"{name} restates the key {key!r}"
        assert "const char* const kAttributes[]" not in text, name
        for call in re.findall(r"RegisterElementPlugin<[^;]*?>\(\s*[\w:]+, ([\w:]+),", text):
            assert call.startswith(("attributes::", "Spec::kAttributes")), (name, call)
        own_default += [(name, k) for k in re.findall(
            r"ReadNumber\(m, instance, \w+, (\w+), [-+0-9.]", text)]
        own_default += [(name, k) for k in re.findall(
            r"ReadBool\(m, instance, \w+, (\w+), (?:true|false)\b", text)]
    assert own_default == [("plugins/contact_friction.cc", "kMu")]
    ranges = sources["common/plugin_util.cc"]
    assert "kKeyRanges" in ranges and not re.search(r'\{"\w+", \{[-0-9.e]+, ', ranges)


def test_the_cpp_law_parameters_take_the_tables_defaults() -> None:
    header = _cpp("laws/friction_law.h")
    keys = _generated_keys()
    struct = re.search(r"struct LawParameters \{(.*?)\};", header, re.S).group(1)
    struct = re.sub(r"//[^\n]*", "", struct)
    declared = re.findall(r"\b(\w+) (\w+) = ([^;]+);", struct)
    # the lists (gms elements, level maps) are members of their own structs, checked below
    declared = [d for d in declared if d[0] != "LevelMap"]
    assert re.findall(r"\bLevelMap (\w+)", struct) == ["position_map", "velocity_map",
                                                         "time_map"]
    assert re.findall(r"\bGmsElements (\w+);", struct) == ["gms"]
    assert declared[0][:2] == ("Law", "law")
    initial = {name: value.strip() for kind, name, value in declared[1:] if kind == "double"}
    assert len(initial) == len(declared) - 1  # every field but the law is a double
    fields = {term.law_field: term for term in FRICTION_TERMS if term.law_field}
    assert set(initial) == set(fields) | {"normal_force"}
    assert initial["normal_force"] == "0.0"  # a rig's or a sensor's, not a table value
    for field, term in fields.items():
        default = re.fullmatch(r"defaults::(k\w+)", initial[field])
        assert default and keys[default.group(1)] == term.mjcf_key, (field, initial[field])
    enum = re.search(r"enum class Law : int \{(.*?)\};", header).group(1)
    values = {name.lower(): int(value) for name, value in re.findall(r"k(\w+) = (\d+)", enum)}
    assert values == {law: index for index, law in enumerate(ALL_LAWS)}
    assert LAWS == PAPER_LAWS == ALL_LAWS[:4]  # the study's and identification's laws
    # law gms's elements and the level maps: sized and defaulted by the table
    assert "kMaxGmsElements =" not in header and "kMaxMapKnots =" not in header
    gms = re.search(r"struct GmsElements \{(.*?)\n\};", header, re.S).group(1)
    assert re.search(r"int count = 0;", gms)
    lists = re.findall(r"double (\w+)\[kMaxGmsElements\] = \{\};", gms)
    assert lists == ["stiffness", "weight"]
    assert [t.name for t in FRICTION_TERMS if t.is_list and t.laws == ("gms",)] == [
        "gms_stiffness_N_per_m", "gms_weights"]
    assert re.search(r"double relaxation_time = defaults::kGmsRelaxationTime;", gms)
    level_map = re.search(r"struct LevelMap \{(.*?)\n\};", header, re.S).group(1)
    assert re.findall(r"double (\w+)\[kMaxMapKnots\] = \{\};", level_map) == [
        "knot", "factor", "curvature"]
    assert [t.name for t in FRICTION_TERMS if t.is_list and "map" in t.name] == [
        "position_map_knots_m", "position_map_factors", "velocity_map_knots_m_per_s",
        "velocity_map_factors", "time_map_knots_s", "time_map_factors"]
    assert re.search(r"double period = defaults::kPositionMapPeriod;", level_map)


def test_the_config_readers_read_each_key_into_its_field() -> None:
    """element_config.cc and friction_element.cc read {kKey, &field} (the default: the table's,
    looked up by key), or a list, or a level map; every friction key is read, into its field."""
    sources = (_cpp("common/element_config.h") + _cpp("common/element_config.cc")
               + _cpp("plugins/friction_element.cc"))
    constants = _generated_keys()
    read = {constants[key]: field for key, field in re.findall(
        r"\{(k\w+), &\w+\.(\w+)\}", sources)}
    read.update({constants[key]: field for key, field in re.findall(
        r"ReadNumber\(m, instance, \w+, (k\w+), &\w+\.(\w+)\)", sources)})
    # a list (law gms's elements) is read whole
    read.update({constants[key]: None for key in re.findall(
        r"ReadNumberList\(m, instance, plugin, (k[A-Z]\w+),", sources)})
    # a level map: ReadLevelMap(..., knots key, factors key, period key or nullptr, ...)
    for knots, factors, period in re.findall(
            r"ReadLevelMap\(m, instance, kPlugin, (k\w+), (k\w+),\s*(k\w+|nullptr),", sources):
        read.update({constants[knots]: None, constants[factors]: None})
        if period != "nullptr":
            read[constants[period]] = None
    for term in FRICTION_TERMS:
        assert term.mjcf_key in read, f"{term.mjcf_key} is not read by the friction element"
        if term.law_field:
            assert read[term.mjcf_key] == term.law_field, term.name


@pytest.mark.parametrize("plugin", ALL_PLUGINS)
def test_each_plugin_registers_the_table_keys_it_takes(plugin: str) -> None:
    """What MuJoCo checks a plugin's config against, read from its registry: exactly the
    table's keys for that plugin, friction terms and own keys (the elements' own keys are
    written out here as well, so that a key moving between the two is seen)."""
    registered = {p["name"]: p["attributes"] for p in registered_plugins()}
    attributes = registered[f"vibrofriction.{plugin}"]
    assert attributes == list(plugin_keys(plugin))
    if plugin in OWN_KEYS:
        own = {row.mjcf_key for row in ELEMENT_KEYS if plugin in row.elements}
        assert own == OWN_KEYS[plugin]
        assert set(attributes) - own == set(element_keys(plugin).values())


def test_the_c_api_struct_and_the_ctypes_layout_are_the_tables() -> None:
    struct = re.search(r"typedef struct vf_law_parameters \{(.*?)\}", _cpp("c_api/c_api.h"),
                       re.S).group(1)
    struct = re.sub(r"//[^\n]*", "", struct)
    declared = [(kind, name.strip()) for kind, names in
                re.findall(r"\b(int|double)\s+([^;]+);", struct) for name in names.split(",")]
    assert len(declared) == struct.count(",") + struct.count(";")  # nothing else declared
    assert declared == [("int", "law"), *(("double", f) for f in LAW_STRUCT_FIELDS)]
    kinds = {ctypes.c_int: "int", ctypes.c_double: "double"}
    assert [(kinds[t], n) for n, t in LawParameters._fields_] == declared
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
    """normal_gain (N per unit of the sensor value or contact force) is an element's own key
    of the vocabulary (ELEMENT_KEYS): every docs table row that names it gives it the table's
    unit, N/unit."""
    assert next(k.unit for k in ELEMENT_KEYS if k.mjcf_key == "normal_gain") == "N/unit"
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
