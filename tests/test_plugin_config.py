"""Strict config validation: every invalid attribute of vibrofriction.friction and
vibrofriction.motion makes model compilation fail with one message that names the element and
the attribute (and says what to write); each numeric attribute has the physical range of its
Python name (params.LIMITS); the MuJoCo version check names both versions."""
from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import mujoco
import pytest

from vibrofriction import sim
import vibrofriction
from vibrofriction.rigs import planar
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import LIMITS, RigParameters, default_friction
from vibrofriction.vocabulary import TERMS_BY_NAME

KEEP = object()


def _spec(law: str = "dahl") -> mujoco.MjSpec:
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    return rig_module.build_spec(rig, default_friction(law, rig), 1e-5)


def _set_config(spec: mujoco.MjSpec, instance: str, changes: dict) -> None:
    for plugin in spec.plugins:
        if plugin.name == instance:
            config = dict(plugin.config)
            for key, value in changes.items():
                if value is None:
                    config.pop(key, None)
                else:
                    config[key] = value
            plugin.config = config
            return
    raise AssertionError(f"no plugin instance {instance}")


def _compile_error(spec: mujoco.MjSpec) -> str:
    with pytest.raises(ValueError) as info:
        spec.compile()
    return str(info.value)


def test_the_valid_scenes_compile_and_step():
    for law in ("coulomb", "dahl", "dupont", "lugre"):
        model = mujoco.MjModel.from_xml_path(str(rig_module.scene_path(law)))
        data = mujoco.MjData(model)
        for _ in range(100):
            mujoco.mj_step(model, data)
        assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0


FRICTION_CASES = [
    # (changes, attribute named, a word of the fix)
    ({"mu": "-0.1"}, "mu", ">= 0"),
    ({"normal": "-5"}, "normal", ">= 0"),
    ({"stiffness": "0"}, "stiffness", "> 0"),
    ({"stiffness": "1e7x"}, "stiffness", "plain number"),
    ({"alpha": "-1"}, "alpha", ">= 0"),
    ({"alpha": "nan"}, "alpha", "finite number"),
    ({"breakaway": "1"}, "breakaway", "(0, 1)"),
    ({"breakaway": "0"}, "breakaway", "(0, 1)"),
    ({"sigma1": "-1"}, "sigma1", ">= 0"),
    ({"viscous": "-1"}, "viscous", ">= 0"),
    ({"static_ratio": "0.9"}, "static_ratio", ">= 1"),
    ({"stribeck_velocity": "0"}, "stribeck_velocity", "> 0"),
    ({"asymmetry": "1"}, "asymmetry", "(-1, 1)"),
    ({"ripple": "1"}, "ripple", "[0, 1)"),
    ({"ripple_wavelength": "0"}, "ripple_wavelength", "> 0"),
    ({"ripple_phase": "pi"}, "ripple_phase", "plain number"),
    ({"normal_modulation": "1.5"}, "normal_modulation", "[0, 1)"),
    ({"modulation_frequency": "-1"}, "modulation_frequency", ">= 0"),
    ({"modulation_phase": "1e400"}, "modulation_phase", "finite number"),
    ({"force_offset": "0.1 N"}, "force_offset", "plain number"),
    ({"sensor_lag": "-1e-3"}, "sensor_lag", ">= 0"),
    ({"alpha": "0x10"}, "alpha", "decimal notation"),  # strtod would read 16
    ({"sigma1": "1e-400"}, "sigma1", "too small to represent"),  # would read 0
    ({"viscous": "1e300"}, "viscous", "within +-1e+15"),
    ({"mu": "-1e300"}, "mu", "within +-1e+09"),
    ({"stiffness": "1e300"}, "stiffness", "within +-1e+18"),
    ({"force_offset": "1e18"}, "force_offset", "within +-1e+09"),
    ({"stribeck_velocity": "1e-16"}, "stribeck_velocity", "at least 1e-15"),
    ({"normal_component": "1e300"}, "normal_component", "past any physical value"),
    ({"normal_sensor": "drive_force", "normal_gain": "1e12"}, "normal_gain", "within +-1e+09"),
    ({"normal_sensor": "no_such_sensor"}, "normal_sensor", "names no sensor"),
    ({"normal_sensor": "drive_force", "normal_component": "1"}, "normal_component",
     "dimension"),
    ({"normal_sensor": "drive_force", "normal_gain": "x2"}, "normal_gain", "plain number"),
    ({"law": "stribeck"}, "law", "coulomb, dahl, dupont, lugre"),
    ({"law": None}, "law", 'add <config key="law"'),
    ({"law": "Dahl"}, "law", "coulomb, dahl, dupont, lugre"),
]


