"""The friction element's parameter vocabulary, one row per parameter: the one table.

Each row gives the Python name (a ``FrictionParameters`` field, the CLI's ``--set`` name, the
JSON key), the friction element's MJCF config key, the field of the C++ ``LawParameters``
(also the C API's ``vf_law_parameters`` and the ctypes struct of ``_native``), the unit, the
default, the magnitudes accepted (``params.LIMITS``: the smallest nonzero, the largest), the
laws it acts in and the elements whose config takes its key. ``ALL_LAWS`` is in the order of
the C++ ``Law`` enum (its values).

``rig.MJCF_KEYS``, ``planar.PLANAR_MJCF_KEYS`` (and the effects ``check_planar`` refuses),
``averaged``'s law keys, ``params.LIMITS`` (its friction part), ``FrictionParameters``'
defaults and ``laws``' struct filling come from this table. So does the C++ side: the build
writes ``vocabulary.h`` from it (``plugin/build_hooks/vocabulary_header.py``: every plugin's
keys, their defaults and ranges, the laws of each friction key, each plugin's attribute list),
which the plugins and ``friction_law.h``'s ``LawParameters`` use; ``ELEMENT_KEYS`` holds the
plugins' own keys (normal load, vibration, contact and feeder geometry, motion, controller,
sensors) the same way. This module imports nothing but the standard library: the build loads
it from its file. ``tests/test_vocabulary.py`` checks the generated header, that no C++
source restates a key, a default or an attribute list, what MuJoCo's registry holds, the
ctypes struct, and the docs' tables (``docs/simulation.md``, ``docs/robots.md``,
``docs/interfaces.md``) against it.
"""
from __future__ import annotations

from dataclasses import dataclass

ALL_LAWS = ("coulomb", "dahl", "dupont", "lugre", "gms")
# The laws the paper compares, which the study and identification run (gms, the generalized
# Maxwell-slip law, is simulated by the 1D and planar elements; it is not a study law).
PAPER_LAWS = ALL_LAWS[:4]
GMS_ELEMENTS = ("friction", "planar")  # the elements that take law gms
MAX_GMS_ELEMENTS = 16  # friction_law.h kMaxGmsElements
MAX_MAP_KNOTS = 16  # friction_law.h kMaxMapKnots
# The elements whose config takes friction keys (vibrofriction.<name>) and the groups of them a
# row names: every one; those with a velocity law of their own (the feeder's map holds its
# velocity dependence); those that resolve the law in time (the averaged element's table holds
# the law's shape); the 1D element alone (effects with no isotropic meaning in the plane).
ALL_ELEMENTS = ("friction", "planar", "contact", "averaged", "contact_averaged", "contact_feeder")
VELOCITY_LAW_ELEMENTS = ("friction", "planar", "contact", "averaged", "contact_averaged")
RESOLVING_ELEMENTS = ("friction", "planar", "contact")
LINE_ELEMENT_ONLY = ("friction",)
PAPER_CONTACT_STIFFNESS_N_PER_M = 80.0e6


@dataclass(frozen=True)
class Term:
    """One row of the vocabulary: a friction parameter's Python name, MJCF config key, C struct
    field, unit, default, accepted magnitudes (SI), the laws it acts in, the elements whose
    config takes it, and the effect whose form alone it sets, if any."""

    name: str  # Python, CLI and JSON name, SI unit in it
    mjcf_key: str  # config key, the same in every element that takes it
    law_field: str | None  # LawParameters / vf_law_parameters field (None: not a law value)
    unit: str
    default: float | tuple[float, ...]  # a tuple: a list of numbers, one per gms element
    # (smallest nonzero magnitude, largest), SI; None: a fraction whose range
    # ``FrictionParameters.validate`` checks itself
    limits: tuple[float, float] | None
    laws: tuple[str, ...]
    elements: tuple[str, ...]  # the elements (ALL_ELEMENTS) whose config takes mjcf_key
    # the effect (a Term.name) whose form alone this term sets, idle while that effect is 0
    shapes: str | None = None

    @property
    def is_list(self) -> bool:
        """A space-separated list in MJCF, a tuple in Python (the gms elements' values)."""
        return isinstance(self.default, tuple)


