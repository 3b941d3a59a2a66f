"""Least-squares fits of a model to the training record, with uncertainties and metrics."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from .analysis import effective_samples
from .model import Model
from .record import Record

# Relative tolerances of least_squares: a relative change of 1e-8 in the cost moves the
# criterion by n_eff * 1e-8, far below one BIC unit for any record identify handles.
_TOL = 1e-8


@dataclass(frozen=True)
class Metrics:
    """One record's error: RMSE (N) and relative error 100 ||y - y_hat|| / ||y|| (%)."""

    dataset: str
    rmse_N: float
    relerr_pct: float

    def as_dict(self, with_name: bool) -> dict:
        out = {"rmse_N": self.rmse_N, "relerr_pct": self.relerr_pct}
        return {"dataset": self.dataset, **out} if with_name else out


@dataclass(frozen=True, eq=False)
class FitResult:
    """An inverse fit: the model, its parameter vector and physical values, the training
    residual (N), its RSS and effective sample count, the values' standard errors, the error on
    each record, the evaluations it took and the values at a bound."""

    model: Model
    q: np.ndarray
    values: dict[str, float]
    residual: np.ndarray  # prediction - measurement on the training record (after low-pass)
    rss: float
    n_eff: float
    uncertainties: dict[str, float]
    train: Metrics
    validation: list[Metrics]
    nfev: int
    notes: list[str] = field(default_factory=list)
    at_bound: tuple[str, ...] = ()  # fitted values that ended on a bound of their range

    @property
    def n(self) -> int:
        return len(self.residual)

    @property
    def k(self) -> int:
        return self.model.k


class Problem:
    """The training record, the held-out records and the fitted-mass bookkeeping."""

    def __init__(self, train: Record, validation: Sequence[Record]):
        self.train = train
        self.validation = list(validation)
        self.measured = train.lowpass(train.target_N)
        self.validation_measured = [r.lowpass(r.target_N) for r in self.validation]

    def residual(self, model: Model, q: np.ndarray) -> np.ndarray:
        return self.train.lowpass(model.predict(self.train, q)) - self.measured

    def metrics(self, model: Model, values: Mapping[str, float]) -> tuple[Metrics, list[Metrics]]:
        train, held = self.predicted(model, values)
        return (record_metrics(self.train.name, train, self.measured),
                [record_metrics(record.name, predicted, measured) for record, predicted, measured
                 in zip(self.validation, held, self.validation_measured)])

    def predicted(self, model: Model, values: Mapping[str, float]
                  ) -> tuple[np.ndarray, list[np.ndarray]]:
        """The predicted measured force (after the record's low-pass) on the training record
        and on each held-out record, as ``metrics`` compares it with the measured one."""
        train = self.train.lowpass(model.predict_values(self.train, values))
        held = []
        for record in self.validation:
            mass = record.mass_kg if record.mass_kg is not None else self.train.mass_kg
            held.append(record.lowpass(model.predict_values(record, values, mass_kg=mass)))
        return train, held

    def fit(self, model: Model, start: Mapping[str, float], *, max_nfev: int | None = None,
            notes: Sequence[str] = ()) -> FitResult:
        """Least squares from ``start`` (named internal values)."""
        q0 = model.internal(start)
        lo, hi = model.bounds()
        result = least_squares(lambda q: self.residual(model, q), q0, bounds=(lo, hi),
                               method="trf", x_scale="jac", ftol=_TOL, xtol=_TOL, gtol=_TOL,
                               max_nfev=max_nfev or 40 * (model.k + 1))
        return self.result(model, result.x, result.fun, result.jac, result.nfev, notes)

    def result(self, model: Model, q: np.ndarray, residual: np.ndarray,
               jac: np.ndarray | None, nfev: int = 0, notes: Sequence[str] = ()) -> FitResult:
        values = model.values(q)
        rss = float(residual @ residual)
        n_eff = effective_samples(residual)
        uncertainties = _uncertainties(model, q, jac, rss, len(residual), n_eff)
        train, held = self.metrics(model, values)
        lo, hi = model.bounds()
        at_bound = tuple(value_name(p.name) for p, x, a, b in zip(model.params, q, lo, hi)
                         if min(x - a, b - x) <= 1e-6 * max(1.0, abs(x))
                         and value_name(p.name) in values)
        return FitResult(model=model, q=np.array(q), values=values, residual=residual, rss=rss,
                         n_eff=n_eff, uncertainties=uncertainties, train=train,
                         validation=held, nfev=nfev, notes=list(notes), at_bound=at_bound)


def value_name(internal: str) -> str:
    """The reported value an internal coordinate moves (a map's free factor c_i: factor_i)."""
    for prefix in ("position_map_c", "velocity_map_c", "time_map_c"):
        if internal.startswith(prefix):
            return f"{prefix[:-1]}factor_{internal[len(prefix):]}"
    return internal


def record_metrics(name: str, predicted: np.ndarray, measured: np.ndarray) -> Metrics:
    """The error of ``predicted`` against ``measured`` (N) on the record ``name``."""
    error = predicted - measured
    norm = float(np.linalg.norm(measured))
    return Metrics(dataset=name, rmse_N=float(np.sqrt(np.mean(error ** 2))),
                   relerr_pct=100.0 * float(np.linalg.norm(error)) / norm if norm > 0 else math.inf)


def _uncertainties(model: Model, q: np.ndarray, jac: np.ndarray | None, rss: float, n: int,
                   n_eff: float) -> dict[str, float]:
    """1-sigma of each physical value from the Jacobian at the optimum.

    cov(q) = s^2 (J^T J)^-1 with s^2 = RSS/(n - k), inflated by n/n_eff because the residual
    is autocorrelated (n_eff independent samples); propagated to the physical values with the
    derivative of q -> values (delta method).
    """
    if jac is None or n <= model.k:
        return {}
    s2 = rss / (n - model.k)
    jtj = jac.T @ jac
    cov_q = np.linalg.pinv(jtj) * s2 * (n / max(n_eff, 1.0))
    names = list(model.values(q))
    base = np.array([model.values(q)[k] for k in names])
    grad = np.empty((len(names), len(q)))
    for j in range(len(q)):
        step = 1e-7 * max(1.0, abs(q[j]))
        dq = np.array(q, dtype=float)
        dq[j] += step
        shifted = model.values(dq)
        grad[:, j] = (np.array([shifted[k] for k in names]) - base) / step
    cov = grad @ cov_q @ grad.T
    return {k: float(math.sqrt(max(cov[i, i], 0.0))) for i, k in enumerate(names)}


__all__ = ["Metrics", "FitResult", "Problem"]