@pytest.mark.parametrize("changes, attribute, fix", FRICTION_CASES,
                         ids=[f"{c[1]}={list(c[0].values())[-1]}" for c in FRICTION_CASES])
def test_invalid_friction_attribute_is_named(changes, attribute, fix):
    spec = _spec()
    _set_config(spec, "friction", changes)
    message = _compile_error(spec)
    assert "vibrofriction.friction" in message
    assert f"'{attribute}'" in message
    assert fix in message


STRUCTURE_CASES = [
    # (how the friction actuator is changed, a word of the message)
    ("ball", "is a ball or free joint"),
    ("spatial tendon", "is not a fixed tendon"),
    ("site", "must be a slide or hinge joint or a fixed tendon"),
    ("actdim 2", 'actdim="2"'),
    ("actdim 3", 'actdim="3"'),
    ("free", "is a ball or free joint"),
    ("gear 0", "gear is 0"),
    ("motion after friction", "computed after this friction element"),
]


def _structural_misuse(case: str, separate_tree: bool = False) -> mujoco.MjSpec:
    """A tiny scene with the element misused as ``case`` says."""
    joint = case if case in ("ball", "free") else "slide"
    transmission = {"spatial tendon": 'tendon="spatial"', "site": 'site="s"'}.get(
        case, 'joint="j"')
    actdim = int(case[-1]) if case.startswith("actdim") else 1
    gear = "0" if case == "gear 0" else "1"
    motion = ('<plugin plugin="vibrofriction.motion"><instance name="shake"/></plugin>',
              '<plugin name="shake" joint="j2" instance="shake"/>')
    first, second = ("", motion[0]) if case == "motion after friction" else (motion[0], "")
    driven = ('<body name="c" pos="0.3 0 0"><joint name="j2" type="slide" axis="1 0 0"/>'
              '<geom size="0.1" mass="1"/></body>')
    return mujoco.MjSpec.from_string(f"""
<mujoco>
  <extension>
    {first}
    <plugin plugin="vibrofriction.friction"><instance name="f">
      <config key="law" value="dahl"/><config key="mu" value="0.2"/>
      <config key="normal" value="10"/><config key="stiffness" value="1e6"/>
    </instance></plugin>
    {second}
  </extension>
  <worldbody>
    <body name="b"><joint name="j" type="{joint}"{' axis="1 0 0"' * (joint == "slide")}/>
      <geom size="0.1" mass="1"/>
      <site name="s"/><site name="s2" pos="0.1 0 0"/>
      {'' if separate_tree else driven}</body>
    {driven if separate_tree else ''}
  </worldbody>
  <tendon><spatial name="spatial"><site site="s"/><site site="s2"/></spatial></tendon>
  <actuator>
    {motion[1]}
    <plugin name="friction" {transmission} instance="f" actdim="{actdim}" gear="{gear}"/>
  </actuator>
</mujoco>""")


@pytest.mark.parametrize("case, words", STRUCTURE_CASES, ids=[c[0] for c in STRUCTURE_CASES])
def test_structural_misuse_is_refused_naming_the_fix(case, words):
    message = _compile_error(_structural_misuse(case))
    assert "vibrofriction.friction" in message and words in message


def test_a_motion_after_the_element_on_another_body_tree_is_fine():
    # the driven body is a tree of its own: its force cannot reach the element's stick solve
    _structural_misuse("motion after friction", separate_tree=True).compile()


def test_unknown_friction_attribute_is_rejected_by_mujoco():
    spec = _spec()
    _set_config(spec, "friction", {"mue": "0.3"})
    assert "mue" in _compile_error(spec)


def test_missing_actdim_is_named_with_the_fix():
    for actdim in (-1, 0):
        spec = _spec()
        spec.actuator("friction").actdim = actdim
        message = _compile_error(spec)
        assert "deflection z" in message and 'actdim="1"' in message


def test_instance_without_actuator_is_named():
    spec = _spec()
    spec.delete(spec.actuator("friction"))
    message = _compile_error(spec)
    assert "vibrofriction.friction" in message and "no actuator" in message


