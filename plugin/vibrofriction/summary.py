"""Summary of a rig run: mean drive force over whole vibration periods after the transient."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RunSummary:
    """The summary of one rig run: the mean drive and friction forces over the averaging window
    (whole vibration periods after the transient), the friction force's minimum and maximum
    in it (all in N), whether it changes sign, the window's start and end (s) and the number
    of periods averaged (0 without vibration)."""

    mean_drive_force_N: float
    mean_friction_force_N: float
    friction_min_N: float
    friction_max_N: float
    sign_change: bool
    window_start_s: float
    window_end_s: float
    periods_averaged: int


def averaging_window(t_s: np.ndarray, period_s: float, settle_time_s: float) -> np.ndarray:
    """Boolean mask of the samples in the largest whole number of periods after settle_time_s.

    With no vibration (period_s <= 0) the whole span after settle_time_s is used.
    """
    t_s = np.asarray(t_s, dtype=float)
    t_end = t_s[-1]
    if settle_time_s >= t_end:
        raise ValueError(
            f"settle time {settle_time_s} s is not before the end of the run ({t_end} s); "
            "simulate longer or settle sooner")
    if period_s > 0:
        n_periods = int(np.floor((t_end - settle_time_s) / period_s + 1e-9))
        if n_periods < 1:
            raise ValueError(
                f"fewer than one vibration period ({period_s} s) after settle time "
                f"{settle_time_s} s; simulate longer")
        start = t_end - n_periods * period_s
    else:
        start = settle_time_s
    return t_s >= start - 1e-12


def summarize(t_s, drive_force_N, friction_force_N, period_s: float,
              settle_time_s: float) -> RunSummary:
    """Time-weighted means over whole periods (trapezoid rule), friction extrema, sign change."""
    t_s = np.asarray(t_s, dtype=float)
    fd = np.asarray(drive_force_N, dtype=float)
    ff = np.asarray(friction_force_N, dtype=float)
    mask = averaging_window(t_s, period_s, settle_time_s)
    tw, fdw, ffw = t_s[mask], fd[mask], ff[mask]
    span = tw[-1] - tw[0]
    mean_fd = float(np.trapezoid(fdw, tw) / span) if span > 0 else float(fdw.mean())
    mean_ff = float(np.trapezoid(ffw, tw) / span) if span > 0 else float(ffw.mean())
    fmin, fmax = float(ffw.min()), float(ffw.max())
    periods = int(round(span / period_s)) if period_s > 0 else 0
    return RunSummary(mean_drive_force_N=mean_fd, mean_friction_force_N=mean_ff,
                      friction_min_N=fmin, friction_max_N=fmax,
                      sign_change=bool(fmin < 0 < fmax), window_start_s=float(tw[0]),
                      window_end_s=float(tw[-1]), periods_averaged=periods)
