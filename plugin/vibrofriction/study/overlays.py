"""Analytic and kinematic overlays of the master curves (docs/physics.md, "Closed-form anchors").

The kinematic limit of every law -- the body moving exactly at v_d over the vibrating support --
comes from the plugin's own law code (``laws.kinematic_mean_ratio``); closed forms (arcsin law,
Dahl at vanishing amplitude) come from ``vibrofriction.oracle.analytic``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .. import laws
from ..params import FrictionParameters, RigParameters

try:  # analytic.py is written alongside this study
    from ..oracle import analytic as _analytic
except ImportError:  # pragma: no cover - depends on the checkout
    _analytic = None


def kinematic_ratios(friction: FrictionParameters, rig: RigParameters,
                     kappas: Sequence[float], *, periods: int = 200,
                     samples_per_period: int = 2000) -> np.ndarray:
    """F_mean/(mu F_N) of the heavy-body (kinematic) limit at each kappa_v = v_a/v_d."""
    out = []
    for kappa in kappas:
        if kappa <= 1.0:
            # v_r = v_d - v_a cos(wt) never reverses: steady sliding, F = mu F_N exactly.
            out.append(1.0)
            continue
        out.append(laws.kinematic_mean_ratio(
            friction, drive_velocity_m_per_s=rig.drive_velocity_m_per_s,
            vibration_velocity_amplitude_m_per_s=kappa * rig.drive_velocity_m_per_s,
            vibration_frequency_Hz=rig.vibration_frequency_Hz,
            normal_force_N=rig.normal_force_N, periods=periods,
            samples_per_period=samples_per_period))
    return np.asarray(out)


def have_analytic() -> bool:
    """Whether ``vibrofriction.oracle.analytic`` is importable (the closed-form overlays need
    it)."""
    return _analytic is not None


def arcsin_ratios(kappas: Sequence[float]) -> np.ndarray | None:
    """Rigid Coulomb, kinematic: (2/pi) arcsin(1/kappa) for kappa > 1, else 1; None if
    ``vibrofriction.oracle.analytic`` is not available."""
    if _analytic is None:  # pragma: no cover - analytic.py ships with the package
        return None
    xi = 1.0 / np.asarray(kappas, dtype=float)
    return np.asarray(_analytic.coulomb_kinematic_ratio(xi), dtype=float)


def dahl_vanishing_amplitude_ratios(kappas: Sequence[float], alpha: float) -> np.ndarray | None:
    """Dahl for u0 -> 0 (tanh(ln(P/N)/(2 alpha)), docs/physics.md); None if analytic.py is
    missing."""
    if _analytic is None:  # pragma: no cover - analytic.py ships with the package
        return None
    xi = 1.0 / np.asarray(kappas, dtype=float)
    return np.asarray(_analytic.dahl_vanishing_amplitude_ratio(xi, alpha), dtype=float)