MOTION_CASES = [
    ("table_shaker", {"frequency": "-4000"}, "frequency", ">= 0"),
    ("table_shaker", {"frequency": "4 kHz"}, "frequency", "plain number"),
    ("table_shaker", {"velocity_amplitude": "-1e-3"}, "velocity_amplitude", ">= 0"),
    ("table_shaker", {"frequency": "0"}, "frequency", "set frequency"),
    ("table_shaker", {"phase": "inf"}, "phase", "finite number"),
    ("table_shaker", {"use_ctrl": "yes"}, "use_ctrl", '"true" or "false"'),
    ("drive_end_motion", {"velocity": "1e7x"}, "velocity", "plain number"),
    # values that would make the run NaN are outside the physical ranges
    ("drive_end_motion", {"velocity": "1e300"}, "velocity", "within +-1000"),
    ("drive_end_motion", {"velocity": "1e18"}, "velocity", "within +-1000"),
    ("table_shaker", {"velocity_amplitude": "1e18"}, "velocity_amplitude", "within +-1000"),
    ("table_shaker", {"frequency": "1e8"}, "frequency", "within +-1e+07"),
]


@pytest.mark.parametrize("instance, changes, attribute, fix", MOTION_CASES,
                         ids=[f"{c[2]}={list(c[1].values())[-1]}" for c in MOTION_CASES])
def test_invalid_motion_attribute_is_named(instance, changes, attribute, fix):
    spec = _spec()
    _set_config(spec, instance, changes)
    message = _compile_error(spec)
    assert "vibrofriction.motion" in message
    assert attribute in message
    assert fix in message


# The plugin attribute of each params.LIMITS name (instance in the rig scene, MJCF key). The
# averaged element reads mu, normal, viscous, static_ratio, stribeck_velocity and
# velocity_amplitude with the same keys and so the same ranges.
PLUGIN_ATTRIBUTES = {name: ("friction", key) for name, key in rig_module.MJCF_KEYS.items()}
PLUGIN_ATTRIBUTES.update({
    "normal_force_N": ("friction", "normal"),
    "vibration_frequency_Hz": ("table_shaker", "frequency"),
    "vibration_velocity_amplitude_m_per_s": ("table_shaker", "velocity_amplitude"),
    "drive_velocity_m_per_s": ("drive_end_motion", "velocity"),
    "vibration_from_s": ("table_shaker", "start_time"),
})
LIMITED = sorted(name for name in PLUGIN_ATTRIBUTES if name in LIMITS)


def test_every_python_limit_of_a_plugin_attribute_is_compared():
    # the rest are built-in MuJoCo values of the rig (body mass, drive spring and its play: the
    # tendon's stiffness and springlength), not plugin keys
    assert set(LIMITS) - set(LIMITED) == {"mass_kg", "drive_stiffness_N_per_m",
                                          "drive_damping_N_s_per_m", "drive_backlash_m",
                                          "drive_backlash_centre_m",
                                          "drive_backlash_stiffness_N_per_m"}


@pytest.mark.parametrize("name", LIMITED)
def test_the_plugin_range_of_an_attribute_equals_its_python_limit(name):
    """Queried from the compiled library: the limit itself compiles, a value just past it is
    refused with a message naming the attribute and its range, which must be LIMITS[name]."""
    smallest, largest = LIMITS[name]
    instance, key = PLUGIN_ATTRIBUTES[name]
    law = "gms" if name.startswith("gms_") else "dahl"  # (the gms keys: the gms scene's)
    elements = len(default_friction("gms").gms_stiffness_N_per_m)

    def compile_with(value: float) -> str | None:
        spec = _spec(law)
        term = TERMS_BY_NAME.get(name)
        config = {key: repr(float(value))}
        if term is not None and term.laws == ("gms",) and term.is_list:
            config[key] = " ".join([repr(float(value))] * elements)
        elif term is not None and "map" in name:  # a map: knots and factors together
            prefix = name.split("_map")[0] + "_map"
            if name.endswith("_factors"):
                config = {f"{prefix}_knots": "0 1 2", key: " ".join([repr(float(value))] * 3)}
            elif term.is_list:  # increasing knots up to the value
                config = {key: " ".join(repr(float(value) * f) for f in (0.25, 0.5, 1.0)),
                          f"{prefix}_factors": "0 0 0"}
        _set_config(spec, instance, config)
        try:
            spec.compile()
        except ValueError as error:
            return str(error)
        return None

    assert compile_with(largest) is None
    message = compile_with(largest * (1 + 1e-9))
    assert message is not None and f"attribute '{key}'=" in message
    rule = f"within +-{largest:g}" + (
        f" and be 0 or at least {smallest:g} in magnitude" if smallest else " (SI units)")
    assert rule in message
    if smallest:
        assert compile_with(smallest) is None
        assert rule in (compile_with(smallest * (1 - 1e-9)) or "")


