#!/usr/bin/env python3
"""Master curves F_d-v/F_d-s against kappa_v = v_a/v_d of the four laws at the paper's
simulation parameters (Gutowski & Leus 2012, section 4), with the kinematic (heavy-body)
limits of each law, the arcsin law and Dahl's vanishing-amplitude limit (docs/physics.md)."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("master curves")
    figures.fig_master_curves(scripts.config(args), args.out, log.progress("runs"))
    return scripts.done(args.out / "master_curves.png")


if __name__ == "__main__":
    sys.exit(main())
