#!/usr/bin/env python3
"""Fig. 12 of Gutowski & Leus (2012): influence of the contact stiffness k_t on (a) the F_F
profile at v_a = 0.75 mm/s and (b) F_d-v/F_d-s against kappa_v (Dahl)."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Fig. 12: k_t influence")
    figures.fig_stiffness(scripts.config(args), args.out, log.progress("k_t values"))
    return scripts.done(args.out / "fig12_stiffness.png")


if __name__ == "__main__":
    sys.exit(main())
