"""What the data cannot tell: whether the record informs each fitted value, and residual
outliers (both identification paths; report.json ``final`` and report.md).

Identifiability of each fitted value of the final model. It is *not informed* when

* its standard error exceeds ``RELATIVE_ERROR_LIMIT`` of its size (the value itself; a phase:
  ``PHASE_ERROR_LIMIT_RAD`` absolute; ``static_ratio``: its excess over 1, the Stribeck peak's
  height), or there is no finite standard error;
* it ended at a bound of its fit's range (``model.Param``), within ``BOUND_TOLERANCE`` of the
  internal coordinate's scale: the data push it to the edge, so the value is the bound, not
  an estimate;
* (laws with bristles) the sample interval does not resolve presliding. The bristles deflect
  by z_c = mu F_N / sigma0 (the friction level over the contact stiffness) before the contact
  slides; at the record's typical sliding speed v (rms of the relative velocity) that takes
  t_pre = z_c / v. A sample interval longer than t_pre sees no presliding transient, only
  the sliding on either side of it: the contact stiffness, and what shapes the transient
  (Dahl's alpha, Dupont's breakaway ratio, the bristle damping), then rest on how the motion
  is interpolated between samples, not on anything measured. The bristle damping acts on a
  time scale sigma1 / sigma0 of its own, which the sample interval must resolve as well.

Law parameters biased by a missing effect: a law parameter of the baseline (the law alone, or
with the declared effects) whose value moves by more than ``MOVED_STANDARD_ERRORS`` of the
final fit's standard error, and by more than ``MOVED_FRACTION`` of its value, once the
selection adds effects. The baseline's value then carried
the effect it lacked (a softer contact standing in for a play, a level standing in for a speed
curve): the final value is the estimate, the baseline's is biased.

Residual outliers of the final fit (measured - predicted, as ``series.py`` writes it), on every
channel the path predicts, of the training record and of each held-out record: a sample that
stands out of its record's residual -- more than ``SHARE_MIN_ROBUST_SD`` robust sd (1.4826
times the median absolute deviation) from its median -- and either carries more than
``OUTLIER_SHARE`` of the record's squared error, or lies beyond ``OUTLIER_ROBUST_SD`` robust
sd with both neighbours within half its own deviation (a single glitch, not a stretch the
model misses). Each is reported with the error its record would have without it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .model import LAW_PARAMETERS, Model
from .series import inverse_series, simulation_series

RELATIVE_ERROR_LIMIT = 0.5
PHASE_ERROR_LIMIT_RAD = 0.5
# A coordinate within this of a bound (times max(1, |bound|)): the internal coordinates are
# scaled to the record's own sizes (model.Scales), so 1e-3 is a thousandth of a typical value
# (a log coordinate: within 0.1 % of its bound).
BOUND_TOLERANCE = 1e-3
OUTLIER_SHARE = 0.10
OUTLIER_ROBUST_SD = 8.0
# Every outlier also stands this far out of the bulk, so the largest sample of a short record
# of white noise (100 samples: about 10 % of the sum of squares) is not taken for a glitch.
SHARE_MIN_ROBUST_SD = 5.0
# A law parameter's move, baseline -> final, that flags it: beyond this many final standard
# errors and this fraction of its value (a refit's own wobble, 1 SE, is not a bias)
MOVED_STANDARD_ERRORS = 3.0
MOVED_FRACTION = 0.01
ISOLATION = 0.5  # a lone glitch's neighbours deviate by less than this fraction of it
MAX_LISTED = 5  # outliers listed per record and channel (the largest shares)
# sd of a normal distribution over its median absolute deviation
MAD_TO_SD = 1.4826

# What shapes the presliding transient (the values a record that does not resolve presliding
# cannot inform); the bristle damping also has its own time scale.
PRESLIDING_VALUES = ("contact_stiffness_N_per_m", "alpha", "breakaway_ratio",
                     "bristle_damping_N_s_per_m", "gms_spread")
# a sine/cosine pair's coordinates: the amplitude they set is what is reported
_SINE_PAIRS = {"ripple_cos": "position_ripple", "ripple_sin": "position_ripple",
               "modulation_cos": "normal_force_modulation",
               "modulation_sin": "normal_force_modulation"}


@dataclass(frozen=True)
class Presliding:
    """The record's sample interval against the fitted contact's presliding time scales."""

    sample_interval_s: float
    typical_sliding_speed_m_per_s: float  # rms of the relative velocity
    deflection_m: float  # z_c = mu F_N / contact stiffness
    presliding_time_s: float  # z_c / typical speed
    bristle_damping_time_s: float | None  # sigma1 / sigma0 (laws with a bristle damping)

    @property
    def resolved(self) -> bool:
        return bool(self.presliding_time_s >= self.sample_interval_s)

    @property
    def damping_resolved(self) -> bool | None:
        if self.bristle_damping_time_s is None:
            return None
        return bool(self.bristle_damping_time_s >= self.sample_interval_s)

    def as_dict(self) -> dict[str, Any]:
        return {"sample_interval_s": _finite(self.sample_interval_s),
                "typical_sliding_speed_m_per_s": _finite(self.typical_sliding_speed_m_per_s),
                "deflection_m": _finite(self.deflection_m),
                "presliding_time_s": _finite(self.presliding_time_s),
                "bristle_damping_time_s": _finite(self.bristle_damping_time_s),
                "resolved": self.resolved, "damping_resolved": self.damping_resolved}

    def presliding_reason(self) -> str:
        return (f"presliding not resolved: the bristles deflect by z_c = {self.deflection_m:.3g} m "
                f"(the level over the contact stiffness), {self.presliding_time_s:.3g} s at the "
                f"typical sliding speed {self.typical_sliding_speed_m_per_s:.3g} m/s, shorter "
                f"than the sample interval {self.sample_interval_s:.3g} s: the value rests on "
                "how the motion is interpolated between samples, not on a measured transient")

    def damping_reason(self) -> str:
        return (f"bristle damping time sigma1/sigma0 = {self.bristle_damping_time_s:.3g} s is "
                f"shorter than the sample interval {self.sample_interval_s:.3g} s")


@dataclass(frozen=True)
class Informed:
    """Whether the record informs one fitted value, and why not."""

    name: str
    informed: bool
    relative_standard_error: float | None
    at_bound: str | None  # "lower", "upper" or None
    reasons: tuple[tuple[str, str], ...] = ()  # (short, full) per reason

    def as_dict(self) -> dict[str, Any]:
        return {"informed": self.informed,
                "relative_standard_error": _finite(self.relative_standard_error),
                "at_bound": self.at_bound,
                "reason": "; ".join(full for _, full in self.reasons) or None}


@dataclass(frozen=True)
class Outlier:
    """One sample that dominates, or stands alone far out of, its record's residual."""

    dataset: str
    channel: str
    held_out: bool
    time_s: float
    residual: float  # measured - predicted (as series_<dataset>.csv), in the channel's unit
    share_of_squared_error: float
    rmse: float  # the record's, in the channel's unit
    relerr_pct: float
    rmse_without: float  # ... with this sample left out
    relerr_pct_without: float

    def as_dict(self) -> dict[str, Any]:
        return {"dataset": self.dataset, "channel": self.channel, "held_out": self.held_out,
                "time_s": self.time_s, "residual": _finite(self.residual),
                "share_of_squared_error": _finite(self.share_of_squared_error),
                "rmse": _finite(self.rmse), "relerr_pct": _finite(self.relerr_pct),
                "rmse_without": _finite(self.rmse_without),
                "relerr_pct_without": _finite(self.relerr_pct_without)}