FRICTION_TERMS: tuple[Term, ...] = (
    Term("friction_coefficient", "mu", "friction_coefficient", "-", 0.2, (0.0, 1e9), ALL_LAWS,
         ALL_ELEMENTS),
    Term("contact_stiffness_N_per_m", "stiffness", "contact_stiffness", "N/m",
         PAPER_CONTACT_STIFFNESS_N_PER_M, (0.0, 1e18), ("dahl", "dupont", "lugre"),
         RESOLVING_ELEMENTS),
    Term("alpha", "alpha", "alpha", "-", 1.0, (0.0, 1e3), ("dahl",), RESOLVING_ELEMENTS),
    Term("breakaway_ratio", "breakaway", "breakaway_ratio", "-", 0.7, None, ("dupont",),
         RESOLVING_ELEMENTS),
    Term("bristle_damping_N_s_per_m", "sigma1", "bristle_damping", "N s/m", 0.0, (0.0, 1e15),
         ("dahl", "dupont", "lugre"), RESOLVING_ELEMENTS),
    Term("viscous_N_s_per_m", "viscous", "viscous", "N s/m", 0.0, (0.0, 1e15), ALL_LAWS,
         VELOCITY_LAW_ELEMENTS),
    Term("static_ratio", "static_ratio", "static_ratio", "-", 1.0, (0.0, 1e3), ALL_LAWS,
         VELOCITY_LAW_ELEMENTS),
    Term("stribeck_velocity_m_per_s", "stribeck_velocity", "stribeck_velocity", "m/s", 1.0e-3,
         (1e-15, 1e3), ALL_LAWS, VELOCITY_LAW_ELEMENTS),
    Term("asymmetry", "asymmetry", "asymmetry", "-", 0.0, None, ALL_LAWS, LINE_ELEMENT_ONLY),
    Term("position_ripple", "ripple", "ripple", "-", 0.0, None, ALL_LAWS, LINE_ELEMENT_ONLY),
    Term("position_ripple_wavelength_m", "ripple_wavelength", "ripple_wavelength", "m", 1.0e-3,
         (1e-15, 1e6), ALL_LAWS, LINE_ELEMENT_ONLY, shapes="position_ripple"),
    Term("position_ripple_phase_rad", "ripple_phase", "ripple_phase", "rad", 0.0, (0.0, 1e6),
         ALL_LAWS, LINE_ELEMENT_ONLY, shapes="position_ripple"),
    Term("normal_force_modulation", "normal_modulation", "normal_modulation", "-", 0.0, None,
         ALL_LAWS, RESOLVING_ELEMENTS),
    Term("normal_force_modulation_frequency_Hz", "modulation_frequency",
         "normal_modulation_frequency", "Hz", 0.0, (0.0, 1e9), ALL_LAWS, RESOLVING_ELEMENTS,
         shapes="normal_force_modulation"),
    Term("normal_force_modulation_phase_rad", "modulation_phase", "normal_modulation_phase",
         "rad", 0.0, (0.0, 1e6), ALL_LAWS, RESOLVING_ELEMENTS, shapes="normal_force_modulation"),
    Term("force_offset_N", "force_offset", "force_offset", "N", 0.0, (0.0, 1e9), ALL_LAWS,
         LINE_ELEMENT_ONLY),
    # a play in the contact before the bristles (friction_law.h, ElasticDeflection)
    Term("contact_play_m", "contact_play", "contact_play", "m", 0.0, (0.0, 1e3),
         ("dahl", "dupont", "lugre"), LINE_ELEMENT_ONLY),
    # law gms: one value per element (LawParameters::gms, not in the C API struct: the gms
    # elements go to vf_run_law_with_lists as arrays)
    Term("gms_stiffness_N_per_m", "gms_stiffness", None, "N/m", (), (0.0, 1e18), ("gms",),
         GMS_ELEMENTS),
    Term("gms_weights", "gms_weight", None, "-", (), None, ("gms",), GMS_ELEMENTS),
    Term("gms_relaxation_time_s", "gms_relaxation_time", None, "s", 0.0, (0.0, 1e3), ("gms",),
         GMS_ELEMENTS),
    # Level maps (LawParameters::position_map, velocity_map, time_map; lists, so not in the C
    # API struct: vf_run_law_with_lists takes them): the level times 1 + a cubic spline through
    # the factors
    Term("position_map_knots_m", "position_map_knots", None, "m", (), (0.0, 1e6), ALL_LAWS,
         LINE_ELEMENT_ONLY, shapes="position_map_factors"),
    Term("position_map_factors", "position_map_factors", None, "-", (), (0.0, 1e3), ALL_LAWS,
         LINE_ELEMENT_ONLY),
    Term("position_map_period_m", "position_map_period", None, "m", 0.0, (0.0, 1e6), ALL_LAWS,
         LINE_ELEMENT_ONLY, shapes="position_map_factors"),
    Term("velocity_map_knots_m_per_s", "velocity_map_knots", None, "m/s", (), (0.0, 1e3),
         ALL_LAWS, LINE_ELEMENT_ONLY, shapes="velocity_map_factors"),
    Term("velocity_map_factors", "velocity_map_factors", None, "-", (), (0.0, 1e3), ALL_LAWS,
         LINE_ELEMENT_ONLY),
    Term("time_map_knots_s", "time_map_knots", None, "s", (), (0.0, 1e9), ALL_LAWS,
         LINE_ELEMENT_ONLY, shapes="time_map_factors"),
    Term("time_map_factors", "time_map_factors", None, "-", (), (0.0, 1e3), ALL_LAWS,
         LINE_ELEMENT_ONLY),
    # (the element's reporting, not the law: kept by the element, not in LawParameters)
    Term("sensor_lag_s", "sensor_lag", None, "s", 0.0, (0.0, 1e3), ALL_LAWS, LINE_ELEMENT_ONLY),
)
TERMS_BY_NAME = {term.name: term for term in FRICTION_TERMS}
LIMITS = {term.name: term.limits for term in FRICTION_TERMS if term.limits is not None}
DEFAULTS = {term.name: term.default for term in FRICTION_TERMS}
MJCF_KEYS = {term.name: term.mjcf_key for term in FRICTION_TERMS}


