#!/usr/bin/env python3
"""Fig. 11 of Gutowski & Leus (2012): F_F profiles, Dahl at v_a = 0.60, 0.75, 1.0, 1.75 and
8.0 mm/s and Coulomb at 8.0 mm/s (f = 4 kHz, v_d = 0.5 mm/s, k_t = 80 N/um)."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Fig. 11: F_F profiles")
    figures.fig_profiles(scripts.config(args), args.out, log.progress("runs"))
    return scripts.done(args.out / "fig11_profiles.png")


if __name__ == "__main__":
    sys.exit(main())