@dataclass(frozen=True)
class Moved:
    """A law parameter that moved, from the baseline to the final fit, by more than its
    standard error once the selected effects were added."""

    name: str
    baseline: float
    final: float
    standard_error: float
    effects: tuple[str, ...]  # the effects the selection added

    @property
    def standard_errors(self) -> float:
        return abs(self.final - self.baseline) / self.standard_error

    def as_dict(self) -> dict[str, Any]:
        return {"baseline": _finite(self.baseline), "final": _finite(self.final),
                "standard_error": _finite(self.standard_error),
                "moved_standard_errors": _finite(self.standard_errors),
                "effects": list(self.effects)}


def moved_parameters(law: str, baseline: Mapping[str, float], final: Mapping[str, float],
                     errors: Mapping[str, float | None], selected) -> list[Moved]:
    """The law parameters the selected effects moved by more than their standard error."""
    if not selected:
        return []
    out = []
    for name in LAW_PARAMETERS.get(law, ()):
        se = errors.get(name)
        if name not in baseline or name not in final or se is None or not se > 0:
            continue
        moved = Moved(name, float(baseline[name]), float(final[name]), float(se),
                      tuple(selected))
        if moved.standard_errors > MOVED_STANDARD_ERRORS and \
                abs(moved.final - moved.baseline) > MOVED_FRACTION * abs(moved.final):
            out.append(moved)
    return out