def element_keys(element: str) -> dict[str, str]:
    """Term name -> MJCF key of the terms that ``vibrofriction.<element>`` takes, in table order."""
    if element not in ALL_ELEMENTS:
        raise ValueError(f"unknown element {element!r}; the elements are {ALL_ELEMENTS}")
    return {term.name: term.mjcf_key for term in FRICTION_TERMS if element in term.elements}


def config_values(friction, keys: dict[str, str]) -> dict[str, str]:
    """MJCF config values (strings) of ``friction`` (a FrictionParameters) for ``keys`` (term name
    -> MJCF key): a number as repr(float), a list space-separated; an empty list (a map that is
    off) is left out, and the gms keys are written only for law gms."""
    config = {}
    for name, key in keys.items():
        term = TERMS_BY_NAME[name]
        if term.laws == ("gms",) and friction.law != "gms":
            continue
        if term.is_list and not getattr(friction, name) and name != "gms_weights":
            continue  # an empty list: the map is off (and gms takes its weights' default)
        if term.is_list:
            values = friction.gms_element_weights if name == "gms_weights" else \
                getattr(friction, name)
            config[key] = " ".join(repr(float(x)) for x in values)
        else:
            config[key] = repr(float(getattr(friction, name)))
    return config


# The plugins that are not friction elements (vibrofriction.<name>): the prescribed motion, the
# lagged tendon sensor, the sampled PD controller and the elements' state sensors.
OTHER_PLUGINS = ("motion", "lagged_tendon", "sampled_pd", "friction_sensor", "planar_sensor",
                 "contact_sensor")
ALL_PLUGINS = ALL_ELEMENTS + OTHER_PLUGINS
NORMAL_LOAD_ELEMENTS = ("friction", "planar", "averaged")  # a load from config, sensor or contact
CONTACT_ELEMENTS = ("contact", "contact_averaged", "contact_feeder")  # the load: MuJoCo's contacts
AVERAGED_ELEMENTS = ("averaged", "contact_averaged")  # the table of the averaged law


@dataclass(frozen=True)
class ElementKey:
    """An MJCF config key of a plugin that is not a friction term: the normal load's source, the
    vibration, the contact and feeder geometry, the motion, the controller, the sensors."""

    mjcf_key: str
    unit: str  # "name": a name of the model; "bool": true or false; "list": numbers
    default: float | bool | None  # None: a name, a list or text, empty unless given
    limits: tuple[float, float] | None  # as Term.limits; None: the reader's own rule
    elements: tuple[str, ...]  # the plugins (ALL_PLUGINS) whose config takes it
    meaning: str


