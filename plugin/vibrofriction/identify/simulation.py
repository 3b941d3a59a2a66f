"""Output-error identification: fit the MuJoCo rig (the plugin) to what the record measured.

The model is ``replay.RigReplay``: the rig scene run by MuJoCo with the friction element,
driven by the record's measured inputs, predicting each measured channel. Every law parameter
and effect is a config attribute of the plugin (or a value of the scene: the slider's mass, the
drive damping), so the fitted model is the model users simulate, and nothing is re-implemented
here.

Cost. Each channel's residual is divided by its estimated white-noise sd (``replay.noise_sd``),
so channels in different units weigh by how well they are measured; the weighted residuals of
all channels are stacked. Least squares (scipy, trust-region reflective) over the internal
coordinates of ``model.Model``; the Jacobian by forward differences, all its columns in one
``mujoco.rollout`` call on parallel threads. Single shooting over the whole record (the drive
spring keeps the rig's position error bounded).

Selection (forward, as the inverse path): a candidate effect is justified when

1. dBIC = n_eff ln((RSS_E + F)/(RSS_M + F)) + (k_E - k_M) ln(n_eff) < ``BIC_THRESHOLD``, with
   n_eff from the residual's autocorrelation and F the simulator's own error: the squared
   weighted difference between the baseline replayed at the chosen timestep and at half of it,
   so that no effect is selected for explaining discretization error;
2. the weighted RMSE (with F) falls by at least ``MIN_IMPROVEMENT``;
3. held-out records' RMSE falls on average;
4. a periodic effect beats an additive tone at its dominant frequency (same dBIC test).
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ..datasets import Dataset
from ..errors import InputError
from ..params import LAWS, FrictionParameters, RigParameters, lugre_default_bristle_damping
from .analysis import effective_samples, spectral_peaks
from .fit import Metrics, _metrics
from .model import EFFECT_INTERNALS, EFFECTS, Model, Scales
from .replay import Replayer, RigReplay, prepare_replay
from .selection import BIC_THRESHOLD, MIN_IMPROVEMENT

ProgressFn = Callable[[str], None]
_TOL = 1e-8
_FD_STEP = 1e-4  # forward-difference step in the internal coordinates (O(1) scaled)
BASELINE_EVALUATIONS = 60
BASELINE_STARTS = 3
CANDIDATE_EVALUATIONS = 12
_LEVEL_SCAN = (1.0, 1.6, 2.5, 4.0, 6.0)  # mu F_N over the drive-force level (vibration lowers it)
_DEFLECTION_SCAN_M = np.logspace(-10, -5, 16)  # characteristic deflection mu F_N / k_t
_BREAKAWAY_SCAN = (0.3, 0.6, 0.85)  # Dupont
_STRIBECK_SCAN = np.logspace(-1.5, 0.5, 6)  # v_s over the rms sliding velocity


@dataclass(frozen=True, eq=False)
class SimFit:
    """One fitted model: values, weighted residual, per-channel errors."""

    model: Model
    q: np.ndarray
    values: dict[str, float]
    residual: np.ndarray  # weighted, all channels stacked
    rss: float
    n_eff: float
    train: Metrics  # of the primary (force) channel
    channels: dict[str, Metrics]  # every measured channel
    validation: list[Metrics]
    nfev: int
    predicted: dict[str, np.ndarray]  # on the training record (measured + extra channels)
    at_bound: tuple[str, ...] = ()

    @property
    def k(self) -> int:
        return self.model.k


@dataclass(frozen=True, eq=False)
class SimCandidate:
    effect: str
    fit: SimFit
    delta_bic: float
    train_drop: float
    validation_log_ratio: float | None
    tone_delta_bic: float | None
    tone_frequency_Hz: float | None
    round: int
    justified: bool
    reason: str
    seconds: float


@dataclass(frozen=True, eq=False)
class SimIdentification:
    law: str
    declared: tuple[str, ...]
    train: RigReplay
    validation: list[RigReplay]
    primary: str
    baseline: SimFit
    final: SimFit
    candidates: dict[str, SimCandidate]
    rounds: list[list[SimCandidate]]
    selected: list[str]
    skipped: dict[str, str]
    numerical_floor: float  # F, in weighted RSS units
    residual_peaks_Hz: list[float]
    settings: dict = field(default_factory=dict)
    simulations: int = 0
    seconds: float = 0.0


class SimulationProblem:
    """The training replay, held-out replays and the parameter-to-model mapping."""

    def __init__(self, train: RigReplay, validation: Sequence[RigReplay], law: str,
                 threads: int | None = None):
        self.train = train
        self.validation = list(validation)
        self.law = law
        self.runner = Replayer(train, threads)
        self.held_runners = [Replayer(r, threads) for r in self.validation]
        self.primary = "friction_force_N" if "friction_force_N" in train.measured else \
            "drive_force_N"
        self.weights = {c: 1.0 / train.noise[c] for c in train.channels}
        self.floor = 0.0

    def close(self) -> None:
        for runner in (self.runner, *self.held_runners):
            runner.close()

    @property
    def simulations(self) -> int:
        return sum(r.simulations for r in (self.runner, *self.held_runners))

    # -------------------------------------------------------------------- model evaluation

    def case(self, model: Model, values: Mapping[str, float],
             replay: RigReplay | None = None) -> tuple[RigParameters, FrictionParameters]:
        replay = replay or self.train
        friction = model.friction_parameters(values)
        mass = values.get("mass_kg", replay.rig.mass_kg if replay.mass_known else
                          self.train.rig.mass_kg)
        rig = replace(replay.rig, mass_kg=mass,
                      drive_damping_N_s_per_m=values.get("drive_damping_N_s_per_m", 0.0))
        return rig, friction

    def predict(self, model: Model, value_sets: Sequence[Mapping[str, float]],
                extra: Sequence[str] = ()) -> list[dict[str, np.ndarray]]:
        return self.runner.run([self.case(model, v) for v in value_sets], extra)

    def weighted(self, predicted: Mapping[str, np.ndarray],
                 replay: RigReplay | None = None) -> np.ndarray:
        replay = replay or self.train
        return np.concatenate([(predicted[c] - replay.measured[c]) * self.weights[c]
                               for c in replay.channels])

    def residuals(self, model: Model, qs: Sequence[np.ndarray]) -> list[np.ndarray]:
        outs = self.predict(model, [model.values(q) for q in qs])
        return [self.weighted(o) for o in outs]

    # --------------------------------------------------------------------------------- fit

    def fit(self, model: Model, start: Mapping[str, float], max_nfev: int) -> SimFit:
        q0 = model.internal(start)
        lo, hi = model.bounds()
        cache: dict[bytes, np.ndarray] = {}

        def fun(q: np.ndarray) -> np.ndarray:
            key = np.asarray(q, dtype=float).tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = self.residuals(model, [q])[0]
            return cache[key]

        def jac(q: np.ndarray) -> np.ndarray:
            r0 = fun(q)
            steps = []
            for j in range(len(q)):
                h = _FD_STEP * max(1.0, abs(q[j]))
                steps.append(h if q[j] + h <= hi[j] else -h)
            shifted = []
            for j, h in enumerate(steps):
                qj = np.array(q, dtype=float)
                qj[j] += h
                shifted.append(qj)
            columns = self.residuals(model, shifted)
            return np.column_stack([(r - r0) / h for r, h in zip(columns, steps)])

        result = least_squares(fun, q0, jac=jac, bounds=(lo, hi), method="trf",
                               x_scale="jac", ftol=_TOL, xtol=_TOL, gtol=_TOL,
                               max_nfev=max_nfev)
        return self.result(model, result.x, result.nfev)

    def result(self, model: Model, q: np.ndarray, nfev: int = 0) -> SimFit:
        values = model.values(q)
        extra = ("friction_force_N", "relative_position_m", "relative_velocity_m_per_s")
        predicted = self.predict(model, [values], extra)[0]
        residual = self.weighted(predicted)
        rss = float(residual @ residual)
        channels = {c: _metrics(self.train.name, predicted[c], self.train.measured[c])
                    for c in self.train.channels}
        held = []
        for replay, runner in zip(self.validation, self.held_runners):
            out = runner.run([self.case(model, values, replay)])[0]
            held.append(_metrics(replay.name, out[self.primary], replay.measured[self.primary]))
        lo, hi = model.bounds()
        at_bound = tuple(p.name for p, x, a, b in zip(model.params, q, lo, hi)
                         if min(x - a, b - x) <= 1e-6 * max(1.0, abs(x)) and p.name in values)
        return SimFit(model=model, q=np.array(q), values=values, residual=residual, rss=rss,
                      n_eff=effective_samples(residual), train=channels[self.primary],
                      channels=channels, validation=held, nfev=nfev, predicted=predicted,
                      at_bound=at_bound)


# ------------------------------------------------------------------------------ identify

def identify_by_simulation(train: Dataset, validation: Sequence[Dataset] = (), *,
                           law: str = "lugre", declared: Sequence[str] = (),
                           substeps: int | None = None,
                           min_improvement: float = MIN_IMPROVEMENT,
                           bic_threshold: float = BIC_THRESHOLD, threads: int | None = None,
                           progress: ProgressFn | None = None) -> SimIdentification:
    """Fit ``law`` (+ declared effects) to ``train`` by simulating the rig, then select."""
    started = time.monotonic()
    say = progress or (lambda message: None)
    if law not in LAWS:
        raise InputError(f"unknown friction law {law!r}; use one of: {', '.join(LAWS)}")
    unknown = [e for e in declared if e not in EFFECTS]
    if unknown:
        raise InputError(f"unknown effect(s) {', '.join(unknown)}; the vocabulary is "
                         f"{', '.join(EFFECTS)}")
    replay = prepare_replay(train, substeps=substeps)
    held = [prepare_replay(d, substeps=replay.substeps) for d in validation]
    for h in held:
        missing = set(replay.channels) - set(h.channels)
        if missing:
            raise InputError(f"{h.name}: held-out record lacks {', '.join(sorted(missing))}, "
                             f"which the training record {replay.name} measures")
    problem = SimulationProblem(replay, held, law, threads)
    try:
        return _identify(problem, law, declared, min_improvement, bic_threshold, say, started)
    finally:
        problem.close()


def _identify(problem: SimulationProblem, law: str, declared: Sequence[str],
              min_improvement: float, bic_threshold: float, say: ProgressFn,
              started: float) -> SimIdentification:
    replay = problem.train
    fit_mass = not replay.mass_known
    say(f"{replay.name}: {replay.n} samples, measured {', '.join(replay.channels)}; "
        f"MuJoCo rig at dt {replay.timestep_s:.4g} s ({replay.substeps} step(s) a sample), "
        f"law {law}" + (", mass identified" if fit_mass else "") +
        (f", {len(problem.validation)} held-out record(s)" if problem.validation else ""))
    skipped = _not_applicable(replay, law, declared)
    declared = tuple(e for e in EFFECTS if e in declared and e not in skipped)
    scales, starts = _start(problem, law, fit_mass, declared)
    model = Model.build(law, declared, fit_mass, scales, FrictionParameters(law=law))
    say(f"baseline: fitting {model.k} parameters ({', '.join(model.names)}) from the "
        f"{len(starts)} best start(s) of a scan")
    # Several starts: a record that measures little of the contact (position and drive force
    # only) has more than one basin in the contact stiffness.
    baseline = min((problem.fit(model, start, BASELINE_EVALUATIONS) for start in starts),
                   key=lambda fit: fit.rss)
    problem.floor = _numerical_floor(problem, baseline)
    say(f"baseline: {problem.primary} relerr {baseline.train.relerr_pct:.3g} %; simulator "
        f"error floor {math.sqrt(problem.floor / len(baseline.residual)):.3g} (weighted rms)")
    current = baseline
    remaining = [e for e in EFFECTS if e not in declared and e not in skipped]
    candidates: dict[str, SimCandidate] = {}
    rounds: list[list[SimCandidate]] = []
    selected: list[str] = []
    while remaining:
        index = len(rounds) + 1
        say(f"round {index}: fitting {len(remaining)} candidate(s): {', '.join(remaining)}")
        evaluated = []
        for effect in remaining:
            c = _candidate(problem, current, effect, scales, index, min_improvement,
                           bic_threshold)
            candidates[effect] = c
            evaluated.append(c)
            say(f"  {c.effect:<24s} dBIC {c.delta_bic:10.1f}  {problem.primary} relerr "
                f"{c.fit.train.relerr_pct:.4g} % ({100 * c.train_drop:+.1f} %)  "
                f"[{c.seconds:.1f} s]  {'justified' if c.justified else 'no: ' + c.reason}")
        rounds.append(evaluated)
        justified = [c for c in evaluated if c.justified]
        if not justified:
            break
        best = min(justified, key=lambda c: c.delta_bic)
        selected.append(best.effect)
        current = best.fit
        remaining.remove(best.effect)
        say(f"round {index}: selected {best.effect}")
    say("selected: " + (", ".join(selected) if selected else "nothing"))
    peaks = _residual_peaks(problem, current)
    return SimIdentification(
        law=law, declared=declared, train=replay, validation=problem.validation,
        primary=problem.primary, baseline=baseline, final=current, candidates=candidates,
        rounds=rounds, selected=selected, skipped=skipped, numerical_floor=problem.floor,
        residual_peaks_Hz=peaks,
        settings={"method": "simulation", "substeps": replay.substeps,
                  "timestep_s": replay.timestep_s, "min_improvement": min_improvement,
                  "bic_threshold": bic_threshold, "fit_mass": fit_mass,
                  "noise_sd": dict(replay.noise)},
        simulations=problem.simulations, seconds=time.monotonic() - started)


def _not_applicable(replay: RigReplay, law: str, declared: Sequence[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    if law == "dahl":
        out["stribeck"] = "the Dahl element has no Stribeck curve yet (use lugre or dupont)"
    if not replay.vibrating:
        out["normal_force_modulation"] = ("the support does not vibrate (no support motion or "
                                          "no vibration_frequency_Hz)")
    if "friction_force_N" not in replay.measured:
        out["sensor_lag"] = ("the plugin lags its reported friction force; this record does "
                             "not measure friction directly (a dynamometer lag is not modelled)")
    for effect in declared:
        out.pop(effect, None)
    return out


# ------------------------------------------------------------------------------- starting

def _start(problem: SimulationProblem, law: str, fit_mass: bool,
           declared: Sequence[str] = ()) -> tuple[Scales, list[dict[str, float]]]:
    """Scales and the best starts of a scan (level, stiffness, shape) simulated at once."""
    replay = problem.train
    normal = replay.rig.normal_force_N
    if "friction_force_N" in replay.measured:
        level = float(np.quantile(np.abs(replay.measured["friction_force_N"]), 0.95))
        levels = [level * r for r in (0.9, 1.0, 1.1)] if "stribeck" in declared else [level]
    else:
        drive = replay.measured["drive_force_N"]
        level = float(np.mean(np.abs(drive[len(drive) // 2:])))
        levels = [level * r for r in _LEVEL_SCAN]
    level = max(level, 1e-9)
    dt = float(np.median(np.diff(replay.time_s)))
    v_rms = math.sqrt(float(np.mean(np.diff(replay.control[:, 0]) ** 2))) / replay.timestep_s
    scales = Scales(force_N=level, velocity_m_per_s=max(v_rms, abs(replay.rig.drive_velocity_m_per_s)),
                    normal_force_N=normal, dt_s=dt,
                    travel_m=float(np.ptp(replay.measured.get("position_m", [0.0]))) or 1e-3)
    model = Model.build(law, declared, fit_mass, scales, FrictionParameters(law=law))
    trials = []
    deflections = _DEFLECTION_SCAN_M if law != "coulomb" else [None]
    breakaways = _BREAKAWAY_SCAN if law == "dupont" else (0.7,)
    # A declared Stribeck curve: at static_ratio 1 its velocity has no gradient, so scan both.
    stribeck = [{}]
    if "stribeck" in declared:
        stribeck = [{"static_ratio": ratio, "stribeck_velocity_m_per_s": r * scales.velocity_m_per_s}
                    for ratio in (1.2, 1.6) for r in (0.3, 1.0, 3.0)]
    for lv, deflection, breakaway, curve in itertools.product(levels, deflections, breakaways,
                                                              stribeck):
        # (with a Stribeck curve the level scanned is its peak, mu F_N static_ratio)
        values = {"friction_coefficient": lv / normal / curve.get("static_ratio", 1.0),
                  "alpha": 1.0, "breakaway_ratio": breakaway, "bristle_damping_N_s_per_m": 0.0,
                  **curve}
        if deflection is not None:
            k_t = lv / deflection
            values["contact_stiffness_N_per_m"] = k_t
            if law == "lugre":
                values["bristle_damping_N_s_per_m"] = lugre_default_bristle_damping(
                    k_t, replay.rig.mass_kg)
        if fit_mass:
            values["mass_kg"] = replay.rig.mass_kg
        trials.append(values)
    internal = [model.internal(_internal_names(model, v)) for v in trials]
    residuals = problem.residuals(model, internal)
    order = np.argsort([float(r @ r) for r in residuals])
    return scales, [_internal_names(model, trials[i]) for i in order[:BASELINE_STARTS]]


def _internal_names(model: Model, values: Mapping[str, float]) -> dict[str, float]:
    """Physical values as the model's named internal values (they coincide for the law)."""
    return {k: v for k, v in values.items() if k in model.names}