@dataclass(frozen=True)
class Diagnostics:
    """What report.json's ``final`` block and report.md say about the final fit."""

    law: str
    identifiability: dict[str, Informed]
    presliding: Presliding | None
    outliers: list[Outlier]
    level_in_N: bool  # no normal force given: friction_coefficient is the friction level in N
    moved: list[Moved] = field(default_factory=list)  # biased in the baseline

    def as_json(self) -> dict[str, Any]:
        """The keys added to report.json's ``final`` block (docs/interfaces.md)."""
        return {"identifiability": {k: v.as_dict() for k, v in self.identifiability.items()},
                "biased_in_baseline": {m.name: m.as_dict() for m in self.moved},
                "presliding": self.presliding.as_dict() if self.presliding else None,
                "residual_outliers": [o.as_dict() for o in self.outliers],
                "friction_coefficient_unit": "N" if self.level_in_N else "1"}

    # ---------------------------------------------------------------------------- markdown

    def label(self, name: str) -> str:
        """A parameter's name in report.md's tables (the friction level's unit said)."""
        return name + self.unit_note(name)

    def unit_note(self, name: str) -> str:
        """" (friction level, N)" after friction_coefficient when no normal force is given."""
        return " (friction level, N)" if name == "friction_coefficient" and self.level_in_N \
            else ""

    def flag(self, name: str) -> str:
        """The parameter table's 'informed' cell: yes, or no and the short reasons."""
        entry = self.identifiability.get(name)
        if entry is None:
            return ""
        if entry.informed:
            return "yes"
        return "**no**: " + ", ".join(short for short, _ in entry.reasons)

    def parameter_notes(self) -> list[str]:
        """The legend of the 'informed' column, the unit of a level, and presliding."""
        lines = ["", "Informed: **no** where the standard error exceeds "
                 f"{RELATIVE_ERROR_LIMIT:g} of the value (a phase: {PHASE_ERROR_LIMIT_RAD:g} "
                 "rad; static_ratio: of its excess over 1) or none could be computed, where "
                 "the value ended at a bound of its fitted range, or (laws with bristles) "
                 "where the sample interval does not resolve presliding; report.json: "
                 "`final.identifiability`."]
        if self.level_in_N:
            lines += ["", "No normal force was given (F_N = 1 N): `friction_coefficient` is "
                      "the friction level in N, not a coefficient."]
        if self.moved:
            moves = ", ".join(f"`{m.name}` {m.baseline:.4g} -> {m.final:.4g} "
                              f"({m.standard_errors:.1f} standard errors)" for m in self.moved)
            lines += ["", f"**Biased without {', '.join(self.moved[0].effects)}:** {moves}. "
                      "The law alone took up what the added effects explain; quote the final "
                      "values (report.json: `final.biased_in_baseline`)."]
        p = self.presliding
        if p is not None and not (p.resolved and p.damping_resolved is not False):
            lost = [n for n, e in self.identifiability.items()
                    if any(short.startswith(("presliding", "damping time"))
                           for short, _ in e.reasons)]
            lines += [""]
            if not p.resolved:
                lines.append(
                    f"**Presliding is not resolved on this record.** The bristles deflect by "
                    f"z_c = {p.deflection_m:.3g} m before the contact slides, "
                    f"{p.presliding_time_s:.3g} s at the typical sliding speed "
                    f"{p.typical_sliding_speed_m_per_s:.3g} m/s (rms), shorter than the sample "
                    f"interval {p.sample_interval_s:.3g} s: the record does not inform "
                    f"{', '.join(lost)}. A rigid law (coulomb) is the honest model for it"
                    + (" (not fitted here: `--law coulomb`)." if self.law != "coulomb" else "."))
            else:
                lines.append(
                    f"The bristle damping's time scale sigma1/sigma0 = "
                    f"{p.bristle_damping_time_s:.3g} s is shorter than the sample interval "
                    f"{p.sample_interval_s:.3g} s: the record does not inform "
                    "bristle_damping_N_s_per_m.")
        return lines

    def outlier_lines(self, unit_of: Mapping[str, str] | None = None) -> list[str]:
        """Lines under the error table: each outlier, where, and the error without it."""
        units = unit_of or {}
        if not self.outliers:
            return [f"Residual outliers: none (no sample carries over {100 * OUTLIER_SHARE:g} "
                    f"% of a record's squared error or stands alone beyond "
                    f"{OUTLIER_ROBUST_SD:g} robust sd).", ""]
        lines = []
        for o in self.outliers:
            unit = units.get(o.channel, "")
            lines.append(
                f"- **Residual outlier**: {'held-out' if o.held_out else 'training'} "
                f"`{o.dataset}`, {o.channel} at t = {o.time_s:.6g} s: residual "
                f"{o.residual:+.3g} {unit}, {100 * o.share_of_squared_error:.3g} % of that "
                f"record's squared error; without it the RMSE would be {o.rmse_without:.4g} "
                f"{unit} (relerr {o.relerr_pct_without:.3g} %) instead of {o.rmse:.4g} {unit} "
                f"({o.relerr_pct:.3g} %).")
        return lines + [""]