ELEMENT_KEYS: tuple[ElementKey, ...] = (
    ElementKey("law", "name", None, None, ("friction", "planar", "contact"),
               "the friction law: coulomb, dahl, dupont, lugre (gms: friction, planar)"),
    ElementKey("normal", "N", 0.0, (0.0, 1e9), NORMAL_LOAD_ELEMENTS,
               "constant normal load"),
    ElementKey("normal_sensor", "name", None, None, NORMAL_LOAD_ELEMENTS,
               "a sensor whose value (times normal_gain) adds to the normal load"),
    ElementKey("normal_gain", "N/unit", 1.0, (0.0, 1e9), NORMAL_LOAD_ELEMENTS,
               "newtons per unit of the normal sensor or contact force"),
    ElementKey("normal_component", "-", 0.0, None, NORMAL_LOAD_ELEMENTS,
               "the sensor's component read as the load"),
    ElementKey("contact_geom1", "name", None, None, NORMAL_LOAD_ELEMENTS,
               "with contact_geom2: the load is the normal force of their contacts"),
    ElementKey("contact_geom2", "name", None, None, NORMAL_LOAD_ELEMENTS,
               "the other geom of the contacts that carry the load"),
    ElementKey("normal_from_ctrl", "bool", False, None, ("friction",),
               "the actuator's ctrl is the normal load"),
    ElementKey("velocity_amplitude", "m/s", 0.0, (0.0, 1e3), AVERAGED_ELEMENTS + ("motion",),
               "the support's vibration velocity amplitude"),
    ElementKey("axis_angle", "rad", 0.0, (0.0, 1e6), ("averaged",),
               "the vibration's direction in the element's plane"),
    ElementKey("use_ctrl", "bool", False, None, ("averaged", "motion"),
               "the actuator's ctrl scales the vibration"),
    ElementKey("table_xi", "list", None, None, AVERAGED_ELEMENTS,
               "the averaged table's speed ratios"),
    ElementKey("table_angle", "list", None, None, AVERAGED_ELEMENTS,
               "the averaged table's angles"),
    ElementKey("table_along", "list", None, None, AVERAGED_ELEMENTS,
               "the averaged force along the motion"),
    ElementKey("table_across", "list", None, None, AVERAGED_ELEMENTS,
               "the averaged force across the motion"),
    ElementKey("table_checksum", "text", None, None, AVERAGED_ELEMENTS,
               "FNV-1a of the four lists: the per-step config check skips them"),
    ElementKey("support", "name", None, None, CONTACT_ELEMENTS,
               "the body the part slides on (its contacts with the part carry the element)"),
    ElementKey("support_geom", "name", None, None, CONTACT_ELEMENTS,
               "the one geom of the support that conveys (walls and stops are MuJoCo's)"),
    ElementKey("torsion_radius", "m", 0.0, None, CONTACT_ELEMENTS,
               "radius of the contact patch for the torsional friction"),
    ElementKey("axis", "list", None, None, ("contact_averaged", "contact_feeder"),
               "the vibration direction in the support's frame"),
    ElementKey("helix_pitch", "m", 0.0, None, ("contact_feeder",),
               "rise per turn of a bowl feeder's helical track"),
    ElementKey("map_velocity", "list", None, None, ("contact_feeder",),
               "the feeder map's conveying velocities"),
    ElementKey("map_force", "list", None, None, ("contact_feeder",),
               "the feeder map's mean forces"),
    ElementKey("frequency", "Hz", 0.0, (0.0, 1e7), ("motion",), "vibration frequency"),
    ElementKey("velocity", "m/s", 0.0, (1e-12, 1e3), ("motion",),
               "constant velocity (the drive's far end)"),
    ElementKey("phase", "rad", 0.0, (0.0, 1e6), ("motion",), "vibration phase"),
    ElementKey("start_time", "s", 0.0, (0.0, 1e9), ("motion",),
               "the vibration starts then"),
    ElementKey("ramp_periods", "-", 0.0, (0.0, 1e9), ("motion",),
               "periods over which the vibration builds up"),
    ElementKey("displacement_from_ctrl", "bool", False, None, ("motion",),
               "the ctrl is the support's displacement (a measured motion replayed)"),
    ElementKey("tendon", "name", None, None, ("lagged_tendon",), "the tendon read"),
    ElementKey("time_constant", "s", 0.0, (0.0, 1e3), ("lagged_tendon",),
               "the reading's first-order lag"),
    ElementKey("beyond_deadband", "bool", False, None, ("lagged_tendon",),
               "read the extension beyond the tendon's dead band (a play)"),
    ElementKey("position_gain", "N/m", 0.0, None, ("sampled_pd",), "P gain"),
    ElementKey("velocity_gain", "N s/m", 0.0, None, ("sampled_pd",), "D gain"),
    ElementKey("drive_gain", "N/unit", 1.0, None, ("sampled_pd",),
               "force per unit of the command"),
    ElementKey("saturation", "N", 0.0, None, ("sampled_pd",), "command limit (0: none)"),
    ElementKey("sample_period", "s", 0.0, None, ("sampled_pd",), "controller sample period"),
    ElementKey("command_delay", "s", 0.0, None, ("sampled_pd",), "delay of the command"),
    ElementKey("actuator", "name", None, None, ("friction_sensor", "planar_sensor"),
               "the friction element's actuator the sensor reads"),
    ElementKey("body", "name", None, None, ("contact_sensor",),
               "the body whose contact element the sensor reads"),
)
# every key of every plugin: the friction terms', then the plugins' own
ALL_KEYS: tuple = FRICTION_TERMS + ELEMENT_KEYS
# each key's default (a number, a bool; a friction term's list: an empty tuple; a plugin's own
# list, name or text: None)
KEY_DEFAULTS = {row.mjcf_key: row.default for row in ALL_KEYS}
# the keys that say where an element's normal load comes from (config, sensor, contacts)
NORMAL_LOAD_KEYS = tuple(k.mjcf_key for k in ELEMENT_KEYS if k.elements == NORMAL_LOAD_ELEMENTS)