def test_an_out_of_range_value_stops_what_would_run_nan():
    """Values within the general 1e18 cap that make a run NaN (issue 9): their ranges refuse
    them at compile time."""
    for instance, key in [("drive_end_motion", "velocity"), ("table_shaker", "velocity_amplitude"),
                          ("friction", "force_offset")]:
        spec = _spec()
        _set_config(spec, instance, {key: "1e18"})
        message = _compile_error(spec)
        assert f"attribute '{key}'=\"1e18\" is out of its physical range" in message



def test_python_modulation_frequency_zero_is_written_as_the_vibration_frequency():
    """normal_force_modulation_frequency_Hz = 0 in Python means "the vibration frequency": the
    rig (1D and planar) writes that frequency into the MJCF key, where 0 would mean 0 Hz; a
    non-zero value is written as it is."""
    rig = RigParameters(vibration_frequency_Hz=2600.0, vibration_velocity_amplitude_m_per_s=3e-3)
    friction = replace(default_friction("dahl", rig), normal_force_modulation=0.2)
    assert friction.normal_force_modulation_frequency_Hz == 0
    configs = {
        "rig.friction_config": rig_module.friction_config(rig, friction),
        "rig.build_spec": _plugin_config(rig_module.build_spec(rig, friction, 1e-5), "friction"),
        "planar.build_rig_spec": _plugin_config(
            planar.build_rig_spec(rig, friction, timestep_s=1e-5), "friction"),
    }
    for where, config in configs.items():
        assert float(config["modulation_frequency"]) == rig.vibration_frequency_Hz, where
    explicit = replace(friction, normal_force_modulation_frequency_Hz=10.0)
    assert float(rig_module.friction_config(rig, explicit)["modulation_frequency"]) == 10.0


def test_mjcf_modulation_frequency_zero_is_zero_hz():
    """modulation_frequency="0" in MJCF is literally 0 Hz: F_N = normal (1 + m sin(phase)),
    constant, although the table vibrates at 4 kHz."""
    spec = _spec()
    _set_config(spec, "friction", {"normal_modulation": "0.2", "modulation_frequency": "0",
                                   "modulation_phase": "0.5"})
    model = spec.compile()
    data = mujoco.MjData(model)
    normal_column = sim.sensor_slices(model)["friction_state"].start + 3
    normal_forces_N = []
    for _ in range(100):  # 1 ms: four vibration periods
        mujoco.mj_step(model, data)
        normal_forces_N.append(data.sensordata[normal_column])
    expected_N = RigParameters().normal_force_N * (1 + 0.2 * math.sin(0.5))
    assert normal_forces_N == pytest.approx([expected_N] * 100, rel=1e-12)


def _plugin_config(spec: mujoco.MjSpec, instance: str) -> dict[str, str]:
    for plugin in spec.plugins:
        if plugin.name == instance:
            return dict(plugin.config)
    raise AssertionError(f"no plugin instance {instance}")

LAGGED_TENDON_CASES = [
    ({"time_constant": "-1e-5"}, "time_constant", ">= 0"),
    ({"time_constant": "8 us"}, "time_constant", "plain number"),
    ({"tendon": None}, "tendon", "name the tendon"),
    ({"tendon": "no_such_tendon"}, "tendon", "names no tendon"),
]


@pytest.mark.parametrize("changes, attribute, fix", LAGGED_TENDON_CASES,
                         ids=[f"{c[1]}={list(c[0].values())[-1]}" for c in LAGGED_TENDON_CASES])
def test_invalid_lagged_tendon_attribute_is_named(changes, attribute, fix):
    spec = _spec()
    _set_config(spec, "dynamometer", changes)
    message = _compile_error(spec)
    assert "vibrofriction.lagged_tendon" in message
    assert attribute in message
    assert fix in message


def test_version_mismatch_names_both_versions():
    with pytest.raises(vibrofriction.MujocoVersionMismatch) as info:
        vibrofriction.check_mujoco_version(runtime="3.9.9", compiled="4.0.0")
    message = str(info.value)
    assert "3.9.9" in message and "4.0.0" in message
    assert "mujoco==4.0.0" in message  # and the fix
    assert isinstance(info.value, ImportError)


def test_matching_versions_pass():
    vibrofriction.check_mujoco_version(runtime="4.0.0", compiled="4.0.0")
    vibrofriction.check_mujoco_version()  # the installed build


def test_load_is_idempotent():
    assert vibrofriction.load() is vibrofriction.load()