# ------------------------------------------------------------------------------- the checks

def presliding(law: str, values: Mapping[str, float], normal_force_N: float,
               sample_interval_s: float, relative_velocity_m_per_s: np.ndarray
               ) -> Presliding | None:
    """The presliding time scales of a fitted law with bristles (None: a rigid law)."""
    stiffness = values.get("contact_stiffness_N_per_m")
    if law == "coulomb" or not stiffness or stiffness <= 0:
        return None
    level = values.get("friction_coefficient", 0.0) * normal_force_N
    speed = float(np.sqrt(np.mean(np.square(relative_velocity_m_per_s))))
    deflection = level / stiffness
    damping = values.get("bristle_damping_N_s_per_m")
    return Presliding(sample_interval_s=sample_interval_s,
                      typical_sliding_speed_m_per_s=speed, deflection_m=deflection,
                      presliding_time_s=deflection / speed if speed > 0 else math.inf,
                      bristle_damping_time_s=None if damping is None else damping / stiffness)


def bound_sides(model: Model, q: np.ndarray) -> dict[str, str]:
    """Fitted value -> "lower"/"upper" where its internal coordinate ended at a bound."""
    from .fit import value_name
    out: dict[str, str] = {}
    lo, hi = model.bounds()
    for p, x, a, b in zip(model.params, np.asarray(q, dtype=float), lo, hi):
        name = _SINE_PAIRS.get(p.name, value_name(p.name))
        if x - a <= BOUND_TOLERANCE * max(1.0, abs(a)):
            out[name] = "lower"
        elif b - x <= BOUND_TOLERANCE * max(1.0, abs(b)):
            out[name] = "upper"
    return out


