"""Baseline fit, residual tracing and forward selection of effects.

Criterion (documented in docs/identification.md). A candidate effect E extends the current
model M; both are fitted by least squares on the training record. E is *justified* when

1. BIC with the effective sample size improves clearly:
   dBIC = n_eff ln(RSS_E / RSS_M) + (k_E - k_M) ln(n_eff) < ``BIC_THRESHOLD`` (-10: "very
   strong" evidence on the Kass & Raftery scale). n_eff = n / tau comes from the candidate's
   residual autocorrelation, so structured (coloured) residuals of real data count for fewer
   independent samples than white noise;
2. the training RMSE falls by at least ``MIN_IMPROVEMENT`` (2 %): an effect that changes the
   error by less is not worth a model term, however significant;
3. with held-out records: their RMSE falls on average (mean log ratio < 0);
4. for the periodic effects (position ripple, normal-force modulation): the effect explains the
   residual clearly better (the same dBIC test) than an additive tone at the dominant frequency
   of the effect's own contribution -- otherwise a disturbance outside the vocabulary could be
   mistaken for it.

Forward selection (``driver.select``, the simulation path's too): every applicable candidate is
fitted; the justified one with the lowest dBIC joins the model; repeat until none is justified.
Nothing is selected when nothing is justified.
"""
from __future__ import annotations

import math
import time
from concurrent.futures import Executor, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

from .. import sim
from ..data.datasets import Dataset
from ..errors import InputError
from ..params import FrictionParameters
from ..vocabulary import TERMS_BY_NAME
from .analysis import ResidualAnalysis, analyse
from .driver import held_out_evidence, select
from .fit import FitResult, Problem
from .model import (IDENTIFIABLE_LAWS, INVERSE_EFFECTS, MODULATION_HARMONICS, RIG_EFFECTS,
                    Model, Scales, effect_internals, excluded_by, exclusive_groups,
                    inverse_effects, modulation_not_applicable, without_declared)
from . import own_effects
from .record import Record, prepare
from .replay import MIN_SAMPLES

BIC_THRESHOLD = -10.0
MIN_IMPROVEMENT = 0.02
CANDIDATE_EVALUATIONS_PER_PARAMETER = 20
# Contact stiffness scan of the baseline start: characteristic deflection mu F_N / k_t over
# this range of fractions of the record's travel.
_DEFLECTION_SCAN = np.logspace(-6, 0, 25)
_STRIBECK_SCAN = np.logspace(-2, 0.5, 11)  # v_s / rms(v_r)
_PLAY_SCAN = np.logspace(-3, math.log10(0.5), 13)  # play width / the record's travel
_PLAY_STIFFNESS_SCAN = (1.0, 3.0, 10.0, 30.0, 100.0)  # contact stiffness / the fit without play
_PLAY_LAWS = TERMS_BY_NAME["contact_play_m"].laws  # the laws with bristles

ProgressFn = Callable[[str], None]


@dataclass(frozen=True, eq=False)
class Candidate:
    """One effect's evaluation in a round of the inverse path: its fit, dBIC and the other
    tests' numbers, the verdict and why."""

    effect: str
    fit: FitResult
    delta_bic: float
    train_drop: float  # relative RMSE reduction on the training record
    validation_log_ratio: float | None  # mean ln(RMSE_E / RMSE_M) over held-out records
    tone_delta_bic: float | None  # candidate vs the best additive tone (periodic effects)
    tone_frequency_Hz: float | None
    round: int
    justified: bool
    reason: str
    seconds: float = 0.0
    # the held-out records' evidence, added to delta_bic for the test (driver.held_out_evidence)
    held_out_evidence: float = 0.0


