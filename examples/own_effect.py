"""An effect of one's own, traced like the vocabulary's: a run-in of the friction level.

A fresh contact often starts above its settled friction and falls towards it over a time
constant (run-in, a film that forms). No vocabulary effect has that form; the free-form
``time_map`` can follow it only as a 4-knot spline. Registered here, ``run_in`` is a
candidate of the automatic selection and a ``--with`` name on both identification paths; the
plugin runs it as its time map (the level map in the C++ law), so the fitted model is still
the one MuJoCo simulates.

Run it to make a record with a run-in hidden (the independent scipy reference, no plugin code)
and identify it:

    python examples/own_effect.py

or give this file to the command line with a record of your own:

    vibrofriction identify record.csv --effects-from examples/own_effect.py
"""
from __future__ import annotations

import numpy as np

from vibrofriction.identify.own_effects import LevelEffect, OwnParameter, register_effect

RUN_IN = register_effect(LevelEffect(
    name="run_in",
    over="time",  # the time since the record's first sample (s)
    parameters=(
        # how far the level lies above its settled value at the start (0: no run-in)
        OwnParameter("run_in_excess", -0.5, 2.0, 0.05),
        # how fast it settles (a log parameter: positive, started at its scale)
        OwnParameter("run_in_time_s", 1e-4, 10.0, 0.01, log=True),
    ),
    # the level's factor over the time t (s): 1 when run_in_excess is 0
    factor=lambda t, p: 1.0 + p["run_in_excess"] * np.exp(-t / p["run_in_time_s"]),
    knots=16,  # the plugin's time map runs it through 16 knots over the record
    description="the level starts run_in_excess above its settled value and settles with "
                "time constant run_in_time_s",
))


def main() -> None:
    from dataclasses import replace

    from vibrofriction.data import synthetic
    from vibrofriction.identify import identify

    duration_s = 0.05

    def level(t: float, x: float, v: float) -> float:  # the truth: 15 % above, 8 ms
        return 1.0 + 0.15 * np.exp(-t / 8e-3)

    records = []
    for held_out in (False, True):
        scenario = replace(synthetic.Scenario(), duration_s=duration_s, level_factor=level,
                           seed=2 if held_out else 1)
        if held_out:  # pulled at another speed
            scenario = replace(scenario, rig=replace(scenario.rig, drive_velocity_m_per_s=0.7e-3))
        records.append(synthetic.generate(scenario, name=f"run_in_{int(held_out)}"))
    print("identifying a record whose level runs in (15 % above, 8 ms), nothing declared ...")
    result = identify(records[0], records[1:], law="lugre")
    print("selected:", ", ".join(result.selected) or "nothing")
    for name in ("run_in_excess", "run_in_time_s"):
        if name in result.final.values:
            print(f"{name} = {result.final.values[name]:.4g} "
                  f"+- {result.final.uncertainties.get(name, float('nan')):.2g}")
    print(f"held-out error: {result.baseline.validation[0].relerr_pct:.3g} % -> "
          f"{result.final.validation[0].relerr_pct:.3g} %")


if __name__ == "__main__":
    main()
