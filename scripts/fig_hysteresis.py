#!/usr/bin/env python3
"""Fig. 10 of Gutowski & Leus (2012): Dahl, F_F against the contact deflection z (and against
the slider's displacement on the support) at v_a = 0.25, 0.75 and 3.0 mm/s."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Fig. 10: runs of Figs. 7-9")
    traces = figures.compute_time_traces(scripts.config(args), log.progress("runs"))
    return scripts.done(figures.fig_hysteresis(traces, args.out))


if __name__ == "__main__":
    sys.exit(main())
