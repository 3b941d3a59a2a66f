"""``vibrofriction reproduce --quick``: every figure appears, and the paper's claims hold with
the numbers this run computes (Gutowski & Leus 2012, sections 4-6)."""
from __future__ import annotations

import csv
import json
import math

import pytest

from vibrofriction import cli, params
from vibrofriction.study.config import (EXPERIMENT_FIG13, EXPERIMENT_FIG14, StudyConfig,
                                        period_timestep, steps_per_period, study_timestep)
from vibrofriction.params import RigParameters

FIGURES = ["fig07_traces_va0.25", "fig08_traces_va0.75", "fig09_traces_va3.0",
           "fig10_hysteresis", "fig11_profiles", "fig13_experiment_traces",
           "fig14_experiment_master", "master_curves", "grid_sweep"]


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    code = cli.main(["reproduce", "--quick", "--no-builtin", "--quiet", "--out", str(out)])
    assert code == 0
    claims = json.loads((out / "claims.json").read_text())
    return out, {c["id"]: c for c in claims["claims"]}, claims


def _rows(path):
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def test_every_figure_and_table_is_written(quick_run):
    out, _, _ = quick_run
    for name in FIGURES:
        png = out / f"{name}.png"
        assert png.stat().st_size > 10_000, name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert len(_rows(out / f"{name}.csv")) > 5, name
    assert (out / "fig12_stiffness.png").is_file()
    for name in ("fig12a_stiffness_profiles.csv", "fig12b_stiffness_master.csv"):
        assert len(_rows(out / name)) > 5
    trace = _rows(out / "fig08_traces_va0.75.csv")
    assert {"law", "time_s", "slider_position_m", "slider_velocity_m_per_s",
            "drive_velocity_m_per_s", "support_velocity_m_per_s", "relative_velocity_m_per_s",
            "friction_force_N"} <= set(trace[0])
    assert {r["law"] for r in trace} == {"dahl", "coulomb"}
    # v_r = v_A - v_v in every row (eq. 6).
    for r in trace[::50]:
        assert math.isclose(float(r["relative_velocity_m_per_s"]),
                            float(r["slider_velocity_m_per_s"])
                            - float(r["support_velocity_m_per_s"]), abs_tol=1e-9)


def test_master_curve_overlays(quick_run):
    out, _, _ = quick_run
    rows = [r for r in _rows(out / "master_curves.csv") if r["law"] == "coulomb"]
    for r in rows:
        kappa = float(r["kappa"])
        arcsin = 1.0 if kappa <= 1 else 2 / math.pi * math.asin(1 / kappa)
        # The kinematic limit from the plugin's own Coulomb law is the arcsin law.
        assert math.isclose(float(r["kinematic_ratio"]), arcsin, rel_tol=0.02, abs_tol=2e-3)
        # The timestep rule gives at least 50 steps per vibration period.
        assert float(r["timestep_s"]) <= 1 / (4000 * 50)


def test_summary_lists_every_claim_and_the_chosen_values(quick_run):
    out, claims, payload = quick_run
    text = (out / "summary.md").read_text()
    for claim_id in ("no_reduction_at_or_below_drive_velocity", "reduction_without_sign_change",
                     "sign_change_at_large_kappa", "more_than_20_fold_reduction",
                     "wrong_stiffness_error_above_100_percent", "laws_differ"):
        assert claim_id in claims
        assert claim_id in text
    # The unspecified values are the ones of params.py, quoted once, not restated.
    assert "drive_stiffness_N_per_m`` 1e6" in text
    assert text.count("Values the paper (Gutowski & Leus 2012) does not give") == 1
    assert payload["unspecified_values"] in params.__doc__
    assert "F_N = p S" in text and "67.2 N" in text and "37.2 N" in text


def test_no_reduction_when_va_below_vd(quick_run):
    _, claims, _ = quick_run
    c = claims["no_reduction_at_or_below_drive_velocity"]
    assert c["holds"] in ("yes", "partly")
    # The paper's simulation rig (Figs. 7-12): nothing is reduced below v_d, for every law.
    assert max(c["values"]["kappa_below_1"]["paper_rig"].values()) < 0.01
    # At the paper's k_t and 4 kHz also v_a = v_d exactly leaves the force unchanged.
    assert max(c["values"]["kappa_equal_1"]["paper_rig"].values()) < 0.01
    # Fig. 7: F_F stays at mu F_N (constant to 1 %).
    assert max(c["values"]["friction_peak_to_peak_over_level_at_0.25mm_s"].values()) < 0.01


def test_reduction_without_sign_change_at_small_kappa(quick_run):
    _, claims, _ = quick_run
    c = claims["reduction_without_sign_change"]
    assert c["holds"] == "yes"
    v = c["values"]
    assert 0.65 < v["dahl_kappa_1.5_ratio"] < 0.9
    assert v["dahl_kappa_1.5_friction_min_N"] > 3.0
    assert not v["dahl_kappa_1.5_sign_change"]


