#!/usr/bin/env python3
"""Fig. 14 analogue of Gutowski & Leus (2012): F_d-v/F_d-s against kappa_v for the four laws at
the second experimental configuration (f 2600 Hz, v_d 0.31 mm/s, F_N = p S = 37.2 N, k_t
72 N/um), with the kinematic limits. The measured points are not available."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Fig. 14 analogue")
    figures.fig_experiment_master(scripts.config(args), args.out, log.progress("runs"))
    return scripts.done(args.out / "fig14_experiment_master.png")


if __name__ == "__main__":
    sys.exit(main())