@dataclass(frozen=True, eq=False)
class Identification:
    """The inverse path's result: the law, the effects declared and selected, the records, the
    baseline and final fits, every candidate by round, and what was not a candidate and why."""

    law: str
    declared: tuple[str, ...]
    train: Record
    validation: list[Record]
    baseline: FitResult
    final: FitResult
    candidates: dict[str, Candidate]  # last evaluation of each effect
    rounds: list[list[Candidate]]
    selected: list[str]
    skipped: dict[str, str]  # effect -> why it was not a candidate
    baseline_analysis: ResidualAnalysis
    final_analysis: ResidualAnalysis
    exposing: dict[str, str]  # selected effect -> the regressor that exposed it
    settings: dict = field(default_factory=dict)


def identify(train: Dataset, validation: Sequence[Dataset] = (), *, law: str = "lugre",
             declared: Sequence[str] = (), substeps: int | None = None,
             lowpass_Hz: float | None = None, min_improvement: float = MIN_IMPROVEMENT,
             bic_threshold: float = BIC_THRESHOLD, threads: int | None = None,
             progress: ProgressFn | None = None) -> Identification:
    """Fit ``law`` (+ declared effects) to ``train``, then trace and select effects."""
    say = progress or (lambda message: None)
    check_law_and_effects(law, declared)
    for record in (train, *validation):
        check_identifiable(record)
    state_law = law != "coulomb"
    record = prepare(train, substeps=substeps, lowpass_Hz=lowpass_Hz, state_law=state_law)
    held = [prepare(d, substeps=substeps, lowpass_Hz=lowpass_Hz, state_law=state_law)
            for d in validation]
    _check_compatible(record, held)
    problem = Problem(record, held)
    fit_mass = record.target == "drive" and record.mass_kg is None
    say(f"{record.name}: {record.n} samples, {record.target} force measured, law {law}"
        + (", mass identified" if fit_mass else "")
        + (f", {len(held)} held-out record(s)" if held else ""))
    skipped = _not_applicable(record, law, declared)
    declared = tuple(e for e in inverse_effects() if e in declared and e not in skipped)
    level, start = _initial_level(record, fit_mass, law)
    scales = Scales.of(record, level)
    base = FrictionParameters(law=law)
    model = Model.build(law, declared, fit_mass, scales, base)
    if state_law:
        start = _scan_stiffness(problem, model, start, level)
    say(f"baseline: fitting {model.k} parameters ({', '.join(model.names)})")
    baseline = problem.fit(model, start)
    say(f"baseline: RMSE {baseline.train.rmse_N:.4g} N, relerr {baseline.train.relerr_pct:.3g} %")
    baseline_analysis = analyse(record, baseline.residual)
    remaining = [e for e in inverse_effects() if e not in declared and e not in skipped
                 and e not in excluded_by(declared)]
    workers = threads or min(len(remaining) or 1, sim.cpu_count())
    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        back_end = _InverseRounds(problem, scales, min_improvement, bic_threshold, pool, say)
        selection = select(back_end, baseline, remaining, say)
    current, selected = selection.final, selection.selected
    final_analysis = analyse(record, current.residual)
    exposing = {e: _exposing_regressor(e, baseline_analysis) for e in selected}
    return Identification(
        law=law, declared=declared, train=record, validation=held, baseline=baseline,
        final=current, candidates=selection.candidates, rounds=selection.rounds,
        selected=selected, skipped=skipped, baseline_analysis=baseline_analysis,
        final_analysis=final_analysis, exposing=exposing,
        settings={"substeps": substeps, "lowpass_Hz": lowpass_Hz,
                  "min_improvement": min_improvement, "bic_threshold": bic_threshold,
                  "fit_mass": fit_mass})