def _numerical_floor(problem: SimulationProblem, fit: SimFit) -> float:
    """Weighted squared difference between the fit at its timestep and at half of it."""
    replay = problem.train
    finer = replace(replay, substeps=2 * replay.substeps, timestep_s=replay.timestep_s / 2,
                    control=_refined_control(replay))
    with Replayer(finer, problem.runner.threads) as runner:
        out = runner.run([problem.case(fit.model, fit.values)])[0]
    difference = problem.weighted(out, replay) - fit.residual
    return float(difference @ difference)


def _refined_control(replay: RigReplay) -> np.ndarray:
    """Controls at half the timestep: the step ends in between by linear interpolation of the
    coarse ones (the coarse controls already follow the measured motion's spline)."""
    c = replay.control
    previous = np.vstack([_first_control(replay), c[:-1]])
    out = np.empty((2 * len(c), c.shape[1]))
    out[0::2] = 0.5 * (previous + c)
    out[1::2] = c
    return out[:2 * (replay.nstep - 1) + 1]


def _first_control(replay: RigReplay) -> np.ndarray:
    return np.array([[replay.initial_support_position_m, replay.initial_drive_end_m, 0.0, 0.0]])


# ----------------------------------------------------------------------------- candidates

def _candidate(problem: SimulationProblem, current: SimFit, effect: str, scales: Scales,
               index: int, min_improvement: float, bic_threshold: float) -> SimCandidate:
    started = time.monotonic()
    model = current.model.extended(effect, scales)
    start = dict(current.model.internal_values(current.q))
    start.update(_effect_start(problem, current, effect, model))
    fit = problem.fit(model, start, CANDIDATE_EVALUATIONS)
    floor = problem.floor
    n_eff = max(current.n_eff, 2.0)
    delta_bic = n_eff * math.log((fit.rss + floor) / (current.rss + floor)) + \
        (fit.k - current.k) * math.log(n_eff)
    drop = 1.0 - math.sqrt((fit.rss + floor) / (current.rss + floor))
    val_ratio = None
    if fit.validation:
        val_ratio = float(np.mean([math.log(a.rmse_N / b.rmse_N)
                                   for a, b in zip(fit.validation, current.validation)]))
    tone_dbic = tone_frequency = None
    if effect in ("position_ripple", "normal_force_modulation"):
        tone_dbic, tone_frequency = _tone_competition(problem, current, fit, effect, n_eff)
    reasons = []
    if not delta_bic < bic_threshold:
        reasons.append(f"dBIC {delta_bic:.1f} not below {bic_threshold:g}")
    if not drop >= min_improvement:
        reasons.append(f"weighted RMSE falls only {100 * drop:.2f} % "
                       f"(< {100 * min_improvement:g} %)")
    if val_ratio is not None and not val_ratio < 0:
        reasons.append(f"held-out RMSE does not fall ({100 * (math.exp(val_ratio) - 1):+.2f} %)")
    if tone_dbic is not None and not tone_dbic < bic_threshold:
        reasons.append(f"no better than an additive tone at {tone_frequency:.4g} Hz "
                       f"(dBIC {tone_dbic:.1f})")
    reason = "; ".join(reasons) if reasons else \
        f"dBIC {delta_bic:.1f}, weighted RMSE -{100 * drop:.1f} %"
    return SimCandidate(effect=effect, fit=fit, delta_bic=delta_bic, train_drop=drop,
                        validation_log_ratio=val_ratio, tone_delta_bic=tone_dbic,
                        tone_frequency_Hz=tone_frequency, round=index, justified=not reasons,
                        reason=reason, seconds=time.monotonic() - started)


