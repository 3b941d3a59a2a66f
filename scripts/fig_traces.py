#!/usr/bin/env python3
"""Figs. 7-9 of Gutowski & Leus (2012): x_A, v_A, v_d, v_v, v_r and F_F over time, Dahl and
Coulomb, at v_a = 0.25, 0.75 and 3.0 mm/s (f = 4 kHz, v_d = 0.5 mm/s)."""
from __future__ import annotations

import sys

from vibrofriction.study import figures, scripts


def main(argv=None) -> int:
    args = scripts.parse(__doc__, argv)
    log = scripts.log()
    log.stage("Figs. 7-9: time traces")
    figures.fig_time_traces(scripts.config(args), args.out, log.progress("runs"))
    return scripts.done(*(args.out / f"{name}.png"
                          for _, name in figures.TRACE_FIGURE_NAMES.values()))


if __name__ == "__main__":
    sys.exit(main())
