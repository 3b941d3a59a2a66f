"""Hidden effects in position-only lab records of the scipy reference, identified by simulation.

For each of the 8 vocabulary effects hidden alone, a clean record and a clean record with a tone
outside the vocabulary (`vibrofriction.synthetic.lab_scenario`: time, drive force, slider
position, support velocity at 100 kHz with sensor noise; 20 ms still, 30 ms vibrating at 4 kHz),
identify with LuGre, nothing declared, and print a Markdown table: what was selected, the
effect's fitted values against the truth, the residual peaks, and the time taken.

    python scripts/check_hidden_effects.py [--effects viscous,stribeck,...]
"""
from __future__ import annotations

import argparse
import sys
import time

from vibrofriction import synthetic
from vibrofriction.identify.model import EFFECT_FIELDS, EFFECTS
from vibrofriction.identify.simulation import identify_by_simulation

TONE = synthetic.PeriodicDisturbance(frequency_Hz=1234.0, amplitude_N=0.2, phase_rad=0.3)
CASES = ["clean", *EFFECTS, "tone"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--effects", default=",".join(CASES),
                        help=f"comma-separated cases (default all: {','.join(CASES)})")
    args = parser.parse_args(argv)
    cases = [c for c in args.effects.split(",") if c]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {', '.join(unknown)}; use: {', '.join(CASES)}")
    print("| hidden | selected | fitted (truth) | residual peaks (Hz) | seconds |")
    print("|---|---|---|---|---|")
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
        print(f"| {label} | {', '.join(result.selected) or 'nothing'} | "
              f"{'; '.join(values) or '-'} | {peaks} | {seconds:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