def _off(name: str, model: Model) -> float:
    p = next(p for p in model.params if p.name == name)
    if name == "static_ratio":
        return 1.0
    return p.scale if p.log else 0.0


def _effect_start(problem: SimulationProblem, current: SimFit, effect: str,
                  model: Model) -> dict[str, float]:
    """Start values of an effect: minus the residual projected on the effect's signatures
    (the change of the weighted prediction when a coordinate moves a little from "off"),
    all signatures of a scan simulated in one batch."""
    base = dict(current.model.internal_values(current.q))
    params = {p.name: p for p in model.params}
    names = list(EFFECT_INTERNALS[effect])
    scans: list[dict[str, float]] = [{}]
    if effect == "stribeck":
        names = ["static_ratio"]
        v_rms = params["stribeck_velocity_m_per_s"].scale
        scans = [{"stribeck_velocity_m_per_s": r * v_rms} for r in _STRIBECK_SCAN]
    elif effect == "position_ripple":
        names = ["ripple_cos", "ripple_sin"]
        scans = [{"position_ripple_wavelength_m": _ripple_wavelength(problem, current)}]
    batch = []
    for fixed in scans:
        off = {**base, **fixed, **{n: _off(n, model) for n in names}}
        batch.append(off)
        for n in names:
            trial = dict(off)
            trial[n] = _off(n, model) + 0.1 * params[n].scale
            batch.append(trial)
    residuals = problem.residuals(model, [model.internal(v) for v in batch])
    best, best_rss = {}, math.inf
    stride = len(names) + 1
    for i, fixed in enumerate(scans):
        r0 = residuals[i * stride]
        columns = np.column_stack([(residuals[i * stride + 1 + j] - r0) /
                                   (0.1 * params[n].scale) for j, n in enumerate(names)])
        coef, *_ = np.linalg.lstsq(columns, -r0, rcond=None)
        rss = float(np.sum((r0 + columns @ coef) ** 2))
        if rss < best_rss:
            values = {n: _off(n, model) + float(c) for n, c in zip(names, coef)}
            best, best_rss = {**fixed, **values}, rss
    for n in list(best):
        p = params[n]
        best[n] = min(max(best[n], p.lower), p.upper)
    if effect == "stribeck":
        best["static_ratio"] = min(max(best["static_ratio"], 1.0 + 1e-3), 3.0)
    return best


