"""Hidden effects in position-only lab records of the scipy reference, identified by simulation.

For each of the 8 vocabulary effects hidden alone, a clean record and a clean record with a tone
outside the vocabulary (`vibrofriction.data.synthetic.lab_scenario`: time, drive force, slider
position, support velocity at 100 kHz with sensor noise; 20 ms still, 30 ms vibrating at 4 kHz),
identify with LuGre, nothing declared, and print a Markdown table: what was selected, the
effect's fitted values against the truth, the residual peaks, and the time taken. Exits 1 when
a case misses what `tests/test_identify_hidden.py` asks (the effect the one selection, its
values within 5 %; the clean and tone records select nothing, the tone in the residual peaks):
this script is the full matrix of that test (whose default run checks three cases).

    python scripts/check_hidden_effects.py [--effects viscous,stribeck,...]
"""
from __future__ import annotations

import argparse
import math
import sys
import time

from vibrofriction.data import synthetic
from vibrofriction.identify.model import EFFECT_FIELDS, EFFECTS
from vibrofriction.identify.simulation import identify_by_simulation

TONE = synthetic.PeriodicDisturbance(frequency_Hz=1234.0, amplitude_N=0.2, phase_rad=0.3)
CASES = ["clean", *EFFECTS, "tone"]
VALUE_TOLERANCE = 0.05  # relative, each effect value (the modulation's phase is weakly seen)
CHECKED = {"stribeck": ("static_ratio", "stribeck_velocity_m_per_s"),
           "position_ripple": ("position_ripple", "position_ripple_wavelength_m")}


def misses(case: str, scenario, result) -> list[str]:
    """What a case misses of the test's criteria (empty: it passes)."""
    effect = case if case in EFFECTS else None
    out = []
    if result.train.channels != ("position_m", "drive_force_N"):
        out.append(f"channels {result.train.channels}")
    if result.selected != ([effect] if effect else []):
        out.append(f"selected {result.selected or 'nothing'}")
    for name in CHECKED.get(effect, EFFECT_FIELDS.get(effect, ())[:1]):
        owner = scenario.rig if hasattr(scenario.rig, name) else scenario.friction
        truth, fitted = getattr(owner, name), result.final.values.get(name)
        if fitted is None or not abs(fitted - truth) <= VALUE_TOLERANCE * abs(truth):
            out.append(f"{name} {fitted} (truth {truth:.4g})")
    phase = result.final.values.get("position_ripple_phase_rad")
    if effect == "position_ripple" and phase is not None:  # (a missing ripple: said above)
        error = math.remainder(phase - scenario.friction.position_ripple_phase_rad, 2 * math.pi)
        if not abs(error) < 0.1:
            out.append(f"ripple phase off by {error:.3g} rad")
    if case == "clean":
        truth = scenario.friction.friction_coefficient
        fitted = result.final.values["friction_coefficient"]
        if not abs(fitted - truth) <= 0.01 * truth:
            out.append(f"friction_coefficient {fitted:.4g} (truth {truth:.4g}, 1 %)")
    if case == "tone" and not any(abs(f - TONE.frequency_Hz) < 0.02 * TONE.frequency_Hz
                                  for f in result.residual_peaks_Hz):
        out.append(f"no residual peak near {TONE.frequency_Hz:g} Hz")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--effects", default=",".join(CASES),
                        help=f"comma-separated cases (default all: {','.join(CASES)})")
    args = parser.parse_args(argv)
    cases = [c for c in args.effects.split(",") if c]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {', '.join(unknown)}; use: {', '.join(CASES)}")
    print("| hidden | selected | fitted (truth) | residual peaks (Hz) | seconds | check |")
    print("|---|---|---|---|---|---|")
    failed = []
    for case in cases:
        effect = case if case in EFFECTS else None
        scenario = synthetic.lab_scenario(effect, TONE if case == "tone" else None)
        record = synthetic.lab_record(scenario, name=case)
        started = time.monotonic()
        result = identify_by_simulation(record, law="lugre")
        seconds = time.monotonic() - started
        values = []
        for name in EFFECT_FIELDS.get(effect, ()):
            owner = scenario.rig if hasattr(scenario.rig, name) else scenario.friction
            fitted = result.final.values.get(name)
            if fitted is not None:
                values.append(f"{name} {fitted:.4g} ({getattr(owner, name):.4g})")
        label = case if case != "tone" else f"tone {TONE.frequency_Hz:g} Hz, {TONE.amplitude_N:g} N"
        peaks = ", ".join(f"{f:.0f}" for f in result.residual_peaks_Hz[:4]) or "-"
        missed = misses(case, scenario, result)
        failed += [case] if missed else []
        print(f"| {label} | {', '.join(result.selected) or 'nothing'} | "
              f"{'; '.join(values) or '-'} | {peaks} | {seconds:.0f} | "
              f"{'MISSED: ' + '; '.join(missed) if missed else 'ok'} |", flush=True)
    if failed:
        print(f"missed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
