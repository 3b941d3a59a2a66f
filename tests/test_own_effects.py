"""A researcher's own effect (issue 34, item 5): registered without editing the selection code,
it is a candidate and a --with name like the vocabulary's, fitted through the plugin's level
map, reported, and refused with one clear line when it cannot be one."""
from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vibrofriction import cli
from vibrofriction.data import synthetic
from vibrofriction.data.datasets import write_dataset
from vibrofriction.errors import InputError
from vibrofriction.identify import identify
from vibrofriction.identify import own_effects
from vibrofriction.identify.own_effects import LevelEffect, OwnParameter, register_effect

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "own_effect.py"
DURATION_S = 0.05
EXCESS, TIME_CONSTANT_S = 0.15, 8e-3  # the hidden run-in


@pytest.fixture
def run_in():
    names = own_effects.load_effects_file(EXAMPLE)
    assert names == ["run_in"]
    yield own_effects.registered()["run_in"]
    for name in names:
        own_effects.unregister(name)


def _records():
    """A rig record (the scipy reference, no plugin code) whose level runs in, and a held-out
    one pulled at another speed."""
    out = []
    for held_out in (False, True):
        scenario = replace(synthetic.Scenario(), duration_s=DURATION_S, seed=2 if held_out else 1,
                           level_factor=lambda t, x, v: 1.0 + EXCESS * math.exp(
                               -t / TIME_CONSTANT_S))
        if held_out:
            scenario = replace(scenario, rig=replace(scenario.rig, drive_velocity_m_per_s=0.7e-3))
        out.append(synthetic.generate(scenario, name=f"run_in_{'heldout' if held_out else 'train'}"))
    return out


def test_an_own_effect_is_selected_its_values_come_back_and_the_plugin_runs_it(run_in):
    train, held = _records()
    result = identify(train, [held], law="lugre")
    # chosen among every candidate (the built-in time map among them), not declared
    assert result.selected == ["run_in"]
    assert "time_map" in result.candidates  # it competed
    assert result.final.values["run_in_excess"] == pytest.approx(EXCESS, rel=0.03)
    assert result.final.values["run_in_time_s"] == pytest.approx(TIME_CONSTANT_S, rel=0.03)
    assert result.final.validation[0].relerr_pct < 0.3 * result.baseline.validation[0].relerr_pct
    # the model the plugin runs: its time map through the effect's knots, the factor at each
    friction = result.final.model.friction_parameters(result.final.values)
    knots = np.asarray(friction.time_map_knots_s)
    assert len(knots) == run_in.knots and knots[0] == 0.0
    expected = run_in.factor(knots, result.final.values) - 1.0
    np.testing.assert_allclose(friction.time_map_factors, expected, rtol=0, atol=1e-12)
    friction.validate()


def test_an_own_effect_excludes_the_built_in_map_over_its_regressor(run_in):
    from vibrofriction.identify.model import excluded_by
    assert "time_map" in excluded_by(["run_in"])
    assert "run_in" in excluded_by(["time_map"])
    with pytest.raises(InputError, match="exclude each other"):
        identify(_records()[0], law="lugre", declared=("run_in", "time_map"))


def test_cli_takes_an_effects_file_declares_it_and_writes_a_runnable_set_line(tmp_path):
    train, _ = _records()
    path = write_dataset(train, tmp_path / "run_in.csv")[0]
    out = tmp_path / "report"
    code = cli.main(["identify", str(path), "--method", "inverse", "--effects-from",
                     str(EXAMPLE), "--with", "run_in", "--no-figures", "--out", str(out)])
    assert code == 0
    report = json.loads((out / "report.json").read_text())
    values = report["final"]["parameters"]
    assert values["run_in_excess"] == pytest.approx(EXCESS, rel=0.05)
    assert len(values["time_map_factors"]) == 16
    # the --set line runs the level map, not the effect's own names (simulate knows none)
    text = (out / "report.md").read_text()
    set_lines = [line for line in text.splitlines() if "--set" in line]
    assert set_lines and "time_map_factors=" in set_lines[0]
    assert "run_in_excess" not in set_lines[0]
    # registered for that run only
    assert "run_in" not in own_effects.registered()


def test_cli_refuses_an_own_effect_it_was_not_given(tmp_path, capsys):
    train, _ = _records()
    path = write_dataset(train, tmp_path / "r.csv")[0]
    code = cli.main(["identify", str(path), "--with", "run_in", "--out", str(tmp_path / "o")])
    assert code != 0
    err = capsys.readouterr().err
    assert "unknown effect(s) run_in" in err and "--effects-from" in err
    assert not (tmp_path / "o").exists()
    code = cli.main(["identify", str(path), "--effects-from", str(tmp_path / "missing.py"),
                     "--out", str(tmp_path / "o")])
    assert code != 0 and "no such file" in capsys.readouterr().err
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('oops')\n")
    code = cli.main(["identify", str(path), "--effects-from", str(broken),
                     "--out", str(tmp_path / "o")])
    assert code != 0 and "RuntimeError: oops" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def _effect(**changes) -> LevelEffect:
    base = dict(name="bump", over="relative_speed",
                parameters=(OwnParameter("bump_height", -0.5, 0.5, 0.05),),
                factor=lambda v, p: 1.0 + p["bump_height"] * np.exp(-v / 1e-3))
    base.update(changes)
    return LevelEffect(**base)