def _ripple_wavelength(problem: SimulationProblem, current: SimFit) -> float:
    """Wavelength whose level-scaled sine/cosine best explains the force residual."""
    channel = problem.primary
    target = current.predicted[channel] - problem.train.measured[channel]
    friction = current.predicted["friction_force_N"]
    x = current.predicted["relative_position_m"]
    travel = float(np.ptp(x)) or 1e-3
    step = float(np.quantile(np.abs(np.diff(x)), 0.95)) or travel
    cycles = np.arange(1.0, max(travel / (4 * step), 1.25), 0.25)
    best, best_gain = travel, -math.inf
    for c in cycles:
        k = 2 * math.pi * c / travel
        a = np.column_stack([friction * np.sin(k * x), friction * np.cos(k * x)])
        coef, *_ = np.linalg.lstsq(a, -target, rcond=None)
        gain = float(coef @ (a.T @ -target))
        if gain > best_gain:
            best, best_gain = travel / c, gain
    return best


def _tone_competition(problem: SimulationProblem, current: SimFit, fit: SimFit, effect: str,
                      n_eff: float) -> tuple[float, float]:
    """dBIC of the effect against an additive tone (in every channel) at the dominant
    frequency of the effect's contribution to the primary channel."""
    replay = problem.train
    channel = problem.primary
    contribution = fit.predicted[channel] - current.predicted[channel]
    t = replay.time_s - replay.time_s[0]
    spectrum = np.abs(np.fft.rfft(contribution - contribution.mean()))
    frequencies = np.fft.rfftfreq(len(t), float(np.median(np.diff(t))))
    peak = int(np.argmax(spectrum[1:])) + 1
    bin_Hz = frequencies[1]
    target = -current.residual
    n = replay.n
    best_rss, best_f = math.inf, float(frequencies[peak])
    for f in frequencies[peak] + bin_Hz * np.linspace(-2, 2, 21):
        if f <= 0:
            continue
        columns = []
        for j, c in enumerate(replay.channels):
            for basis in (np.sin(2 * math.pi * f * t), np.cos(2 * math.pi * f * t)):
                col = np.zeros(len(target))
                col[j * n:(j + 1) * n] = basis
                columns.append(col)
        a = np.column_stack(columns)
        coef, *_ = np.linalg.lstsq(a, target, rcond=None)
        rss = float(np.sum((target - a @ coef) ** 2))
        if rss < best_rss:
            best_rss, best_f = rss, float(f)
    k_tone = 2 * len(replay.channels) + 1
    k_effect = len(EFFECT_INTERNALS[effect])
    floor = problem.floor
    dbic = n_eff * math.log((fit.rss + floor) / (best_rss + floor)) + \
        (k_effect - k_tone) * math.log(n_eff)
    return float(dbic), best_f


def _residual_peaks(problem: SimulationProblem, fit: SimFit) -> list[float]:
    from scipy.ndimage import median_filter
    from scipy.signal import welch
    channel = problem.primary
    residual = fit.predicted[channel] - problem.train.measured[channel]
    dt = float(np.median(np.diff(problem.train.time_s)))
    n = len(residual)
    if n < 64:
        return []
    nperseg = int(2 ** math.ceil(math.log2(max(64, n // 4))))
    frequency, psd = welch(residual - residual.mean(), fs=1.0 / dt, nperseg=min(nperseg, n))
    floor = median_filter(psd, size=max(15, len(psd) // 8) | 1, mode="mirror")
    return [round(f, 6) for f in spectral_peaks(frequency, psd, floor)]


__all__ = ["identify_by_simulation", "SimIdentification", "SimFit", "SimCandidate",
           "SimulationProblem"]
