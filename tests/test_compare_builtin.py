"""``vibrofriction compare-builtin``: the rig with MuJoCo's own friction elements, made by MjSpec
editing, against the plugin laws they correspond to."""
from __future__ import annotations

import json
import math

import mujoco
import pytest

from vibrofriction import cli
from vibrofriction.params import RigParameters
from vibrofriction.study import builtin
from vibrofriction.study.config import StudyConfig

MU_FN = 0.2 * 55.2  # mu F_N of the paper rig (N)
VARIANTS = ("springyield", "dcmotor-lugre", "frictionloss-tight", "frictionloss-default",
            "contact-tight")


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    missing = {v: why for v, why in builtin.unavailable_variants().items() if v in VARIANTS}
    if missing:
        pytest.skip(f"MuJoCo {mujoco.__version__} lacks {'; '.join(missing.values())}")
    out = tmp_path_factory.mktemp("builtin")
    code = cli.main(["compare-builtin", "--quick", "--quiet", "--ladder", "25,100",
                     "--variants", ",".join(VARIANTS), "--out", str(out)])
    assert code == 0
    payload = json.loads((out / "builtin.json").read_text())
    return out, {v["variant"]: v for v in payload["variants"]}, payload


def test_variants_are_built_by_spec_editing():
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=0.75e-3)
    config = StudyConfig.quick_config()
    for name in builtin.available_variants(builtin.BUILTIN_VARIANTS):
        model = builtin.build_variant_spec(name, rig, config, 5e-6).compile()
        # The friction plugin is gone; the support and drive-end motions and the dynamometer
        # sensor stay.
        assert model.nplugin == 3, name
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, "friction") == -1
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "friction") == -1
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, "friction_state") == -1
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "slider_on_table")
        dof = model.jnt_dofadr[joint]
        if name.startswith("frictionloss"):
            assert math.isclose(model.dof_frictionloss[dof], MU_FN)
        elif name.startswith("contact"):
            for geom in ("table", "slider"):
                g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom)
                assert model.geom_contype[g] == 1 and model.geom_condim[g] == 3
            assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "normal_load") >= 0
        elif name == "dcmotor-lugre":
            assert model.na == 1  # the bristle deflection
        elif name == "springyield":
            assert math.isclose(model.jnt_stiffness[joint], 80e6)
            assert math.isclose(model.jnt_springyield[joint] * 80e6, MU_FN)


def test_contact_variant_carries_the_normal_force():
    rig = RigParameters()
    model = builtin.build_variant_spec("contact-tight", rig, StudyConfig.quick_config(),
                                       5e-6).compile()
    data = mujoco.MjData(model)
    for _ in range(4000):  # 20 ms: the normal contact settles
        mujoco.mj_step(model, data)
    normal = 0.0
    for i in range(data.ncon):
        force = __import__("numpy").zeros(6)
        mujoco.mj_contactForce(model, data, i, force)
        normal += force[0]
    assert math.isclose(normal, rig.normal_force_N, rel_tol=0.01)


def test_builtin_elements_match_their_plugin_laws(cli_run):
    _, rows, payload = cli_run
    r = {name: row["ratios"]["1.5"] for name, row in rows.items()}
    # MuJoCo's native LuGre and the plugin's LuGre: same law, same numbers.
    assert math.isclose(r["dcmotor-lugre"], r["plugin-lugre"], rel_tol=0.01)
    # springyield is the Jenkins element = Dupont with z_ba -> z_max.
    assert math.isclose(r["springyield"], r["plugin-dupont-jenkins"], rel_tol=0.005)
    # Tight frictionloss and contact approach the plugin's rigid Coulomb with true stick.
    assert math.isclose(r["frictionloss-tight"], r["plugin-coulomb"], rel_tol=0.02)
    assert math.isclose(r["contact-tight"], r["plugin-coulomb"], rel_tol=0.03)
    # Default frictionloss creeps: it cannot even hold the slider without vibration.
    assert payload["static_drive_force_N"]["frictionloss-default"] < 0.1 * MU_FN
    assert math.isclose(payload["static_drive_force_N"]["plugin-coulomb"], MU_FN, rel_tol=1e-3)


