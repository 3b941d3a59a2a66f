#!/usr/bin/env python3
"""Fig. 13 analogue of Gutowski & Leus (2012): F_F over time for Coulomb, Dahl, Dupont and
LuGre at the first experimental configuration (f 3900 Hz, v_d 0.62 mm/s, F_N = p S = 67.2 N,
k_t 78 N/um, v_a 1.76 and 3.44 mm/s). The measured curves are not available."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Fig. 13 analogue")
    figures.fig_experiment_traces(scripts.config(args), args.out, log.progress("runs"))
    return scripts.done(args.out / "fig13_experiment_traces.png")


if __name__ == "__main__":
    sys.exit(main())
