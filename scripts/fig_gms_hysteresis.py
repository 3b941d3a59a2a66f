#!/usr/bin/env python3
"""Presliding hysteresis of the gms law (generalized Maxwell-slip), run by the plugin's own
code (``laws.run_law``): the virgin curve, the branches after reversals (Masing's rule: the
virgin curve doubled) and an inner loop that closes and is wiped out, against the one-state
Dahl law with the same total stiffness, whose inner loop drifts instead of closing.

    .venv/bin/python scripts/fig_gms_hysteresis.py [--out docs/figures]

Writes OUT/gms_hysteresis.png.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from vibrofriction import laws
from vibrofriction.params import FrictionParameters, default_friction

NORMAL_N = 55.2
SPEED_M_PER_S = 1e-3
STEP_M = 2e-9
# relative position (m) the contact is driven through: out, back, an inner loop, out again
PATH_M = (1.0e-6, -1.0e-6, 0.5e-6, 0.1e-6, 0.5e-6, 1.0e-6)


def _history(points_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, times and velocities of a piecewise-constant-speed path through ``points_m``."""
    x = [0.0]
    for target in points_m:
        direction = np.sign(target - x[-1])
        x.extend(np.arange(x[-1], target, direction * STEP_M)[1:].tolist() + [target])
    x = np.array(x)
    dt = np.abs(np.diff(x)) / SPEED_M_PER_S
    t = np.concatenate([[0.0], np.cumsum(dt)])
    v = np.concatenate([[0.0], np.diff(x) / dt])
    return x, t, v


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    args = parser.parse_args(argv)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gms = default_friction("gms")
    dahl = FrictionParameters(law="dahl", friction_coefficient=gms.friction_coefficient,
                              contact_stiffness_N_per_m=sum(gms.gms_stiffness_N_per_m))
    x, t, v = _history(PATH_M)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for friction, label, style in ((gms, "gms, 3 elements", "-"), (dahl, "Dahl, same k_t", "--")):
        force = laws.run_law(friction, t, v, normal_force_N=NORMAL_N).friction_force_N
        ax.plot(x * 1e6, force, style, label=label)
    level = gms.friction_coefficient * NORMAL_N
    ax.axhline(level, color="0.7", lw=0.8)
    ax.axhline(-level, color="0.7", lw=0.8)
    ax.set_xlabel("relative position (um)")
    ax.set_ylabel("friction force (N)")
    ax.set_title("out to 1 um, back to -1 um, inner loop 0.5 -> 0.1 -> 0.5 um, out", fontsize=10)
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "gms_hysteresis.png"
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