class _InverseRounds:
    """The inverse path's rounds for ``driver.select``: every candidate fitted (on the
    ``pool``'s threads) and judged; accepted as fitted; no backward step."""

    round_action = "fitting"

    def __init__(self, problem: Problem, scales: Scales, min_improvement: float,
                 bic_threshold: float, pool: Executor, say: ProgressFn):
        self.problem, self.scales, self.pool, self.say = problem, scales, pool, say
        self.min_improvement, self.bic_threshold = min_improvement, bic_threshold

    def evaluate_round(self, current: FitResult, remaining: Sequence[str],
                       index: int) -> list[Candidate]:
        jobs = [self.pool.submit(_candidate, self.problem, current, effect, self.scales,
                                 index, self.min_improvement, self.bic_threshold)
                for effect in remaining]
        evaluated = [job.result() for job in jobs]
        for c in evaluated:
            self.say(f"  {c.effect:<24s} dBIC {c.delta_bic:10.1f}  RMSE "
                     f"{c.fit.train.rmse_N:.4g} N ({100 * c.train_drop:+.1f} %)  "
                     f"[{c.fit.nfev} evaluations, {c.seconds:.1f} s]  "
                     f"{'justified' if c.justified else 'no: ' + c.reason}")
        return evaluated

    def accept(self, best: Candidate, current: FitResult, index: int) -> Candidate:
        return best

    def selected_note(self, accepted: Candidate) -> str:
        return ""

    def backward_step(self, current: FitResult, selected: list[str], index: int,
                      final: bool) -> FitResult:
        return current


# ---------------------------------------------------------------------------- applicability

