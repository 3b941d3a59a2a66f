"""vibrofriction.sim: the MuJoCo plumbing shared by rigs, robots and identify. Scene builders
write the plugins' configs through it, their keys checked against the one table."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

import vibrofriction
from vibrofriction import sim
from vibrofriction.params import ParameterError
from vibrofriction.vocabulary import plugin_keys

PLATE_AND_PART = """<mujoco><option timestep="1e-3"/><worldbody>
<body name="plate"><geom name="plate" type="box" size=".1 .1 .005" condim="1"/></body>
<body name="part" pos="0 0 .0149"><freejoint/>
<geom name="part" type="box" size=".01 .01 .01" condim="1" mass="0.03"/></body>
</worldbody></mujoco>"""


def test_a_config_key_the_table_does_not_give_the_plugin_is_named_with_its_keys() -> None:
    with pytest.raises(ParameterError, match=r"vibrofriction.contact has no config key 'muu'; "
                                             r"its keys are mu, stiffness"):
        sim.plugin_config("contact", {"muu": "0.5"})
    with pytest.raises(ParameterError, match="unknown plugin 'vibrofriction.frictoin'"):
        sim.plugin_config("vibrofriction.frictoin", {})
    with pytest.raises(ParameterError, match="mu=nan is not finite"):
        sim.plugin_config("contact", {"mu": float("nan")})


def test_values_are_written_as_mjcf_text() -> None:
    config = sim.plugin_config("contact_feeder", {"mu": 0.5, "axis": (1, 0, 0.5),
                                                  "support": "plate", "helix_pitch": "0.02"})
    assert config == {"mu": "0.5", "axis": "1.0 0.0 0.5", "support": "plate",
                      "helix_pitch": "0.02"}
    assert sim.plugin_config("motion", {"use_ctrl": True})["use_ctrl"] == "true"
    assert sim.plugin_config("motion", {"use_ctrl": np.bool_(True)})["use_ctrl"] == "true"
    assert sim.plugin_config("contact_feeder", {"axis": np.array([1.0, 0.0, 0.0])})["axis"] == \
        "1.0 0.0 0.0"


def test_an_element_added_through_mjspec_holds_a_part_as_its_xml_twin_does() -> None:
    """A contact element added with add_plugin_instance: a part pushed at half its sliding
    friction stays put, as the same element written in MJCF does."""
    vibrofriction.load()
    spec = mujoco.MjSpec.from_string(PLATE_AND_PART)
    sim.add_plugin_instance(spec, "contact", "part_friction",
                            {"law": "coulomb", "mu": 0.5, "support": "plate"}, body="part")
    model = spec.compile()
    assert model.nplugin == 1 and model.body_plugin[model.body("part").id] == 0
    text = PLATE_AND_PART.replace(
        "<worldbody>", '<extension><plugin plugin="vibrofriction.contact">'
        + sim.instance_xml("contact", "part_friction",
                           {"law": "coulomb", "mu": 0.5, "support": "plate"})
        + "</plugin></extension><worldbody>").replace(
        '<geom name="part" type="box" size=".01 .01 .01" condim="1" mass="0.03"/>',
        '<geom name="part" type="box" size=".01 .01 .01" condim="1" mass="0.03"/>'
        '<plugin instance="part_friction"/>')
    twin = mujoco.MjModel.from_xml_string(text)
    finals = []
    for m in (model, twin):
        data = mujoco.MjData(m)
        part = m.body("part").id
        for _ in range(300):
            data.xfrc_applied[part, 0] = 0.5 * 0.5 * 0.03 * 9.81  # half the sliding friction
            mujoco.mj_step(m, data)
        finals.append(data.qpos.copy())
    # held: 35 um while the contact settles, against 0.11 m for the push without friction
    assert abs(finals[0][0]) < 1e-4
    np.testing.assert_array_equal(finals[0], finals[1])


def test_add_plugin_instance_names_a_missing_body_and_set_plugin_config_checks_keys() -> None:
    vibrofriction.load()
    spec = mujoco.MjSpec.from_string(PLATE_AND_PART)
    with pytest.raises(ParameterError, match="the model has no body 'prat'"):
        sim.add_plugin_instance(spec, "contact", "f", {"law": "coulomb", "support": "plate"},
                                body="prat")
    assert len(spec.plugins) == 0  # a failing call adds nothing
    spec = mujoco.MjSpec.from_string(PLATE_AND_PART)
    sim.add_plugin_instance(spec, "contact", "f", {"law": "coulomb", "support": "plate"})
    with pytest.raises(ParameterError, match="has no config key 'torsion'"):
        sim.set_plugin_config(spec, "f", {"torsion": "0.01"})


def test_every_plugin_key_list_is_the_tables() -> None:
    assert "support_geom" in plugin_keys("contact_feeder")
    assert plugin_keys("friction_sensor") == ("actuator",)
    assert sim.cpu_count() >= 1