def identifiability(values: Mapping[str, float], errors: Mapping[str, float | None],
                    bounds: Mapping[str, str], scales: Presliding | None
                    ) -> dict[str, Informed]:
    """Whether the record informs each fitted value (module docstring)."""
    out = {}
    for name, value in values.items():
        reasons: list[tuple[str, str]] = []
        error = errors.get(name)
        relative = None
        if name not in errors:
            reasons.append(("no standard error", "no standard error computed for it"))
        elif error is None or not math.isfinite(error):
            reasons.append(("no standard error", "no finite standard error: the fit's "
                            "information matrix is singular in it"))
        elif name.endswith("_phase_rad"):
            if error > PHASE_ERROR_LIMIT_RAD:
                reasons.append((f"standard error {error:.2g} rad",
                                f"standard error {error:.3g} rad, above "
                                f"{PHASE_ERROR_LIMIT_RAD:g} rad"))
        else:
            peak = name == "static_ratio"
            size = abs(value - 1.0) if peak else abs(value)
            if size == 0:
                reasons.append(("value exactly 0" if not peak else "no peak",
                                "the value is exactly " + ("1 (no peak)" if peak else "0")))
            else:
                relative = error / size
                if relative > RELATIVE_ERROR_LIMIT:
                    what = "its excess over 1 (the peak's height)" if peak else "the value"
                    times = f"{relative:.2g}x" if relative < 1e3 else "over 1000x"
                    reasons.append((f"standard error {times} {'the excess' if peak else 'it'}",
                                    f"standard error {error:.3g} is {relative:.3g} times "
                                    f"{what} (limit {RELATIVE_ERROR_LIMIT:g}): the record "
                                    f"does not tell it from {'1' if peak else '0'}"))
        side = bounds.get(name)
        if side is not None:
            reasons.append((f"at its {side} bound", f"ended at the {side} bound of its fitted "
                            "range: the value is the bound, not an estimate"))
        if scales is not None and name in PRESLIDING_VALUES and not scales.resolved:
            reasons.append(("presliding not resolved", scales.presliding_reason()))
        if scales is not None and name == "bristle_damping_N_s_per_m" and \
                scales.damping_resolved is False:
            reasons.append(("damping time unresolved", scales.damping_reason()))
        out[name] = Informed(name=name, informed=not reasons,
                             relative_standard_error=relative, at_bound=side,
                             reasons=tuple(reasons))
    return out


def residual_outliers(dataset: str, channel: str, held_out: bool, time_s: np.ndarray,
                      measured: np.ndarray, predicted: np.ndarray) -> list[Outlier]:
    """The samples of one record's residual (measured - predicted) that dominate it or stand
    alone far out of it (module docstring), the largest shares first, at most
    ``MAX_LISTED``."""
    y = np.asarray(measured, dtype=float)
    r = y - np.asarray(predicted, dtype=float)
    n = len(r)
    sse = float(r @ r)
    if n < 3 or not sse > 0 or not math.isfinite(sse):
        return []
    deviation = np.abs(r - np.median(r))
    robust_sd = MAD_TO_SD * float(np.median(deviation))
    share = r ** 2 / sse
    dominant = share > OUTLIER_SHARE
    if robust_sd > 0:  # (more than half the residual exactly at its median: no robust scale)
        neighbours = np.maximum(np.concatenate([[0.0], deviation[:-1]]),
                                np.concatenate([deviation[1:], [0.0]]))
        dominant |= (deviation > OUTLIER_ROBUST_SD * robust_sd) & \
            (neighbours < ISOLATION * deviation)
    picked = np.flatnonzero(dominant & (deviation > SHARE_MIN_ROBUST_SD * robust_sd))
    picked = picked[np.argsort(-share[picked], kind="stable")][:MAX_LISTED]
    yy = float(y @ y)
    rmse = math.sqrt(sse / n)
    relerr = 100.0 * math.sqrt(sse / yy) if yy > 0 else math.inf
    out = []
    for i in picked.tolist():
        rest, rest_y = max(sse - r[i] ** 2, 0.0), max(yy - y[i] ** 2, 0.0)
        out.append(Outlier(dataset=dataset, channel=channel, held_out=held_out,
                           time_s=float(time_s[i]), residual=float(r[i]),
                           share_of_squared_error=float(share[i]), rmse=rmse,
                           relerr_pct=relerr, rmse_without=math.sqrt(rest / (n - 1)),
                           relerr_pct_without=100.0 * math.sqrt(rest / rest_y)
                           if rest_y > 0 else math.inf))
    return out