def test_sign_change_at_large_kappa(quick_run):
    _, claims, _ = quick_run
    c = claims["sign_change_at_large_kappa"]
    assert c["holds"] == "yes"
    v = c["values"]
    assert v["dahl_kappa_6_friction_min_N"] < -3.0 < 3.0 < v["dahl_kappa_6_friction_max_N"]
    onset = v["onset"]["dahl"]
    assert 1.5 <= onset["last_kappa_without"] < onset["first_kappa_with_sign_change"] <= 6


def test_more_than_twenty_fold_reduction(quick_run):
    _, claims, _ = quick_run
    c = claims["more_than_20_fold_reduction"]
    assert c["holds"] == "yes"
    for law, v in c["values"]["per_law"].items():
        # The arcsin law needs kappa 12.7; the rig's laws need a little more.
        assert 10 < v["kappa_for_20_fold"] < 25, law
        assert v["reduction_factor_at_max_kappa"] > 40, law


def test_wrong_contact_stiffness_changes_the_drive_force(quick_run):
    _, claims, _ = quick_run
    c = claims["wrong_stiffness_error_above_100_percent"]
    errors = c["values"]["all"]
    by = {(e["wrong_stiffness_N_per_um"], e["kappa"]): e["error_percent"] for e in errors}
    # Softer contact: less reduction, the drive force is over-predicted (most at large kappa).
    assert by[(20.0, 20.0)] > 50
    # Stiffer contact (resonance at the excitation): large under-prediction near kappa 1-3.
    assert by[(320.0, 1.5)] < -30
    assert abs(c["values"]["largest"]["error_percent"]) > 50


def test_laws_differ(quick_run):
    _, claims, _ = quick_run
    c = claims["laws_differ"]
    assert c["holds"] == "yes"
    r = c["values"]["ratios"]
    # Dahl and LuGre (same k_t, LuGre adds bristle damping) stay within 3 %; Dupont's elastic
    # stick range keeps more force; Coulomb (with true stick) reduces less at kappa 1.5.
    assert abs(r["dahl"]["1.5"]["ratio"] - r["lugre"]["1.5"]["ratio"]) < 0.03
    assert r["dupont"]["3"]["ratio"] > r["dahl"]["3"]["ratio"] + 0.2
    assert r["coulomb"]["1.5"]["ratio"] > r["dahl"]["1.5"]["ratio"] + 0.05
    assert not r["dupont"]["3"]["sign_change"] and r["dahl"]["3"]["sign_change"]
    # Coulomb with true stick rides with the table instead of reversing at kappa 1.5.
    assert c["values"]["coulomb_kappa_1.5_friction_min_N"] > 0
    # Far above v_d every law approaches its kinematic (heavy-body) limit.
    for law, dev in c["values"]["kinematic_limit_deviation_at_max_kappa"].items():
        assert dev < 0.2, law
    # Fig. 13 configuration: Dupont keeps the most force at v_a = 1.76 mm/s.
    fig13 = c["values"]["fig13_ratios"]["1.76"]
    assert fig13["dupont"] == max(fig13.values())


def test_normal_force_choice_is_stated_with_its_effect(quick_run):
    _, _, payload = quick_run
    assert math.isclose(EXPERIMENT_FIG13.normal_force_N, 67.2)
    assert math.isclose(EXPERIMENT_FIG14.normal_force_N, 37.2)
    assert math.isclose(EXPERIMENT_FIG13.normal_force_from_loads_N, 61.8 + 0.5 * 9.81)
    for v in payload["normal_force_choice"].values():
        assert abs(v["difference"]) < 0.01


def test_timestep_rule():
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=0.75e-3)
    assert steps_per_period(1.5) == 50 and steps_per_period(20) == 100
    assert steps_per_period(40) == 200 and steps_per_period(41) == 400
    assert math.isclose(study_timestep(rig), 1 / (4000 * 50.381966))
    # Not an integer number of steps per period (the grid slides along the phase).
    steps = 1 / (4000 * period_timestep(4000, 50))
    assert abs(steps - round(steps)) > 0.3
    assert study_timestep(RigParameters()) == 1e-5  # no vibration


def test_quick_config_is_small():
    quick, full = StudyConfig.quick_config(), StudyConfig.full()
    assert len(quick.kappas) < len(full.kappas)
    for kappa in (0.5, 1.0, 1.5, 6.0):
        assert kappa in quick.kappas and kappa in full.kappas


def test_bad_input_exits_2(tmp_path, capsys):
    assert cli.main(["reproduce", "--quick", "--out", str(tmp_path), "--set", "nope=1"]) == 2
    assert "unknown parameter" in capsys.readouterr().err
    assert cli.main(["reproduce", "--quick", "--out", str(tmp_path), "--timestep", "-1"]) == 2