def test_timestep_study(cli_run):
    out, rows, payload = cli_run
    assert payload["ladder_steps_per_period"] == [25, 100]
    # The plugin's Dahl-like state laws are within 1 % at T/25 (about 10 us) ...
    assert rows["plugin-dupont-jenkins"]["dt_own_s"] > 9e-6
    # ... the soft default frictionloss converges to its own answer but never to Coulomb's.
    assert rows["frictionloss-default"]["dt_target_s"] is None
    assert max(rows["frictionloss-default"]["errors_vs_target"]["1.5"]) > 0.5
    for name in ("springyield", "plugin-coulomb", "dcmotor-lugre"):
        assert rows[name]["wall_own_s"] is None or rows[name]["wall_own_s"] > 0
    text = (out / "builtin.md").read_text()
    assert "| variant | MuJoCo element |" in text and "dcmotor-lugre" in text
    for name in ("builtin_comparison.png", "builtin_table.csv", "builtin_timestep_ladder.csv",
                 "builtin_master.csv", "builtin_traces.csv"):
        assert (out / name).stat().st_size > 200, name


def test_variants_this_mujoco_lacks_are_named_or_left_out(tmp_path, capsys, monkeypatch):
    """As on MuJoCo 3.x (no joint springyield): asked for, one message naming what is missing;
    by default, left out with a note (reproduce's builtin.md names them too)."""
    monkeypatch.setattr(builtin, "_missing_builtins",
                        lambda: (("springyield", "joint attribute springyield"),))
    assert cli.main(["compare-builtin", "--variants", "springyield", "--quick",
                     "--out", str(tmp_path / "asked")]) == 2
    err = capsys.readouterr().err
    assert "springyield: joint attribute springyield" in err and "MuJoCo >= 4.0" in err
    assert not (tmp_path / "asked").exists()
    assert "springyield" not in builtin.available_variants(builtin.VARIANTS)
    assert "Not run: MuJoCo" in builtin._not_run_note()


def test_unknown_variant_exits_2(tmp_path, capsys):
    assert cli.main(["compare-builtin", "--variants", "nope", "--out", str(tmp_path)]) == 2
    assert "unknown variant" in capsys.readouterr().err



def test_timestep_is_not_an_option_the_ladder_sets_the_timesteps(tmp_path, capsys):
    """compare-builtin chooses every timestep (--ladder, the master grid): --timestep is neither
    offered by --help nor accepted (argparse's own error, exit 2)."""
    with pytest.raises(SystemExit) as help_exit:
        cli.main(["compare-builtin", "--help"])
    assert help_exit.value.code == 0
    assert "--timestep" not in capsys.readouterr().out
    with pytest.raises(SystemExit) as usage_exit:
        cli.main(["compare-builtin", "--quick", "--timestep", "1e-5", "--out", str(tmp_path)])
    assert usage_exit.value.code == 2
    assert "unrecognized arguments: --timestep 1e-5" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []

def test_required_timestep_is_the_largest_from_which_on_all_finer_steps_pass():
    dts = [8.0, 4.0, 2.0, 1.0]  # coarse -> fine; the last is the own reference
    assert builtin._required([0.02, 0.005, 0.001, 0.0], dts, 0.01, skip_last=True) == 4.0
    # A coarse step that happens to pass does not count when a finer one fails.
    assert builtin._required([0.005, 0.02, 0.001, 0.0], dts, 0.01, skip_last=True) == 2.0
    assert builtin._required([0.5, 0.5, 0.5, 0.5], dts, 0.01, skip_last=False) is None
    # Against another variant's reference the finest step counts too.
    assert builtin._required([0.5, 0.5, 0.5, 0.005], dts, 0.01, skip_last=False) == 1.0


def test_the_converged_curves_cost_is_measured_per_law_family(cli_run):
    """compare-builtin times the converged master curve by each route, per law family whose
    plugin variant ran (reproduce leaves this out)."""
    _, _, payload = cli_run
    costs = payload["converged_costs"]
    assert costs["kappas"] == pytest.approx([1.5, 6.0, 24.0]) and costs["accuracy"] == 0.01
    assert costs["laws"]
    for law, entry in costs["laws"].items():
        assert entry["periodic"]["cpu_s"] > 0 and entry["transient"]["cpu_s"] > 0, law
        assert entry["periodic"]["runs"] == 4, law  # the static run and three kappa_v