def plugin_keys(plugin: str) -> tuple[str, ...]:
    """The MJCF config keys ``vibrofriction.<plugin>`` takes, in table order (the friction
    terms', then its own): exactly the attributes it registers with MuJoCo."""
    if plugin not in ALL_PLUGINS:
        raise ValueError(f"unknown plugin {plugin!r}; the plugins are {ALL_PLUGINS}")
    return tuple(row.mjcf_key for row in ALL_KEYS if plugin in row.elements)


# The C API struct's doubles after ``int law``, in c_api.h's order (the ABI: written out, so
# that reordering the table cannot move them): the law values and the normal load (a rig's or
# a sensor's, not a FrictionParameters value). tests/test_vocabulary.py checks both.
LAW_STRUCT_FIELDS = (
    "friction_coefficient", "normal_force", "contact_stiffness", "alpha", "breakaway_ratio",
    "bristle_damping", "viscous", "static_ratio", "stribeck_velocity", "asymmetry", "ripple",
    "ripple_wavelength", "ripple_phase", "normal_modulation", "normal_modulation_frequency",
    "normal_modulation_phase", "force_offset", "contact_play")

__all__ = ["Term", "FRICTION_TERMS", "TERMS_BY_NAME", "DEFAULTS", "MJCF_KEYS", "LIMITS",
           "LAW_STRUCT_FIELDS", "ALL_LAWS", "PAPER_LAWS", "GMS_ELEMENTS", "MAX_GMS_ELEMENTS", "MAX_MAP_KNOTS", "ALL_ELEMENTS", "VELOCITY_LAW_ELEMENTS",
           "RESOLVING_ELEMENTS",
           "LINE_ELEMENT_ONLY", "PAPER_CONTACT_STIFFNESS_N_PER_M", "element_keys", "config_values",
           "ElementKey", "ELEMENT_KEYS", "ALL_KEYS", "OTHER_PLUGINS", "ALL_PLUGINS",
           "NORMAL_LOAD_ELEMENTS", "NORMAL_LOAD_KEYS", "KEY_DEFAULTS", "CONTACT_ELEMENTS", "AVERAGED_ELEMENTS", "plugin_keys"]