def test_readme_snippet_compiles_and_the_block_creeps(tmp_path):
    """The MJCF example of docs/simulation.md ("Adding the friction element...") works."""
    doc = Path(__file__).resolve().parents[1] / "docs" / "simulation.md"
    if not doc.is_file():
        pytest.skip("docs/simulation.md is not in this checkout")
    xml = re.search(r"```xml\n(.*?)```", doc.read_text(), re.S).group(1)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("pull").id] = 5.0
    for _ in range(20000):
        mujoco.mj_step(model, data)
    block = model.joint("block_on_plate").qposadr[0]
    assert data.qpos[block] == pytest.approx(0.26e-3, rel=0.05)
    f_f, z = data.sensordata[0], data.sensordata[1]
    assert f_f == pytest.approx(8e7 * z)


def test_a_second_copy_at_another_path_is_refused(tmp_path):
    """load() uses one absolute path; a copy elsewhere would register the same names again.
    Run in a child process: the refused copy stays mapped in the process that tried it."""
    import subprocess
    import sys

    script = (
        "import shutil, sys, mujoco, vibrofriction\n"
        "from vibrofriction.laws import _native\n"
        "vibrofriction.load()\n"
        "assert _native.library_path().is_absolute()\n"
        "copy = shutil.copy(_native.library_path(), sys.argv[1])\n"
        "try:\n"
        "    mujoco.mj_loadPluginLibrary(copy)\n"
        "except Exception as exc:\n"
        "    print(exc)\n")
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "copy.so")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "already registered" in out.stdout


def _entry_point_installed() -> bool:
    from importlib.metadata import entry_points
    return any(ep.value == "vibrofriction.laws._mujoco_plugins:register"
               for ep in entry_points(group="mujoco.plugins"))


@pytest.mark.skipif(not _entry_point_installed(),
                    reason="the mujoco.plugins entry point is not installed (a source tree on "
                           "PYTHONPATH); it is with pip install .")
@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4,
                    reason=f"MuJoCo {mujoco.__version__} does not load mujoco.plugins entry points "
                           "(4.0 does): import vibrofriction first")
@pytest.mark.parametrize("first", ["mujoco", "vibrofriction"])
def test_a_plain_import_mujoco_registers_the_plugins(first):
    """The entry point in the group mujoco.plugins: a scene loads after `import mujoco` alone
    (as in `python -m mujoco.viewer`), and importing vibrofriction first is no circular import
    (warnings are errors in the child: a failed entry point would warn)."""
    import subprocess
    import sys

    script = (
        "import warnings\n"
        "warnings.simplefilter('error')\n"
        f"import {first}\n"
        "import mujoco\n"
        "model = mujoco.MjModel.from_xml_path(sys.argv[1])\n"
        "assert model.nplugin > 0\n"
        "import vibrofriction\n"
        "vibrofriction.load()\n"
        "print('loaded')\n")
    out = subprocess.run([sys.executable, "-c", "import sys\n" + script,
                          str(rig_module.scene_path("dahl"))],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "loaded"


def test_info_reads_every_plugin_and_its_attributes_from_mujocos_registry(tmp_path):
    """`vibrofriction info --json`: the versions, and each plugin as MuJoCo registered it; every
    friction key of the vocabulary (rig.MJCF_KEYS) is an attribute of the friction element."""
    import json

    from vibrofriction import cli
    path = tmp_path / "info.json"
    assert cli.main(["info", "--json", str(path)]) == 0
    payload = json.loads(path.read_text())
    assert payload["versions"]["mujoco"] == mujoco.__version__
    plugins = {p["name"]: p for p in payload["plugins"]}
    assert set(plugins) == {f"vibrofriction.{n}" for n in (
        "friction", "motion", "planar", "averaged", "contact", "contact_averaged", "contact_feeder",
        "friction_sensor", "planar_sensor", "contact_sensor", "lagged_tendon", "sampled_pd")}
    assert plugins["vibrofriction.friction"]["kinds"] == ["actuator"]
    assert plugins["vibrofriction.contact"]["kinds"] == ["passive"]
    assert {"support", "torsion_radius"} <= set(plugins["vibrofriction.contact"]["attributes"])
    assert plugins["vibrofriction.contact_sensor"]["attributes"] == ["body"]
    assert set(rig_module.MJCF_KEYS.values()) <= set(plugins["vibrofriction.friction"]["attributes"])
    assert {"start_time", "ramp_periods"} <= set(plugins["vibrofriction.motion"]["attributes"])