@pytest.mark.parametrize("changes, message", [
    (dict(name="viscous"), "name is taken"),
    (dict(name="not a name"), "identifier"),
    (dict(over="temperature"), "over='temperature'"),
    (dict(knots=40), "knots=40"),
    (dict(parameters=(OwnParameter("friction_coefficient", -1, 1, 0.1),)), "is taken"),
    (dict(parameters=(OwnParameter("bump_height", 0.1, 0.5, 0.05),)), "lower <= 0 <= upper"),
    (dict(parameters=(OwnParameter("bump_speed", 1e-4, 1.0, 1e-3, log=True),)),
     "at least one linear parameter"),
    (dict(factor=lambda v, p: 1.1 + p["bump_height"] * v), "not 1 with the linear"),
    # the rig's and the report's names, the fit's coordinate prefixes, repeats
    (dict(parameters=(OwnParameter("normal_force_N", -1, 1, 0.1),)), "is taken"),
    (dict(parameters=(OwnParameter("time_map_cool", -1, 1, 0.1),)), "starts like"),
    (dict(parameters=(OwnParameter("bump_height", -1, 1, 0.1),
                      OwnParameter("bump_height", -1, 1, 0.1))), "repeat"),
])
def test_a_bad_own_effect_is_refused_with_what_to_change(changes, message):
    with pytest.raises(InputError, match=message):
        register_effect(_effect(**changes))
    assert "bump" not in own_effects.registered() and "viscous" not in own_effects.registered()


def test_a_factor_that_turns_non_positive_is_named():
    effect = register_effect(_effect())
    try:
        with pytest.raises(InputError, match="not a positive finite number"):
            effect.factors(np.array([0.0, 1e-3]), {"bump_height": -1.5})
    finally:
        own_effects.unregister("bump")


def test_a_file_that_fails_half_way_leaves_nothing_registered(tmp_path):
    half = tmp_path / "half.py"
    half.write_text(
        "from vibrofriction.identify.own_effects import LevelEffect, OwnParameter, "
        "register_effect\n"
        "register_effect(LevelEffect('halfway', 'time', (OwnParameter('halfway_a', -1, 1, 0.1),),"
        " lambda t, p: 1 + p['halfway_a'] * t))\n"
        "raise RuntimeError('later')\n")
    for _ in range(2):  # (the second time the same name is free again)
        with pytest.raises(InputError, match="RuntimeError: later"):
            own_effects.load_effects_file(half)
        assert "halfway" not in own_effects.registered()


def test_the_choice_ranks_by_the_test_and_takes_a_candidate_only_the_held_out_records_justify():
    from types import SimpleNamespace

    from vibrofriction.identify.driver import _choose

    def candidate(name, delta_bic, held, ratio):
        return SimpleNamespace(effect=name, delta_bic=delta_bic, held_out_evidence=held,
                               validation_log_ratio=ratio, justified=True)

    # a training dBIC above 0 that the held-out records carry past the threshold
    only_held = candidate("offset", 3.0, -20.0, -0.3)
    assert _choose([only_held])[0] is only_held
    # ranked by the sum the test compares: -17 beats -12
    assert _choose([only_held, candidate("viscous", -12.0, 0.0, -0.05)])[0] is only_held


def test_a_declared_harmonic_without_a_vibration_is_refused():
    from vibrofriction.data.datasets import Dataset
    record = synthetic.generate(replace(synthetic.Scenario(), duration_s=0.02), name="still")
    # a record of a machine whose support does not vibrate: no support motion measured
    record = Dataset(name="still", metadata=record.metadata,
                     columns={k: v for k, v in record.columns.items()
                              if not k.startswith("support_")})
    with pytest.raises(InputError, match="normal_force_modulation_2f: not applicable"):
        identify(record, law="lugre", declared=("normal_force_modulation_2f",))


def test_dropping_an_exclusive_effect_frees_its_partners():
    """The driver: selecting one load-modulation harmonic takes its partners out of the
    candidates; once a backward step drops it, they are candidates again (the dropped one
    not)."""
    from types import SimpleNamespace

    from vibrofriction.identify.driver import select

    class BackEnd:
        round_action = "fitting"

        def __init__(self):
            self.seen = []

        def evaluate_round(self, current, remaining, index):
            self.seen.append(list(remaining))
            winner = {1: "normal_force_modulation", 2: "viscous"}.get(index)
            return [SimpleNamespace(effect=e, delta_bic=-50.0 if e == winner else 5.0,
                                    held_out_evidence=0.0, validation_log_ratio=None,
                                    justified=e == winner, fit=current) for e in remaining]

        def accept(self, best, current, index):
            return best

        def selected_note(self, accepted):
            return ""

        def backward_step(self, current, selected, index, final):
            if index == 2 and "normal_force_modulation" in selected:
                selected.remove("normal_force_modulation")  # no longer justified
            return current

    back_end = BackEnd()
    effects = ["normal_force_modulation", "normal_force_modulation_2f", "viscous", "stribeck"]
    result = select(back_end, start=None, effects=effects, say=lambda line: None)
    assert back_end.seen[1] == ["viscous", "stribeck"]  # the 2f held back in round 2
    assert back_end.seen[2] == ["normal_force_modulation_2f", "stribeck"]  # ... and freed
    assert result.selected == ["viscous"]