def _not_applicable(record: Record, law: str, declared: Sequence[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    out.update(modulation_not_applicable(
        None if record.vibrating else "the support does not vibrate (no support velocity or "
        "vibration_frequency_Hz)", record.vibration_frequency_Hz,
        float(np.median(np.diff(record.time_s)))))
    if record.target == "drive":
        out["sensor_lag"] = ("the lag (sensor_lag_s) is the plugin's friction-sensor lag; this "
                             "record measures the drive force, whose prediction holds the "
                             "measured acceleration: a lag there would smooth sensor noise, "
                             "not model a sensor")
    if record.target != "drive":
        out["drive_damping"] = ("friction is measured directly: drive damping does not enter "
                                "the measured force")
    elif not record.vibrating and record.drive_velocity_m_per_s == 0:
        out["drive_damping"] = ("identical to viscous here: fixed support and no drive spring, "
                                "so h_d (v_d - xdot) = -h_d v_r")
    if law not in _PLAY_LAWS:
        out["contact_play"] = (f"a play before the bristles needs a law with bristles "
                               f"({', '.join(_PLAY_LAWS)}), not {law}")
    if np.ptp(record.relative_position_m) < 2 * _min_wavelength(record):
        out["position_ripple"] = "the record does not travel two ripple wavelengths"
    return without_declared(out, declared)


def check_law_and_effects(law: str, declared: Sequence[str],
                          effects: Sequence[str] | None = None) -> None:
    """InputError naming an unknown law or effect (both identification paths: the simulation
    path passes its own ``effects``, the vocabulary without the maps)."""
    if law not in IDENTIFIABLE_LAWS:
        raise InputError(f"unknown friction law {law!r}; use one of: "
                         f"{', '.join(IDENTIFIABLE_LAWS)}")
    effects = inverse_effects() if effects is None else effects
    unknown = [e for e in declared if e not in effects]
    if unknown:
        maps = [e for e in unknown if e in INVERSE_EFFECTS]
        rig_only = [e for e in unknown if e in RIG_EFFECTS]
        notes = ([f"{', '.join(maps)}: the inverse path only, --method inverse"] if maps else []) \
            + ([f"{', '.join(rig_only)}: the simulation path only, where the rig's drive is "
                "simulated"] if rig_only else [])
        where = f" ({'; '.join(notes)})" if notes else ""
        raise InputError(f"unknown effect(s) {', '.join(unknown)}{where}; the vocabulary is "
                         f"{', '.join(effects)}")
    clashing = [group for group in exclusive_groups()
                if len([e for e in declared if e in group]) > 1]
    if clashing:
        both = [e for e in declared if e in clashing[0]]
        raise InputError(f"effects {', '.join(both)} exclude each other (one load modulation, one "
                         "level map over each regressor); declare one of them")
    if "contact_play" in declared and law not in _PLAY_LAWS:
        raise InputError(f"effect contact_play is a play before the bristles, which law {law} "
                         f"does not have; use --law with one of {', '.join(_PLAY_LAWS)}, or "
                         "leave it out")


def check_identifiable(dataset) -> None:
    """InputError when a record cannot be identified at all (both paths): too short, a
    force that never changes, a body that never moves."""
    where = str(dataset.source_path or dataset.name)
    columns = dataset.columns
    if dataset.n_rows < MIN_SAMPLES:
        raise InputError(f"{where}: {dataset.n_rows} samples; identification needs at least "
                         f"{MIN_SAMPLES}")
    # (a scene driven by its measured drive force has it as an input: a constant push is fine)
    inputs: tuple[str, ...] = ()
    scene = dataset.metadata.model not in (None, "rig")
    if scene:
        from .machine_replay import machine
        base = dataset.source_path.parent if dataset.source_path is not None else None
        inputs = tuple(machine(str(dataset.metadata.model), where, base).inputs)
    forces = [c for c in ("friction_force_N", "drive_force_N") if c in columns and
              c not in inputs]
    if forces and all(np.ptp(columns[c]) == 0 for c in forces):
        raise InputError(f"{where}: {' and '.join(forces)} never change"
                         f"{'s' if len(forces) == 1 else ''} (all {columns[forces[0]][0]:g}); "
                         "there is no friction to fit")
    # relative motion: the body, or the support under a held body
    motion = [c for c in ("position_m", "velocity_m_per_s") +
              (() if scene else ("support_position_m", "support_velocity_m_per_s"))
              if c in columns]
    if motion and all(np.ptp(columns[c]) == 0 for c in motion):
        raise InputError(f"{where}: {' and '.join(motion)} never change"
                         f"{'s' if len(motion) == 1 else ''}: nothing slides, so no friction "
                         "law can be told from another")


def _check_compatible(train: Record, held: Sequence[Record]) -> None:
    for record in held:
        if record.target != train.target:
            raise InputError(f"{record.name}: measures the {record.target} force but the "
                             f"training record {train.name} the {train.target} force; "
                             "validate on records that measure the same force")
        if train.target == "drive" and record.acceleration_m_per_s2 is None:
            raise InputError(f"{record.name}: no acceleration")


# ------------------------------------------------------------------------------ baseline start

def _initial_level(record: Record, fit_mass: bool, law: str) -> tuple[float, dict[str, float]]:
    """Friction level (N) and start values by linear least squares on sgn(v) (+ a, + 1)."""
    v = record.relative_velocity_m_per_s
    y = np.array(record.target_N, dtype=float)
    columns = [np.sign(v) * record.normal_force_N]
    if record.target == "drive":
        if fit_mass:
            columns.append(record.acceleration_m_per_s2)
        else:
            y = y - record.mass_kg * record.acceleration_m_per_s2
    columns.append(np.ones_like(v))
    coef, *_ = np.linalg.lstsq(np.column_stack(columns), y, rcond=None)
    normal = float(np.median(record.normal_force_N))
    mu = float(coef[0]) if coef[0] > 0 else float(np.median(np.abs(y)) / normal)
    mu = max(mu, 1e-9)
    start = {"friction_coefficient": mu, "alpha": 1.0, "breakaway_ratio": 0.7,
             "bristle_damping_N_s_per_m": 0.0, "force_offset_N": float(coef[-1])}
    if fit_mass:
        start["mass_kg"] = max(float(coef[1]), 1e-6)
    return mu * normal, start


def _scan_stiffness(problem: Problem, model: Model, start: dict[str, float],
                    level: float) -> dict[str, float]:
    travel = float(np.ptp(problem.train.relative_position_m)) or 1e-3
    best, best_rss = None, math.inf
    for fraction in _DEFLECTION_SCAN:
        trial = dict(start, contact_stiffness_N_per_m=level / (fraction * travel))
        r = problem.residual(model, model.internal(trial))
        rss = float(r @ r)
        if rss < best_rss:
            best, best_rss = trial, rss
    return best


# ------------------------------------------------------------------------------- candidates

def _candidate(problem: Problem, current: FitResult, effect: str, scales: Scales, index: int,
               min_improvement: float, bic_threshold: float) -> Candidate:
    model = current.model.extended(effect, scales)
    start = dict(current.model.internal_values(current.q))
    start.update(_effect_start(problem, current, effect, model))
    started = time.monotonic()
    # A candidate starts next to its optimum (the projection); one that needs more than this
    # budget is not clearly in the data, and a truncated fit only understates its merit.
    budget = CANDIDATE_EVALUATIONS_PER_PARAMETER * (model.k + 1)
    fit = problem.fit(model, start, max_nfev=budget)
    if fit.rss > current.rss:
        # The projection linearizes; a free shape (a map) can start where the fit cannot come
        # back from. The effect switched off is the current model: start there instead.
        off = problem.fit(model, dict(current.model.internal_values(current.q)),
                          max_nfev=budget)
        fit = off if off.rss < fit.rss else fit
    seconds = time.monotonic() - started
    n_eff = fit.n_eff
    delta_bic = n_eff * math.log(fit.rss / current.rss) + (fit.k - current.k) * math.log(n_eff)
    drop = 1.0 - fit.train.rmse_N / current.train.rmse_N
    val_ratio = None
    if fit.validation:
        val_ratio = float(np.mean([math.log(a.rmse_N / b.rmse_N)
                                   for a, b in zip(fit.validation, current.validation)]))
    held = held_out_evidence(n_eff, problem.train.n, [r.n for r in problem.validation],
                             fit.validation, current.validation)
    tone_dbic = tone_frequency = None
    if effect == "position_ripple" or effect in MODULATION_HARMONICS:
        tone_dbic, tone_frequency = _tone_competition(problem, current, fit, effect)
    reasons = []
    if not delta_bic + held < bic_threshold:
        reasons.append(f"dBIC {delta_bic:.1f}" + (f" + held out {held:.1f}" if held else "")
                       + f" not below {bic_threshold:g}")
    if not drop >= min_improvement:
        reasons.append(f"RMSE falls only {100 * drop:.2f} % (< {100 * min_improvement:g} %)")
    if val_ratio is not None and not val_ratio < 0:
        reasons.append(f"held-out RMSE does not fall ({100 * (math.exp(val_ratio) - 1):+.2f} %)")
    if tone_dbic is not None and not tone_dbic < bic_threshold:
        reasons.append(f"no better than an additive tone at {tone_frequency:.4g} Hz "
                       f"(dBIC {tone_dbic:.1f})")
    return Candidate(effect=effect, fit=fit, delta_bic=delta_bic, train_drop=drop,
                     validation_log_ratio=val_ratio, tone_delta_bic=tone_dbic,
                     tone_frequency_Hz=tone_frequency, round=index, justified=not reasons,
                     reason="; ".join(reasons) if reasons else _why(delta_bic, held, drop),
                     seconds=seconds, held_out_evidence=held)


def _why(delta_bic: float, held: float, drop: float) -> str:
    return f"dBIC {delta_bic:.1f}" + (f" + held out {held:.1f}" if held else "") + \
        f", training RMSE -{100 * drop:.1f} %"


def _effect_start(problem: Problem, current: FitResult, effect: str,
                  model: Model) -> dict[str, float]:
    """Start values of an effect's coordinates: the residual projected on its signature.

    The signature of a coordinate is the change of the prediction when it moves a little away
    from "off"; the least-squares projection of minus the residual on the signatures gives the
    start. Nonlinear coordinates (Stribeck velocity, ripple wavelength) are scanned.
    """
    record = problem.train
    base = dict(current.model.internal_values(current.q))
    params = {p.name: p for p in model.params}

    def prediction(values: Mapping[str, float]) -> np.ndarray:
        return record.lowpass(model.predict(record, model.internal({**base, **values})))

    def project(names: Sequence[str], fixed: Mapping[str, float]) -> tuple[dict, float]:
        reference = prediction({**fixed, **{n: _off(params[n]) for n in names}})
        columns = []
        for name in names:
            step = 0.1 * params[name].scale
            trial = {**fixed, **{n: _off(params[n]) for n in names}}
            trial[name] = _off(params[name]) + step
            columns.append((prediction(trial) - reference) / step)
        target = problem.measured - reference  # what the effect must add to the others
        a = np.column_stack(columns)
        coef, *_ = np.linalg.lstsq(a, target, rcond=None)
        rss = float(np.sum((a @ coef - target) ** 2))
        values = {name: float(_off(params[name]) + c) for name, c in zip(names, coef)}
        return values, rss

    if effect == "stribeck":
        v_rms = math.sqrt(float(np.mean(record.relative_velocity_m_per_s ** 2))) or 1e-3
        best, best_rss = {}, math.inf
        for ratio in _STRIBECK_SCAN:
            fixed = {"stribeck_velocity_m_per_s": ratio * v_rms}
            values, rss = project(["static_ratio"], fixed)
            if rss < best_rss:
                best, best_rss = {**fixed, **values}, rss
        # The projection linearizes; start within a plausible Stribeck peak.
        best["static_ratio"] = min(max(best.get("static_ratio", 1.0), 1.0 + 1e-3), 3.0)
        return best
    if effect == "contact_play":
        # The force is not linear in the play's width (it moves where the contact closes):
        # scanned over widths from 1/1000 of the travel to half of it. A play and a soft
        # bristle trade off (both delay the force after a reversal), so a fit without the
        # play may have taken a softer contact: the contact stiffness is scanned with it.
        travel = params["contact_play_m"].upper
        stiffness = base.get("contact_stiffness_N_per_m")
        multipliers = _PLAY_STIFFNESS_SCAN if stiffness else (1.0,)
        best, best_rss = {}, math.inf
        for fraction in _PLAY_SCAN:
            for multiplier in multipliers:
                trial = {"contact_play_m": fraction * travel}
                if stiffness:
                    trial["contact_stiffness_N_per_m"] = multiplier * stiffness
                r = problem.residual(model, model.internal({**base, **trial}))
                rss = float(r @ r)
                if rss < best_rss:
                    best, best_rss = trial, rss
        return best
    if effect == "position_ripple":
        wavelength = _ripple_scan(problem, current)
        fixed = {"position_ripple_wavelength_m": wavelength}
        values, _ = project(["ripple_cos", "ripple_sin"], fixed)
        return {**fixed, **values}
    own = own_effects.registered().get(effect)
    # (an own effect: projected on its linear parameters, the log ones at their scale)
    values, _ = project(own.linear_names if own else list(effect_internals(effect)), {})
    return values


def _off(p) -> float:
    """Internal value that switches a coordinate's effect off."""
    if p.name == "static_ratio":
        return 1.0
    return 0.0 if not p.log else p.scale


def _min_wavelength(record: Record) -> float:
    """Shortest ripple wavelength the sampling resolves: 4 samples of travel per wavelength."""
    step = np.abs(np.diff(record.relative_position_m))
    return 4.0 * float(np.quantile(step, 0.95)) if len(step) else math.inf


def _ripple_scan(problem: Problem, current: FitResult) -> float:
    """Wavelength whose level-scaled sine/cosine pair best explains the residual."""
    record = problem.train
    values = dict(current.values)
    for name in ("viscous_N_s_per_m", "force_offset_N", "sensor_lag_s"):
        values.pop(name, None)
    level_model = current.model
    friction = np.asarray(level_model.predict_values(_as_friction(record), values))
    x = record.relative_position_m
    travel = float(np.ptp(x))
    cycles_max = travel / _min_wavelength(record)
    cycles = np.arange(1.0, max(cycles_max, 1.25), 0.25)
    target = -current.residual
    best, best_gain = travel, -math.inf
    for c in cycles:
        k = 2 * math.pi * c / travel
        # (unfiltered columns even for low-passed records: this only picks a start value)
        a = np.column_stack([friction * np.sin(k * x), friction * np.cos(k * x)])
        coef, *_ = np.linalg.lstsq(a, target, rcond=None)
        gain = float(coef @ (a.T @ target))
        if gain > best_gain:
            best, best_gain = travel / c, gain
    return best


def _as_friction(record: Record) -> Record:
    """The record seen as a friction measurement (so predict returns the law force only)."""
    from dataclasses import replace
    return replace(record, target="friction")


def _tone_competition(problem: Problem, current: FitResult, fit: FitResult,
                      effect: str) -> tuple[float, float]:
    """dBIC of the effect against an additive tone at its dominant frequency."""
    record = problem.train
    off = dict(fit.values)
    if effect == "position_ripple":
        off["position_ripple"] = 0.0
    else:
        off["normal_force_modulation"] = 0.0
    contribution = record.lowpass(fit.model.predict_values(record, fit.values)) - \
        record.lowpass(fit.model.predict_values(record, off))
    t = record.time_s
    dt = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], dt)
    sampled = np.interp(grid, t, contribution)
    spectrum = np.abs(np.fft.rfft(sampled - sampled.mean()))
    frequencies = np.fft.rfftfreq(len(sampled), dt)
    peak = int(np.argmax(spectrum[1:])) + 1
    bin_Hz = frequencies[1]
    target = -current.residual
    best_rss, best_f = math.inf, frequencies[peak]
    for f in frequencies[peak] + bin_Hz * np.linspace(-2, 2, 41):
        if f <= 0:
            continue
        a = np.column_stack([np.sin(2 * math.pi * f * t), np.cos(2 * math.pi * f * t)])
        a = np.column_stack([record.lowpass(a[:, 0]), record.lowpass(a[:, 1])])
        coef, *_ = np.linalg.lstsq(a, target, rcond=None)
        rss = float(np.sum((target - a @ coef) ** 2))
        if rss < best_rss:
            best_rss, best_f = rss, float(f)
    k_effect = len(effect_internals(effect))
    n_eff = fit.n_eff
    dbic = n_eff * math.log(fit.rss / best_rss) + (k_effect - 3) * math.log(n_eff)
    return float(dbic), best_f


def _exposing_regressor(effect: str, analysis: ResidualAnalysis) -> str:
    """The regressor that shows the effect in the baseline residual."""
    preferred = {
        "viscous": "relative_velocity", "stribeck": "relative_velocity",
        "asymmetry": "relative_velocity", "position_ripple": "position",
        **{e: "support_phase" for e in MODULATION_HARMONICS}, "drive_damping": "support_phase",
        "sensor_lag": "support_phase", "force_offset": "relative_velocity",
        "position_map": "position", "velocity_map": "relative_velocity", "time_map": "time",
        "contact_play": "time_since_reversal",
        **{name: {"time": "time", "relative_speed": "relative_velocity",
                  "position": "position"}[e.over]
           for name, e in own_effects.registered().items()},
    }[effect]
    if preferred in analysis.binned:
        return preferred
    strongest = analysis.strongest()
    return strongest and next(k for k, v in analysis.binned.items() if v is strongest) or "time"


__all__ = ["identify", "Identification", "Candidate", "BIC_THRESHOLD", "MIN_IMPROVEMENT"]