def series_outliers(series) -> list[Outlier]:
    """Residual outliers of every channel of every record's ``series.Series`` (the final
    model's prediction, as report.json's errors and the series files hold it)."""
    out: list[Outlier] = []
    for s in series:
        for channel, (measured, predicted) in s.channels.items():
            out += residual_outliers(s.dataset, channel, s.role != "train", s.time_s,
                                     measured, predicted)
    return out


# --------------------------------------------------------------------------------- the paths

def inverse_diagnostics(result) -> Diagnostics:
    """Diagnostics of an inverse-path ``selection.Identification``'s final fit (each record's
    prediction recomputed as its errors were: one run of the law, no simulation)."""
    fit, record = result.final, result.train
    normal = float(np.median(record.normal_force_N))
    dt = float(np.median(np.diff(record.time_s)))
    scales = presliding(result.law, fit.values, normal, dt, record.relative_velocity_m_per_s)
    informed = identifiability(fit.values, fit.uncertainties, bound_sides(fit.model, fit.q),
                               scales)
    outliers = series_outliers(inverse_series(result))
    moved = moved_parameters(result.law, result.baseline.values, fit.values, fit.uncertainties,
                             [e for e in result.selected])
    return Diagnostics(law=result.law, identifiability=informed, presliding=scales,
                       outliers=outliers, level_in_N=not record.normal_force_known, moved=moved)


def simulation_diagnostics(result) -> Diagnostics:
    """Diagnostics of a simulation-path ``simulation.SimIdentification``'s final fit (the
    outputs its fit keeps from the simulations its errors came from: none run here)."""
    fit, replay = result.final, result.train
    dt = float(np.median(np.diff(replay.time_s)))
    # (the typical sliding speed from the simulated relative motion: a record may measure
    # only the position, or no relative velocity at all)
    speed = fit.predicted.get("relative_velocity_m_per_s")
    scales = None if speed is None else \
        presliding(result.law, fit.values, replay.rig.normal_force_N, dt, speed)
    informed = identifiability(fit.values, result.standard_errors,
                               bound_sides(fit.model, fit.q), scales)
    outliers = series_outliers(simulation_series(result))
    level_in_N = not replay.normal_force_known and \
        not getattr(replay, "normal_force_from_record", False)
    moved = moved_parameters(result.law, result.baseline.values, fit.values,
                             result.standard_errors, list(result.selected))
    return Diagnostics(law=result.law, identifiability=informed, presliding=scales,
                       outliers=outliers, level_in_N=level_in_N, moved=moved)


def _finite(value: float | None) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


__all__ = ["Diagnostics", "Informed", "Moved", "Outlier", "Presliding", "identifiability",
           "moved_parameters",
           "presliding", "residual_outliers", "series_outliers", "bound_sides",
           "inverse_diagnostics", "simulation_diagnostics", "RELATIVE_ERROR_LIMIT",
           "BOUND_TOLERANCE", "OUTLIER_SHARE", "OUTLIER_ROBUST_SD"]
