"""Output-error identification: fit the MuJoCo rig (the plugin) to what the record measured.

The model is ``replay.RigReplay``: the rig scene run by MuJoCo with the friction element,
driven by the record's measured inputs, predicting each measured channel. Every law parameter
and effect is a config attribute of the plugin (or a value of the scene: the slider's mass, the
drive damping), so the fitted model is the model users simulate, and nothing is re-implemented
here.

Cost. Each channel's residual is divided by its estimated white-noise sd (``replay.noise_sd``),
so channels in different units weigh by how well they are measured; the weighted residuals of
all channels are stacked. After the baseline fit each channel's sd becomes at least its
residual's rms (maximum likelihood for unknown channel variances: a channel the model cannot
follow to its sensor's resolution, e.g. a position driven by an integrated noisy velocity, does
not dominate). Least squares (scipy, trust-region reflective) over the internal coordinates of
``model.Model``; the Jacobian by forward differences, all its columns in one
``mujoco.rollout`` call on parallel threads. Single shooting over the whole record (the drive
spring keeps the rig's position error bounded).

Timestep. Halved until halving it again moves the prediction less than
``TIMESTEP_TOLERANCE`` noise sd (rms), at the best start of the scan and again at the fitted
baseline (a fit can move to stiff contacts the step no longer resolves, and exploit its error).

Baseline. Starts from a scan of the level and the contact's deflection (then the shape); when
the record begins with the support standing still, fits to that stage alone are two more starts:
one over the whole stage, one over growing windows of it (``STILL_WINDOWS``), each started from
the last, so that the contact's loading fixes the stiffness before a stick-slip's timing can
trap the fit.

Selection (forward, ``driver.select``, as the inverse path). Each round screens every candidate
linearized at the round's model (in round 1 at each local optimum of the baseline): the residual
projected on the model's and the effect's sensitivities. The ``SCREENED_FITS`` best with a
linearized dBIC below 0 (and a linearized RMSE drop of at least ``LINEARIZED_DROP_FRACTION`` of
the improvement asked, except for the effects far from linear) are fitted; the
``CONVERGED_LEADERS`` best justified ones are then fitted to convergence before the choice.
After each choice a backward step drops an earlier effect that the same test no longer
justifies. A candidate effect is justified when

1. dBIC = n_eff ln((RSS_E + F)/(RSS_M + F)) + (k_E - k_M) ln(n_eff) < ``BIC_THRESHOLD``, with
   n_eff from the autocorrelation of the current model's residual and F the simulator's own
   error: the squared weighted difference between the baseline replayed at the chosen
   timestep and at half of it, so that no effect is selected for explaining discretization
   error; plus the held-out records' evidence where they favour the effect
   (``driver.held_out_evidence``);
2. the weighted RMSE (with F) falls by at least ``MIN_IMPROVEMENT``;
3. held-out records' RMSE falls on average;
4. a periodic effect beats an additive tone at its dominant frequency (same dBIC test).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ..data.datasets import Dataset
from ..errors import InputError
from ..params import FrictionParameters, RigParameters, lugre_default_bristle_damping
from .analysis import effective_samples, uniform_spectrum
from .driver import held_out_evidence, select
from .fit import Metrics, record_metrics
from .model import (MODULATION_HARMONICS, Model, Scales, effect_internals, excluded_by,
                    forward_steps, modulation_not_applicable, simulation_effects,
                    without_declared)
from . import own_effects
from .replay import MAX_SUBSTEPS, MIN_SAMPLES, Replayer, RigReplay, stick_phase_steps
from .replays import prepare_replay
from .shooting import MultipleShooting
from .selection import (BIC_THRESHOLD, MIN_IMPROVEMENT, check_identifiable,
                        check_law_and_effects)

ProgressFn = Callable[[str], None]
_TOL = 1e-8
# A fit stops once STALL_EVALUATIONS evaluations within STALL_BAND of the best weighted RSS so
# far have come since it last fell by STALL_RELATIVE of itself. The simulator's step grid
# makes the cost rough at that scale: on a clean 0.4 s lab record a baseline fit's rejected
# steps came back 3.4e-4 above its best, and the three baseline fits spent 31 of their 71
# evaluations there, the trust region shrinking, after they had reached their optimum's RSS to
# 0.03 %. (Steps rejected far above the best only shrink the trust region: not a stall.)
STALL_EVALUATIONS = 3
STALL_RELATIVE = 1e-4
STALL_BAND = 1e-2
# A baseline start after the first is abandoned when its RSS after RACE_EVALUATIONS
# evaluations is still above RACE_RATIO times the best baseline fit's so far: it is descending
# a long valley from far away (on a clean 0.4 s lab record, a start at 5.4 times the best after
# 10 evaluations took 25 evaluations to arrive at the same optimum as the first start).
RACE_EVALUATIONS = 10
RACE_RATIO = 3.0
# The backward step's fit of the model without an effect starts at the current values: one
# still this far above the RSS that would drop the effect after RACE_EVALUATIONS is abandoned.
DROP_RACE_RATIO = 1.25
# Forward-difference step in the internal coordinates (O(1) scaled). At 1e-4 a fit stopped short
# in a declared Stribeck curve's narrow valley (a noise-free position-only LuGre record: r 1.255
# for 1.3); at 1e-6 the step grid's roughness misled the hidden-Stribeck lab record's fit (v_s
# -13 %); at 1e-5 both come back.
_FD_STEP = 1e-5
# The timestep is halved until halving it again moves the prediction less than this (rms, in
# units of each channel's noise sd).
TIMESTEP_TOLERANCE = 0.1
# ... at the scan's best start the check is this loose: a scan point is a guess on a grid (a
# level and a deflection, a default damping), often stiffer than the fit it leads to, and the
# fitted baseline is checked again at TIMESTEP_TOLERANCE (refined there if it needs it). (The
# 0.4 s lab record's best start, once the scan reached its level, asked for 4 steps a sample
# at 0.127 sd; its fit needs 2: 0.026 sd.)
START_TIMESTEP_TOLERANCE = 2 * TIMESTEP_TOLERANCE
BASELINE_EVALUATIONS = 60
# A long fit says how it stands at least this often (seconds): its evaluations, its best
# weighted RSS and, from the time an evaluation has taken, how long its budget can still run.
HEARTBEAT_S = 25.0
# The support "stands still" while its speed stays below this fraction of its peak.
# Fractions of the still stage fitted in turn, each from the last one's values: the loading
# before the first slip gives the contact's stiffness, the breakaway then its level (measured
# on a noise-free LuGre record with a Stribeck peak: started on the whole stage, the fit lands
# 3-33 % off; over these windows, on the truth to 4 digits).
STILL_WINDOWS = (0.125, 0.25, 0.5, 1.0)
STILL_FRACTION = 0.1
BASELINE_STARTS = 3
CANDIDATE_EVALUATIONS = 12
SCREENED_FITS = 3  # candidates fitted in full per round (the best linearized ones)
# A candidate whose linearized fit lowers the weighted RMSE by less than this fraction of
# MIN_IMPROVEMENT is not fitted in full (on a clean 0.4 s lab record three level effects were
# fitted for 7 s each to fall 0.03 %) unless it is far from linear in its values: a Stribeck
# peak (stick-slip) or a sensor lag of a sizeable part of the vibration period.
LINEARIZED_DROP_FRACTION = 0.25
_NONLINEAR_EFFECTS = ("stribeck", "sensor_lag", "backlash")
CONVERGED_LEADERS = 2  # justified candidates whose fits are converged before a round's choice
_STEP_FRACTIONS = (1.0, 0.5, 0.25, 0.1)  # of a candidate's linearized step, tried at once
# mu F_N over the drive-force level (vibration lowers it), about 1.25 apart: at 1.6 apart a
# position-only Dupont record's nearest levels were 24 % and 22 % off its own, the scan ranked a
# stiff contact first and the fit selected three effects it does not have; from this grid it
# comes back exact (scripts/bench_identify.py)
_LEVEL_SCAN = (1.0, 1.25, 1.6, 2.0, 2.5, 3.2, 4.0, 5.0, 6.3)
_DEFLECTION_SCAN_M = np.logspace(-10, -5, 16)  # characteristic deflection mu F_N / k_t
# ... and on up, at the same spacing, to this share of the record's travel: a machine's guide
# or a damper's compliance deflects by tenths of a millimetre (a 24.7 kg carriage's 2e5 N/m
# at 38 N: 0.19 mm), which the rig's micrometre grid never reached (a gms fit then stayed at
# 1e11 N/m, 99 % off).
DEFLECTION_SCAN_TRAVEL_SHARE = 0.05


def _travel_m(replay) -> float:
    """The record's measured travel (1 mm when it measures no position)."""
    return float(np.ptp(replay.measured.get("position_m", [0.0]))) or 1e-3


def _position_range_m(replay) -> tuple[float, float]:
    """The range of the slider's measured position relative to the support (a position map's
    knots); without a measured position, the drive's travel over the record."""
    position = replay.measured.get("position_m")
    if position is None:
        travel = replay.rig.drive_velocity_m_per_s * float(np.ptp(replay.time_s))
        return (min(0.0, travel), max(0.0, travel)) if travel else (0.0, 1e-3)
    return float(np.min(position)), float(np.max(position))


def deflection_scan_m(travel_m: float) -> np.ndarray:
    """The scanned characteristic deflections for a record with this travel."""
    step = float(np.log10(_DEFLECTION_SCAN_M[1] / _DEFLECTION_SCAN_M[0]))
    top = math.log10(max(DEFLECTION_SCAN_TRAVEL_SHARE * travel_m, _DEFLECTION_SCAN_M[-1]))
    extra = int(math.floor((top - math.log10(_DEFLECTION_SCAN_M[-1])) / step + 1e-9))
    return np.concatenate([_DEFLECTION_SCAN_M,
                           _DEFLECTION_SCAN_M[-1] * 10 ** (step * np.arange(1, extra + 1))])
_BREAKAWAY_SCAN = (0.3, 0.6, 0.85)  # Dupont
_STRIBECK_SCAN = np.logspace(-1.5, 0.5, 6)  # v_s over the velocity scale (rms support speed)
_STRIBECK_RATIOS = (1.2, 1.5, 2.0)
_STRIBECK_STARTS = 3  # grid points a Stribeck candidate is fitted from
# A declared Stribeck curve is fitted again from these (static ratio, v_s over the velocity
# scale: the rms support speed, or the drive speed if larger), the best baseline's other values
# kept (its level coordinate too). From a scan's start the contact is far off, the fit flattens
# the peak on the way (static ratio 1, where v_s has no gradient) and stays there: measured on
# a noise-free position-only LuGre record (ratio 1.3, v_s 1.9 times the scale), which came back
# at ratio 1.02; from (1.2, 1) it is exact. With sensor noise the same record has local optima
# along the curve's valley a few units of weighted RSS apart: from the first two shapes the fit
# stopped at ratio 1.21 (mu +4 to +5 %, three noise seeds; the optimum near the truth 3.5 lower
# in RSS, a ridge 70 higher between them); from (1.5, 3) all three come back within 1.8 %.
_STRIBECK_RESTARTS = ((1.2, 1.0), (1.2, 3.0), (1.5, 3.0))
# A stick-slip record's segmented replay (``_segmented_starts``): its scan's shapes, how many
# of the scan's best points are fitted on it, and with how many evaluations each.
MIN_SLIPS = 2
SEGMENTED_PEAK_SCAN = (0.9, 1.0, 1.1)  # of the largest measured force
SEGMENTED_SCAN_RATIOS = (1.1, 1.2, 1.35, 1.6, 2.0, 2.5)
SEGMENTED_ALPHA_SCAN = (0.7, 1.4, 2.8)
SEGMENTED_SCAN_SPEEDS = (0.3, 1.0, 3.0)  # v_s over the velocity scale
SEGMENTED_STARTS = 3
SEGMENTED_EVALUATIONS = 60
_OTHER_STARTS = "further starts"  # key of a start dict: more starts for the same candidate


class _Stalled(Exception):
    """A fit's evaluations stopped making progress that matters (``STALL_RELATIVE``)."""


class _Abandoned(Exception):
    """A fit is still far above a better one after its first evaluations (``RACE_RATIO``)."""


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
    # on each held-out record: its measured channels as ``validation``'s errors compare them
    validation_predicted: tuple[dict[str, np.ndarray], ...] = ()

    @property
    def k(self) -> int:
        return self.model.k


@dataclass(frozen=True, eq=False)
class SimCandidate:
    """One effect's evaluation in a round of the simulation path: its fit (or, screened out,
    the round's model), dBIC, the linearized screen's dBIC, the verdict and why."""

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
    screen_delta_bic: float | None = None  # linearized at the round's model
    fitted: bool = True  # False: screened out, ``fit`` is the round's model
    # the held-out records' evidence, added to delta_bic for the test (driver.held_out_evidence)
    held_out_evidence: float = 0.0


@dataclass(frozen=True, eq=False)
class SimIdentification:
    """The simulation path's result: the law, the effects declared and selected, the
    replays, the baseline and final fits, every candidate by round, and the settings used."""

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
    dropped: dict[str, str] = field(default_factory=dict)  # effect -> why (backward step)
    seconds: float = 0.0
    # standard error of each fitted value of the final model (same units), from the
    # Jacobian at the optimum; None where the information matrix is singular there
    standard_errors: dict[str, float | None] = field(default_factory=dict)
    # machine records: the benchmark-defined errors of the closed-loop simulation, per model
    # ("baseline", "final") and record ("train", then each held-out record's name)
    closed_loop: dict[str, dict[str, dict[str, float]]] | None = None


class SimulationProblem:
    """The training replay, held-out replays and the parameter-to-model mapping."""

    def __init__(self, train: RigReplay, validation: Sequence[RigReplay], law: str,
                 threads: int | None = None, coarse: RigReplay | None = None,
                 segment_steps: Sequence[int] = ()):
        self.train = train
        self.validation = list(validation)
        self.law = law
        # (segment_steps: the training record replayed as segments, ``Replayer``)
        self.runner = Replayer(train, threads, segment_steps)
        self.held_runners = [Replayer(r, threads) for r in self.validation]
        # the training record at twice the timestep, for scans that only rank their points
        self.coarse_runner = Replayer(coarse, threads) if coarse is not None else None
        # the measured force (friction, else drive); a record driven by its force: position
        self.primary = next((c for c in ("friction_force_N", "drive_force_N")
                             if c in train.measured), train.channels[0])
        self.noise = dict(train.noise)  # channel -> sd the residual is divided by
        self.weights = {c: 1.0 / train.noise[c] for c in train.channels}
        self.floor = 0.0
        self.other_simulations = 0  # run on replays of its own (segmented, shooting)
        self.say: ProgressFn | None = None  # progress lines while a fit runs (HEARTBEAT_S)
        # initial-state values fitted with the parameters (the training record's only)
        self.state: tuple[str, ...] = tuple(getattr(train, "estimated_state", ()))
        # named values of the scene fitted with the parameters (a machine's joint damping)
        self.scene: tuple[str, ...] = tuple(getattr(train, "fitted_scene_values", ()))

    def reweight(self, fit: SimFit) -> None:
        """Maximum-likelihood channel weights: each channel's sd becomes at least the rms of
        its residual in ``fit``, and its weight is scaled by the square root of its
        residual's effective sample share. A channel that the model cannot follow to its
        white noise (the integral of a noisy measured input, the simulator's own error) then
        weighs by how well it is actually predicted and by how many independent samples its
        misfit has, not by its sensor's resolution and sample count. (Measured on a 60 ms
        Dahl record with every column noisy: the position, about 2 nm rms off at the true
        values, 1 nm of it noise, the rest wandering with the support's measured motion,
        pulled mu and alpha +5 % and +6 %; weighted so, +0.4 % and +0.5 %.)"""
        n = self.train.n
        for j, channel in enumerate(self.train.channels):
            raw = fit.residual[j * n:(j + 1) * n] / self.weights[channel]
            self.noise[channel] = max(self.noise[channel],
                                      math.sqrt(float(np.mean(raw ** 2))))
            # a residual correlated over many samples (the slider's position wandering with
            # the noise of the measured support motion it is driven by) informs as its
            # effective samples do, not as its sample count
            share = min(1.0, effective_samples(raw) / n)
            self.weights[channel] = math.sqrt(share) / self.noise[channel]

    @property
    def _runners(self) -> list[Replayer]:
        return [self.runner, *self.held_runners,
                *([self.coarse_runner] if self.coarse_runner else [])]

    def close(self) -> None:
        for runner in self._runners:
            runner.close()

    @property
    def simulations(self) -> int:
        return sum(r.simulations for r in self._runners) + self.other_simulations

    # -------------------------------------------------------------------- model evaluation

    def case(self, model: Model, values: Mapping[str, float],
             replay: RigReplay | None = None
             ) -> tuple[RigParameters, FrictionParameters, dict[str, float], dict[str, float]]:
        """(rig, friction, initial-state values, the scene's named values) of one
        simulation, as ``Replayer.run`` takes them."""
        replay = replay or self.train
        friction = model.friction_parameters(values, replay.rig.vibration_frequency_Hz or None)
        mass = values.get("mass_kg", replay.rig.mass_kg if replay.mass_known else
                          self.train.rig.mass_kg)
        rig = replay.fitted_rig(values, mass)
        initial = {n: values[n] for n in model.state if n in values} \
            if replay is self.train else {}
        return rig, friction, initial, {n: values[n] for n in model.scene if n in values}

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

    def scan_rss(self, model: Model, qs: Sequence[np.ndarray]) -> list[float]:
        """Weighted RSS of each point of a scan that only ranks its points, run at half the
        substeps (about twice the timestep) where there is a coarser grid (the points differ
        by far more than the simulator's error there; their RSS is not comparable with
        ``residuals``')."""
        runner = self.coarse_runner or self.runner
        outs = runner.run([self.case(model, model.values(q)) for q in qs])
        return [float(r @ r) for r in (self.weighted(o) for o in outs)]

    # --------------------------------------------------------------------------------- fit

    def fit(self, model: Model, start: Mapping[str, float], max_nfev: int,
            race: tuple[int, float] | None = None, label: str = "fit") -> SimFit | None:
        """Least squares from ``start``; with ``race`` (evaluations, rss), None when the RSS
        after that many evaluations is still above that rss. ``label`` names the fit in the
        progress lines a long one writes."""
        q0 = model.internal(start)
        lo, hi = model.bounds()
        cache: dict[bytes, np.ndarray] = {}
        best = {"rss": math.inf, "q": np.array(q0, dtype=float), "stalled": 0, "nfev": 0}
        began = time.monotonic()
        last_said = [began]

        def heartbeat() -> None:
            now = time.monotonic()
            if self.say is None or now - last_said[0] < HEARTBEAT_S or not best["nfev"]:
                return
            last_said[0] = now
            per = (now - began) / best["nfev"]  # (its Jacobians' share included)
            self.say(f"{label}: {best['nfev']} evaluations in {now - began:.0f} s, weighted "
                     f"RSS {best['rss']:.6g}; at most {max_nfev - best['nfev']} more, "
                     f"{per * (max_nfev - best['nfev']):.0f} s at {per:.1f} s each")

        def fun(q: np.ndarray) -> np.ndarray:
            key = np.asarray(q, dtype=float).tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = residual = self.residuals(model, [q])[0]
                best["nfev"] += 1
                rss = float(residual @ residual)
                if rss < best["rss"] * (1.0 - STALL_RELATIVE):
                    best.update(rss=rss, q=np.array(q, dtype=float), stalled=0)
                elif rss < best["rss"] * (1.0 + STALL_BAND):
                    if rss < best["rss"]:
                        best.update(rss=rss, q=np.array(q, dtype=float))
                    best["stalled"] += 1
                    if best["stalled"] >= STALL_EVALUATIONS:
                        raise _Stalled
                if race and best["nfev"] == race[0] and best["rss"] > race[1]:
                    raise _Abandoned
                heartbeat()
            return cache[key]

        def jac(q: np.ndarray) -> np.ndarray:
            columns = self.jacobian(model, q, fun(q))
            heartbeat()
            return columns

        try:
            result = least_squares(fun, q0, jac=jac, bounds=(lo, hi), method="trf",
                                   x_scale="jac", ftol=_TOL, xtol=_TOL, gtol=_TOL,
                                   max_nfev=max_nfev)
        except _Stalled:
            return self.result(model, best["q"], best["nfev"])
        except _Abandoned:
            return None
        # (least_squares returns its last accepted point: the best evaluated one, up to the
        # stall tolerance)
        return self.result(model, result.x, result.nfev)

    def jacobian(self, model: Model, q: np.ndarray, r0: np.ndarray) -> np.ndarray:
        """Forward-difference Jacobian of the weighted residual, all columns in one rollout."""
        _, hi = model.bounds()
        shifted, steps = zip(*forward_steps(q, hi, len(q), _FD_STEP))
        columns = self.residuals(model, shifted)
        return np.column_stack([(r - r0) / h for r, h in zip(columns, steps)])

    def standard_errors(self, fit: SimFit) -> dict[str, float | None]:
        """Standard error of each fitted value: the sandwich covariance
        (J^T J)^-1 (sum_c v_c J_c^T J_c) (J^T J)^-1 in the internal coordinates, J_c channel
        c's rows of the weighted Jacobian and v_c its weighted residual's mean square scaled by
        n / n_eff of that channel (a correlated residual carries less information than its
        sample count; the channels' weights differ from 1 / their sd by their effective sample
        share, ``reweight``), mapped to each value by its derivatives in the coordinates.
        Values of a sine/cosine pair (ripple, modulation) are left out: their amplitude and
        phase are not coordinates."""
        jacobian = self.jacobian(fit.model, fit.q, fit.residual)
        n_all, k = len(fit.residual), fit.k
        names = [p.name for p in fit.model.params if p.name in fit.values]
        # (J^T J)^-1 = V diag(1/s^2) V^T from J's singular values; a direction the record
        # does not inform (s below 1e-6 of the largest) leaves every error undefined, not huge
        _, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
        if singular.size < k or not singular[-1] > 1e-6 * singular[0]:
            return {name: None for name in names}
        bread = (vt.T / singular ** 2) @ vt
        meat = np.zeros((k, k))
        n = self.train.n
        for j in range(len(self.train.channels)):
            rows = slice(j * n, (j + 1) * n)
            r = fit.residual[rows]
            v = float(r @ r) / max(effective_samples(r), 2.0)  # mean square * n / n_eff
            meat += v * jacobian[rows].T @ jacobian[rows]
        covariance = n_all / max(n_all - k, 1) * bread @ meat @ bread
        # d value / d q by differences (a value may depend on several coordinates: mu on the
        # level and the Stribeck curve's)
        at = fit.model.internal_values(fit.q)
        _, hi = fit.model.bounds()
        slopes = np.zeros((len(names), k))
        for j, (q, h) in enumerate(forward_steps(fit.q, hi, k, 1e-6)):
            moved = fit.model.internal_values(q)
            slopes[:, j] = [(moved[name] - at[name]) / h for name in names]
        sd = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", slopes, covariance, slopes), 0.0))
        return {name: float(value) if math.isfinite(value) else None
                for name, value in zip(names, sd)}

    def result(self, model: Model, q: np.ndarray, nfev: int = 0) -> SimFit:
        values = model.values(q)
        extra = ("friction_force_N", "relative_position_m", "relative_velocity_m_per_s")
        predicted = self.predict(model, [values], extra)[0]
        residual = self.weighted(predicted)
        rss = float(residual @ residual)
        channels = {c: record_metrics(self.train.name, predicted[c], self.train.measured[c])
                    for c in self.train.channels}
        held, held_predicted = [], []
        for replay, runner in zip(self.validation, self.held_runners):
            out = runner.run([self.case(model, values, replay)])[0]
            held.append(record_metrics(replay.name, out[self.primary], replay.measured[self.primary]))
            held_predicted.append(out)  # (kept for the report's series: no second replay)
        lo, hi = model.bounds()
        at_bound = tuple(p.name for p, x, a, b in zip(model.params, q, lo, hi)
                         if min(x - a, b - x) <= 1e-6 * max(1.0, abs(x)) and p.name in values)
        return SimFit(model=model, q=np.array(q), values=values, residual=residual, rss=rss,
                      n_eff=effective_samples(residual), train=channels[self.primary],
                      channels=channels, validation=held, nfev=nfev, predicted=predicted,
                      at_bound=at_bound, validation_predicted=tuple(held_predicted))


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
    check_law_and_effects(law, declared, simulation_effects())
    for record in (train, *validation):
        check_identifiable(record)
    replay = prepare_replay(train, substeps=substeps)
    held = [prepare_replay(d, substeps=replay.substeps) for d in validation]
    for h in held:
        if _model_identity(h) != _model_identity(replay):
            raise InputError(f"{h.name}: a held-out record must be of the training record's "
                             f"model ({_model_name(replay)}), not of {_model_name(h)}; check "
                             "the sidecars' 'model'")
        missing = set(replay.channels) - set(h.channels)
        if missing:
            raise InputError(f"{h.name}: held-out record lacks {', '.join(sorted(missing))}, "
                             f"which the training record {replay.name} measures")
    refused = {e: why for e, why in getattr(replay, "not_applicable", {}).items()
               if e in declared}
    if refused:
        raise InputError("--with " + "; ".join(f"{e}: not an effect of this record's model "
                                               f"({why})" for e, why in refused.items()))
    refine = substeps is None and not replay.timestep_from_record
    problems: list[SimulationProblem] = []  # every one made is closed, whatever happens

    def problem_at(steps: int) -> SimulationProblem:
        if steps == replay.substeps:  # already prepared above
            at, at_held = replay, held
        else:
            at = prepare_replay(train, substeps=steps)
            at_held = [prepare_replay(d, substeps=steps) for d in validation]
        coarse = prepare_replay(train, substeps=steps // 2) if steps >= 2 else None
        problems.append(SimulationProblem(at, at_held, law, threads, coarse))
        problems[-1].say = say
        return problems[-1]

    try:
        problem = problem_at(replay.substeps)
        scan = None
        if refine:
            steps, scan = _converged_timestep(problem, train, law, declared, say)
            if steps != replay.substeps:
                problem = problem_at(steps)
        while True:
            still = _still_stage(train)
            try:
                return _identify(problem, law, declared, min_improvement, bic_threshold, say,
                                 started, scan, still, refine)
            except _Unresolved as unresolved:
                # The baseline went where the timestep does not resolve it: halve it and
                # fit again from the baseline's local optima.
                problem = problem_at(2 * problem.train.substeps)
                scan = (unresolved.scales, unresolved.starts, unresolved.origins)
    finally:
        for made in problems:
            made.close()


def _model_identity(replay) -> str:
    """What a replay runs, exactly: a scene's resolved file, else the rig."""
    scene = getattr(replay, "scene", None)
    return str(scene.path) if scene is not None else "rig"


def _model_name(replay) -> str:
    """The model a replay runs: a bundled machine's folder name, else the rig."""
    scene = getattr(replay, "scene", None)
    return scene.name if scene is not None else "rig"


class _Unresolved(Exception):
    """The baseline fit is not resolved by the timestep (raised to refine it)."""

    def __init__(self, scales: Scales, starts: list[dict[str, float]], origins: list[str]):
        super().__init__("timestep too coarse for the baseline")
        self.scales, self.starts, self.origins = scales, starts, origins


def _converged_timestep(problem: SimulationProblem, train: Dataset, law: str,
                        declared: Sequence[str], say: ProgressFn) -> tuple[int, tuple]:
    """Steps a sample from halving the MuJoCo timestep until the best start of the scan changes
    by less than ``START_TIMESTEP_TOLERANCE`` noise sd (rms over the channels) when it is halved
    again: the simulator's error then stays below the record's noise (or ``MAX_SUBSTEPS`` is
    reached). Returns them and the scan (scales, starts) they were checked with."""
    fit_mass = not problem.train.mass_known
    declared = tuple(e for e in simulation_effects() if e in declared)
    scales, starts = _start(problem, law, fit_mass, declared)
    model = Model.build(law, declared, fit_mass, scales, FrictionParameters(law=law),
                        problem.state, problem.scene)
    case = problem.case(model, model.values(model.internal(starts[0])))
    steps = problem.train.substeps
    coarse_dt = problem.train.timestep_s
    with Replayer(problem.train, problem.runner.threads) as runner:
        coarse = runner.run([case])[0]
    sd = dict(problem.noise)
    if getattr(problem.train, "timestep_in_fit_weights", False):
        # A machine's friction model misses the record by far more than its sensors' noise:
        # judged in each channel's sd as the fit will take it (at least the start's residual
        # rms; the baseline is checked again in its own), not in white-noise units.
        for c in problem.train.channels:
            rms = math.sqrt(float(np.mean((coarse[c] - problem.train.measured[c]) ** 2)))
            sd[c] = max(sd[c], rms)
    while 2 * steps <= MAX_SUBSTEPS:
        finer = prepare_replay(train, substeps=2 * steps)
        with Replayer(finer, problem.runner.threads) as runner:
            fine = runner.run([case])[0]
        change = np.concatenate([(fine[c] - coarse[c]) / sd[c] for c in problem.train.channels])
        rms = math.sqrt(float(change @ change) / len(change))
        say(f"timestep {coarse_dt:.4g} s: halving it changes the prediction by "
            f"{rms:.3g} sd (rms)" + ("" if rms <= START_TIMESTEP_TOLERANCE else "; halving"))
        if rms <= START_TIMESTEP_TOLERANCE:
            break
        steps, coarse, coarse_dt = 2 * steps, fine, finer.timestep_s
    return steps, (scales, starts)


def _identify(problem: SimulationProblem, law: str, declared: Sequence[str],
              min_improvement: float, bic_threshold: float, say: ProgressFn,
              started: float, scan: tuple | None = None,
              still: Dataset | None = None, refine: bool = False) -> SimIdentification:
    """The baseline (``_baseline``), then forward selection (``driver.select`` over
    ``_SimulationRounds``); ``_Unresolved`` when the baseline asks for a finer timestep."""
    replay = problem.train
    fit_mass = not replay.mass_known
    say(f"{replay.name}: {replay.n} samples, measured {', '.join(replay.channels)}; "
        f"MuJoCo rig at dt {replay.timestep_s:.4g} s ({replay.steps_per_sample:.4g} step(s) a "
        f"sample{', sliding along the vibration' if replay.sliding else ''}), "
        f"law {law}" + (", mass identified" if fit_mass else "") +
        (", the support still (its measured velocity holds only its sensor's noise)"
         if getattr(replay, "support_still", False) else "") +
        (f", {len(problem.validation)} held-out record(s)" if problem.validation else ""))
    skipped = _not_applicable(replay, law, declared)
    declared = tuple(e for e in simulation_effects() if e in declared and e not in skipped)
    baseline = _baseline(problem, law, declared, fit_mass, say, scan, still, refine)
    back_end = _SimulationRounds(problem, baseline.scales, baseline.local, declared,
                                 min_improvement, bic_threshold, say)
    remaining = [e for e in simulation_effects() if e not in declared and e not in skipped
                 and e not in excluded_by(declared)]
    selection = select(back_end, baseline.fit, remaining, say)
    current = selection.final
    errors = problem.standard_errors(current)
    say("final: " + ", ".join(f"{n} {current.values[n]:.6g}" +
                              (f" +- {e:.2g}" if e is not None else "")
                              for n, e in errors.items()))
    peaks = _residual_peaks(problem, current)
    closed_loop = None
    if hasattr(replay, "scene"):
        closed_loop = {label: _closed_loop_errors(problem, fit)
                       for label, fit in (("baseline", baseline.fit), ("final", current))}
    return SimIdentification(
        law=law, declared=declared, train=replay, validation=problem.validation,
        primary=problem.primary, baseline=baseline.fit, final=current,
        candidates=selection.candidates, rounds=selection.rounds,
        selected=selection.selected, skipped=skipped, dropped=back_end.dropped,
        numerical_floor=problem.floor,
        residual_peaks_Hz=peaks,
        settings={"method": "simulation", "substeps": replay.substeps,
                  "steps_per_sample": replay.steps_per_sample,
                  "timestep_s": replay.timestep_s, "min_improvement": min_improvement,
                  "bic_threshold": bic_threshold, "fit_mass": fit_mass,
                  "noise_sd": dict(problem.noise), "stick_phases": baseline.stick_phases,
                  "baseline_start": baseline.start,
                  "support_still": bool(getattr(replay, "support_still", False))},
        simulations=problem.simulations, seconds=time.monotonic() - started,
        standard_errors=errors, closed_loop=closed_loop)


# ------------------------------------------------------------------------------- baseline

@dataclass(frozen=True, eq=False)
class _Baseline:
    fit: SimFit  # the best
    local: list[SimFit]  # its distinct local optima, best first (``fit`` among them)
    scales: Scales
    start: str  # where the best fit's start came from
    stick_phases: int  # of a stick-slip record (0: none, or not looked for)


def _baseline(problem: SimulationProblem, law: str, declared: Sequence[str], fit_mass: bool,
              say: ProgressFn, scan: tuple | None, still: Dataset | None,
              refine: bool) -> _Baseline:
    """The baseline fitted from every start (the scan's, the still stage's, a stick-slip
    record's segmented ones, the Stribeck restarts), its channels reweighted and the
    simulator's error floor set (``_check_timestep``)."""
    replay = problem.train
    # (a scan carried over from a coarser timestep: the local optima found there, each with
    # where its start came from; a stick-slip record's segmented stage is not run again)
    scales, starts, *carried = scan or _start(problem, law, fit_mass, declared)
    carried_origins = carried[0] if carried and len(carried[0]) == len(starts) else None
    # A finer timestep after a baseline the coarser one did not resolve: the starts are that
    # baseline's local optima, its basins already explored (the scan, the still stage, the
    # Stribeck restarts): the best is fitted again, the others are carried as they stand for
    # round 1's screening. (EMPS with a declared Stribeck curve: the whole baseline again at
    # each refinement, on 2 busy cores, had refitted every start and restart: 200 s each.)
    refining = carried_origins is not None
    model = Model.build(law, declared, fit_mass, scales, FrictionParameters(law=law),
                        problem.state, problem.scene)
    say(f"baseline: fitting {model.k} parameters ({', '.join(model.names)}) " + (
        f"again from the coarser timestep's best fit ({len(starts) - 1} other local "
        "optimum/optima carried as they stand)" if refining else
        f"from the {len(starts)} best start(s) of a scan"))
    # Several starts: a record that measures little of the contact (position and drive force
    # only) has more than one basin in the contact stiffness.
    scanned = len(starts)
    if still is not None and not refining:
        starts = [*starts, *_still_starts(problem, model, still, starts[0], say)]
    fits, origin = _fit_starts(problem, model, starts, scanned, carried_origins, say)
    stick_phases = _fit_segmented_starts(problem, model, fits, origin, say) \
        if isinstance(replay, RigReplay) and not carried_origins else 0
    if "stribeck" in model.effects and not refining:
        _fit_stribeck_restarts(problem, model, fits, origin, say)
    local = _distinct(problem, sorted(fits, key=lambda fit: fit.rss))
    if refining and local[0] is not fits[0]:
        # a carried optimum, only re-evaluated, is now below the refitted best: fit it too
        # (the baseline is always a fit at this step)
        refit = problem.fit(model, model.internal_values(local[0].q), BASELINE_EVALUATIONS,
                            label="baseline: a carried optimum fitted again")
        origin[id(refit)] = origin.get(id(local[0]), "the scan")
        local = _distinct(problem, sorted([refit, *local], key=lambda fit: fit.rss))
    baseline = local[0]
    baseline_start = origin.get(id(baseline), "the scan")
    if len(replay.channels) > 1:
        baseline, local = _reweighted(problem, model, local, say)
    _check_timestep(problem, model, scales, baseline, local, origin, refine, say)
    return _Baseline(fit=baseline, local=local, scales=scales, start=baseline_start,
                     stick_phases=stick_phases)


def _still_starts(problem: SimulationProblem, model: Model, still: Dataset,
                  start: dict[str, float], say: ProgressFn) -> list[dict[str, float]]:
    """Two more baseline starts from the stage before the vibration, which shows the contact
    alone (pre-sliding, breakaway): fitted at once, and over growing windows of it
    (``STILL_WINDOWS``) each from the last, from ``start`` (at once was measured the better
    start of a position-only record with a hidden Stribeck peak; the windows, of a
    noise-free record of a LuGre law with its peak)."""
    substeps = problem.train.substeps
    stage = SimulationProblem(prepare_replay(still, substeps=substeps), [], problem.law,
                              problem.runner.threads)
    try:
        at_once = model.internal_values(stage.fit(model, start, BASELINE_EVALUATIONS).q)
    finally:
        stage.close()
    for fraction in STILL_WINDOWS:
        rows = max(4 * MIN_SAMPLES, int(fraction * still.n_rows))
        window = prepare_replay(_first_rows(still, rows), substeps=substeps)
        stage = SimulationProblem(window, [], problem.law, problem.runner.threads)
        try:
            start = model.internal_values(stage.fit(model, start, BASELINE_EVALUATIONS).q)
        finally:
            stage.close()
    say(f"baseline: the {still.n_rows} samples before the vibration starts, fitted at "
        f"once and over {len(STILL_WINDOWS)} growing windows, give two more starts")
    return [at_once, start]


def _race(fits: Sequence[SimFit]) -> tuple[int, float]:
    """A later start's race against the best baseline fit so far (``RACE_RATIO``)."""
    return RACE_EVALUATIONS, RACE_RATIO * min(f.rss for f in fits)


def _fit_starts(problem: SimulationProblem, model: Model, starts: Sequence[dict[str, float]],
                scanned: int, carried_origins: Sequence[str] | None, say: ProgressFn
                ) -> tuple[list[SimFit], dict[int, str]]:
    """The baseline fitted from each start (the first ``scanned`` from the scan, racing the
    best so far; the others the still stage's); with ``carried_origins``, a finer timestep's
    refit, only the first is fitted and the others are carried as they stand. Returns the
    fits and where each one's start came from (by ``id``, for the report)."""
    refining = carried_origins is not None
    fits: list[SimFit] = []
    origin: dict[int, str] = {}  # id(fit) -> where its start came from (for the report)
    for index, start in enumerate(starts):
        if refining and index > 0:
            fits.append(problem.result(model, model.internal(start)))
            origin[id(fits[-1])] = carried_origins[index]
            continue
        # (the still stage's starts are fitted in full: they stand for another basin)
        race = _race(fits) if fits and index < scanned else None
        fit = problem.fit(model, start, BASELINE_EVALUATIONS, race,
                          label=f"baseline: start {index + 1} of {len(starts)}")
        if fit is not None:
            fits.append(fit)
            origin[id(fit)] = carried_origins[index] if carried_origins else \
                "the scan" if index < scanned else "the still stage"
    if len(fits) < len(starts):
        say(f"baseline: {len(starts) - len(fits)} start(s) abandoned, still above "
            f"{RACE_RATIO:g} times the best fit's RSS after {RACE_EVALUATIONS} evaluations")
    return fits, origin


def _fit_segmented_starts(problem: SimulationProblem, model: Model, fits: list[SimFit],
                          origin: dict[int, str], say: ProgressFn) -> int:
    """The baseline fitted from a stick-slip record's segmented starts
    (``_segmented_starts``), added to ``fits`` and ``origin``; returns the stick phases."""
    stick_phases, segmented = _segmented_starts(problem, model, say)
    for index, (label, start) in enumerate(segmented):
        # (the first, multiple shooting's, is fitted in full; the others race it)
        race = _race(fits) if index else None
        fit = problem.fit(model, start, BASELINE_EVALUATIONS, race,
                          label=f"baseline: from {label}")
        if fit is not None:
            fits.append(fit)
            origin[id(fit)] = label
        say(f"baseline: from {label}, " +
            (f"{problem.primary} relerr {fit.train.relerr_pct:.3g} % over the whole record "
             f"({fit.nfev} evaluations)" if fit is not None else
             f"abandoned after {RACE_EVALUATIONS} evaluations"))
    return stick_phases


def _fit_stribeck_restarts(problem: SimulationProblem, model: Model, fits: list[SimFit],
                           origin: dict[int, str], say: ProgressFn) -> None:
    """A declared Stribeck curve fitted again from the shapes of ``_STRIBECK_RESTARTS`` at
    the best fit's contact, added to ``fits`` and ``origin``."""
    restarts = _stribeck_restarts(model, min(fits, key=lambda fit: fit.rss))
    for index, start in enumerate(restarts):
        # (the first is fitted in full: from the baseline's basin it is far at first)
        race = _race(fits) if index else None
        fit = problem.fit(model, start, BASELINE_EVALUATIONS, race,
                          label=f"baseline: Stribeck restart {index + 1} of "
                                f"{len(restarts)}")
        if fit is not None:
            fits.append(fit)
            origin[id(fit)] = "a Stribeck restart"
    say(f"baseline: the Stribeck curve fitted again from {len(restarts)} shapes at the "
        "best fit's contact")


def _reweighted(problem: SimulationProblem, model: Model, local: Sequence[SimFit],
                say: ProgressFn) -> tuple[SimFit, list[SimFit]]:
    """The best baseline refitted with the channel sd from its residual
    (``SimulationProblem.reweight``), the other local optima evaluated again with them:
    (the best, all of them best first)."""
    problem.reweight(local[0])
    baseline = problem.fit(model, model.internal_values(local[0].q), BASELINE_EVALUATIONS,
                           label="baseline: refit with the channel sd from its residual")
    local = sorted([baseline] + [problem.result(model, fit.q) for fit in local[1:]],
                   key=lambda fit: fit.rss)
    say("baseline: channel sd from its residual: " + ", ".join(
        f"{c} {problem.noise[c]:.3g}" for c in problem.train.channels))
    return local[0], local


def _check_timestep(problem: SimulationProblem, model: Model, scales: Scales,
                    baseline: SimFit, local: Sequence[SimFit], origin: Mapping[int, str],
                    refine: bool, say: ProgressFn) -> None:
    """Set the simulator's error floor (``problem.floor``) from the baseline replayed at half
    the timestep; with ``refine``, ``_Unresolved`` (from ``local``'s values) when that
    changes the prediction by more than ``TIMESTEP_TOLERANCE``."""
    replay = problem.train
    change = _halved_change(problem, baseline)
    problem.floor = float(np.sum((change * _stacked(problem, problem.weights)) ** 2))
    # Judged in each channel's sd as the fit takes it (at least its residual's rms): a misfit
    # far above the noise (stick-slip not yet modelled) is not refined for ever. (Not in the
    # weights themselves: their effective-sample share says how much a channel informs, not
    # how large an error its noise hides; with it, EMPS stopped at one step a sample and its
    # force error rose from 4.37 % to 4.60 %.)
    per_sd = {c: 1.0 / problem.noise[c] for c in replay.channels}
    floor_rms = math.sqrt(float(np.sum((change * _stacked(problem, per_sd)) ** 2)) / len(change))
    if refine and floor_rms > TIMESTEP_TOLERANCE and 2 * replay.substeps <= MAX_SUBSTEPS:
        say(f"baseline: halving the timestep changes its prediction by {floor_rms:.3g} "
            f"(weighted rms); halving it and fitting again")
        raise _Unresolved(scales, [model.internal_values(f.q) for f in local],
                          [origin.get(id(f), "the scan") for f in local])
    say(f"baseline: {problem.primary} relerr {baseline.train.relerr_pct:.3g} %; simulator "
        f"error floor {math.sqrt(problem.floor / len(baseline.residual)):.3g} (weighted rms)")


# ------------------------------------------------------------------------------ selection

class _SimulationRounds:
    """The simulation path's rounds for ``driver.select``: each candidate screened
    linearized, the promising ones fitted, the leaders converged; a choice that was not
    converged is refitted; the backward step drops an earlier effect that the same test no
    longer justifies (``_drop_if_unneeded``)."""

    round_action = "screening"

    def __init__(self, problem: SimulationProblem, scales: Scales, local: Sequence[SimFit],
                 declared: Sequence[str], min_improvement: float, bic_threshold: float,
                 say: ProgressFn):
        self.problem, self.scales, self.say = problem, scales, say
        self.local = list(local)  # the baseline's local optima, best first
        self.declared = tuple(declared)
        self.min_improvement, self.bic_threshold = min_improvement, bic_threshold
        self.dropped: dict[str, str] = {}  # effect -> why (backward step)
        self._converged: set[str] = set()  # the last round's leaders, fitted to convergence

    def evaluate_round(self, current: SimFit, remaining: Sequence[str],
                       index: int) -> list[SimCandidate]:
        problem, min_improvement = self.problem, self.min_improvement
        # Round 1 screens at every local optimum of the baseline: an effect missing from the
        # model can pull the best baseline into another basin than the one it belongs to.
        screens = _screen(problem, current, self.local if index == 1 else [current],
                          remaining, self.scales)
        ranked = sorted(remaining, key=lambda e: screens[e][1])
        # (a linearized drop far below the improvement asked is not fitted in full, except
        # for the effects far from linear in their values)
        promising = [e for e in ranked if screens[e][1] < 0 and (
            e in _NONLINEAR_EFFECTS or screens[e][4] >= LINEARIZED_DROP_FRACTION *
            min_improvement)]
        fitted = promising[:SCREENED_FITS]
        evaluated = []
        for effect in ranked:
            start, screen_dbic, seconds, at, screen_drop = screens[effect]
            if effect in fitted:
                c = _candidate(problem, current, at, effect, self.scales, index,
                               min_improvement, self.bic_threshold, start, screen_dbic, seconds)
            else:
                c = _screened_out(current, effect, index, effect in promising, screen_dbic,
                                  screen_drop, seconds, min_improvement)
            evaluated.append(c)
            self.say(f"  {c.effect:<24s} screen {screen_dbic:8.1f}  " + (
                f"dBIC {c.delta_bic:8.1f}  {problem.primary} relerr "
                f"{c.fit.train.relerr_pct:.4g} % ({100 * c.train_drop:+.1f} %)  "
                if c.fitted else "") +
                f"[{c.seconds:.1f} s]  {'justified' if c.justified else 'no: ' + c.reason}")
        self._converge_leaders(current, evaluated, index)
        return evaluated

    def _converge_leaders(self, current: SimFit, evaluated: list[SimCandidate],
                          index: int) -> None:
        """The leading candidates' fits (a few evaluations each) converged before the choice,
        in place in ``evaluated``: a strongly nonlinear effect (a Stribeck peak's stick-slip)
        may still be far from its optimum where a flexible imitation (a ripple) already looks
        better."""
        problem = self.problem
        leaders = sorted((c for c in evaluated if c.justified),
                         key=lambda c: c.delta_bic)[:CONVERGED_LEADERS]
        self._converged = {c.effect for c in leaders}
        for leader in leaders:
            begun = time.monotonic() - leader.seconds
            refit = problem.fit(leader.fit.model, leader.fit.model.internal_values(leader.fit.q),
                                BASELINE_EVALUATIONS, label=f"round {index}: {leader.effect} "
                                                            "converged")
            if refit.rss < leader.fit.rss:
                c = _judge(problem, current, refit, leader.effect, index, self.min_improvement,
                           self.bic_threshold, leader.screen_delta_bic, begun)
                evaluated[evaluated.index(leader)] = c
                self.say(f"  {c.effect:<24s} converged: dBIC {c.delta_bic:8.1f}  "
                         f"{problem.primary} relerr {c.fit.train.relerr_pct:.4g} %")

    def accept(self, best: SimCandidate, current: SimFit, index: int) -> SimCandidate:
        if best.effect in self._converged:
            return best
        # the next round's candidates, a few evaluations each, must not be credited with the
        # rest of this fit's descent
        refit = self.problem.fit(best.fit.model, best.fit.model.internal_values(best.fit.q),
                                 BASELINE_EVALUATIONS)
        return replace(best, fit=refit) if refit.rss < best.fit.rss else best

    def selected_note(self, accepted: SimCandidate) -> str:
        return (f" ({self.problem.primary} relerr {accepted.fit.train.relerr_pct:.4g} % after "
                "refitting)")

    def backward_step(self, current: SimFit, selected: list[str], index: int,
                      final: bool) -> SimFit:
        if not final:
            # An effect chosen earlier as a stand-in for this one (an offset for a
            # modulation's mean) is dropped when the model without it is as good by the same
            # test.
            for earlier in [e for e in selected[:-1] if e not in self.declared]:
                current = _drop_if_unneeded(self.problem, current, earlier, selected,
                                            self.dropped, f"round {index}", self.bic_threshold,
                                            self.say, self.scales)
        elif selected and selected[-1] not in self.declared:
            # ... and the last choice too, once nothing more is chosen: a fit that found its
            # way out of a poor baseline's basin through an effect may no longer need it
            # (measured: a staged noise-free position-only Dahl record selected an offset of
            # 1.6e-9 N, its law exact; the baseline had stopped 0.7 % off)
            current = _drop_if_unneeded(self.problem, current, selected[-1], selected,
                                        self.dropped, "after the last round",
                                        self.bic_threshold, self.say, self.scales)
        return current


def _screened_out(current: SimFit, effect: str, index: int, promising: bool,
                  screen_dbic: float, screen_drop: float, seconds: float,
                  min_improvement: float) -> SimCandidate:
    """A candidate the screen did not fit in full (its ``fit`` is the round's model)."""
    why = (f"linearized dBIC {screen_dbic:.1f} not below 0" if screen_dbic >= 0
           else f"linearized weighted RMSE drop {100 * screen_drop:.2f} %, under "
                f"{LINEARIZED_DROP_FRACTION:g} of the {100 * min_improvement:g} % "
                "asked" if not promising
           else f"linearized dBIC {screen_dbic:.1f}: not among the "
                f"{SCREENED_FITS} best")
    return SimCandidate(effect=effect, fit=current, delta_bic=0.0, train_drop=0.0,
                        validation_log_ratio=None, tone_delta_bic=None,
                        tone_frequency_Hz=None, round=index, justified=False,
                        reason=f"screened out ({why})", seconds=seconds,
                        screen_delta_bic=screen_dbic, fitted=False)


def _drop_if_unneeded(problem: SimulationProblem, current: SimFit, effect: str,
                      selected: list[str], dropped: dict[str, str], when: str,
                      bic_threshold: float, say: ProgressFn, scales: Scales) -> SimFit:
    """``current`` without ``effect`` (removed from ``selected``, noted in ``dropped``) when
    the model without it passes the selection's test against it; else ``current``."""
    model = current.model
    reduced = Model.build(model.law, [e for e in model.effects if e != effect], model.fit_mass,
                          scales, model.base, model.state, model.scene)
    start = {k: v for k, v in current.model.internal_values(current.q).items()
             if k in reduced.names}
    # The RSS at which the test would drop the effect (at the current model's n_eff): a fit
    # still DROP_RACE_RATIO times above it after RACE_EVALUATIONS evaluations is abandoned and
    # the effect kept (EMPS: the model without its asymmetry, 1.8 times above, descending for
    # 60 evaluations, 180 s, to stay there).
    n_now = max(current.n_eff, 2.0)
    needed = (current.rss + problem.floor) * math.exp(
        ((current.k - reduced.k) * math.log(n_now) - bic_threshold) / n_now) - problem.floor
    without = problem.fit(reduced, start, BASELINE_EVALUATIONS,
                          (RACE_EVALUATIONS, DROP_RACE_RATIO * needed),
                          label=f"{when}: the model without {effect}")
    if without is None:
        return current
    n_eff = max(without.n_eff, 2.0)
    keep_dbic = n_eff * math.log((current.rss + problem.floor) /
                                 (without.rss + problem.floor)) + \
        (current.k - reduced.k) * math.log(n_eff)
    # (the held-out records count here as in the forward step, or an effect they justified
    # would be dropped at once)
    keep_dbic += held_out_evidence(n_eff, len(current.residual),
                                   [r.n for r in problem.validation], current.validation,
                                   without.validation)
    if keep_dbic < bic_threshold:
        return current
    selected.remove(effect)  # (and not a candidate again: no cycles)
    dropped[effect] = f"dropped {when}: keeping it, dBIC {keep_dbic:.1f}"
    say(f"{when}: dropped {effect} (keeping it: dBIC {keep_dbic:.1f})")
    return without


def _closed_loop_errors(problem: SimulationProblem, fit: SimFit) -> dict[str, dict]:
    """A machine's closed-loop errors as its benchmark defines them, on every record."""
    from .machine_replay import closed_loop_errors
    extra = ("position_m", "velocity_m_per_s")  # (and every measured channel)
    # the training record's prediction is the fit's own (a machine's relative velocity is
    # its velocity); held-out records are simulated here
    train = {"velocity_m_per_s": fit.predicted["relative_velocity_m_per_s"], **fit.predicted}
    out = {"train": closed_loop_errors(problem.train, train)}
    for replay, runner in zip(problem.validation, problem.held_runners):
        predicted = runner.run([problem.case(fit.model, fit.values, replay)], extra)[0]
        out[replay.name] = closed_loop_errors(replay, predicted)
    return out


def _still_stage(dataset: Dataset) -> Dataset | None:
    """The record's first stage before the support starts to vibrate (None when there is none
    of at least a fifth of the record)."""
    velocity = np.abs(np.asarray(dataset.support_velocity_m_per_s, dtype=float))
    if not dataset.metadata.vibration_frequency_Hz or not np.any(velocity > 0):
        return None
    moving = np.flatnonzero(velocity > STILL_FRACTION * velocity.max())
    first = int(moving[0]) if len(moving) else len(velocity)
    if first < max(64, len(velocity) // 5) or first > 0.9 * len(velocity):
        return None
    return _first_rows(dataset, first, " (before the vibration)")


def _first_rows(dataset: Dataset, rows: int, label: str = "") -> Dataset:
    return Dataset(name=f"{dataset.name}{label}", metadata=dataset.metadata,
                   columns={c: np.asarray(v)[:rows] for c, v in dataset.columns.items()})


def _not_applicable(replay: RigReplay, law: str, declared: Sequence[str]) -> dict[str, str]:
    out: dict[str, str] = dict(getattr(replay, "not_applicable", {}))
    reason = None
    if not replay.vibrating:
        reason = "the support does not vibrate (no support motion or no vibration_frequency_Hz)"
    elif getattr(replay, "normal_force_from_record", False):  # (a machine replay has none)
        reason = "the record measures the normal load (normal_force_N), which the replay " \
            "applies as it is"
    dt = float(np.median(np.diff(replay.time_s)))
    for effect, why in modulation_not_applicable(
            reason, replay.rig.vibration_frequency_Hz, dt).items():
        out.setdefault(effect, why)
    return without_declared(out, declared)


# ------------------------------------------------------------------------------- starting

def _start(problem: SimulationProblem, law: str, fit_mass: bool,
           declared: Sequence[str] = ()) -> tuple[Scales, list[dict[str, float]]]:
    """Scales and the best starts of a scan simulated in batches: the level and the
    characteristic deflection together (the record's drive force ties them), then the
    shape (Dupont's breakaway, a declared Stribeck curve) around the best of those."""
    replay = problem.train
    normal = replay.rig.normal_force_N
    level, levels = replay.start_levels(_LEVEL_SCAN)
    dt = float(np.median(np.diff(replay.time_s)))
    sliding = replay.sliding_speeds_m_per_s
    scales = Scales(force_N=level, velocity_m_per_s=replay.velocity_scale_m_per_s,
                    normal_force_N=normal, dt_s=dt,
                    travel_m=_travel_m(replay),
                    sliding_speeds_m_per_s=sliding,
                    position_range_m=_position_range_m(replay),
                    # (the maps' knots: the top of the estimated sliding speeds; the
                    # replay's MuJoCo time, 0 at the first sample)
                    top_speed_m_per_s=max((*sliding, replay.velocity_scale_m_per_s)),
                    time_range_s=(0.0, float(replay.time_s[-1] - replay.time_s[0])))
    model = Model.build(law, declared, fit_mass, scales, FrictionParameters(law=law),
                        problem.state, problem.scene)

    def best(trials: list[tuple], count: int) -> list[tuple]:
        values = [_scan_point(problem, fit_mass, *trial) for trial in trials]
        rss = problem.scan_rss(model, [model.internal(_internal_names(model, v))
                                       for v in values])
        order = np.argsort(rss)
        return [trials[i] for i in order[:count]]

    deflections = deflection_scan_m(scales.travel_m) if law != "coulomb" else [None]
    stage = best([(lv, x, {}) for lv in levels for x in deflections], BASELINE_STARTS)
    shapes = []
    if law == "dupont":
        shapes = [{"breakaway_ratio": b} for b in _BREAKAWAY_SCAN]
    if "stribeck" in declared:
        # At static_ratio 1 the Stribeck velocity has no gradient: scan both.
        curves = [{"static_ratio": ratio, "stribeck_velocity_m_per_s": r * scales.velocity_m_per_s}
                  for ratio in (1.2, 1.6) for r in (0.3, 1.0, 3.0)]
        shapes = [{**a, **c} for a in (shapes or [{}]) for c in curves]
    if shapes:
        stage = best([(lv, x, shape) for lv, x, _ in stage for shape in shapes],
                     BASELINE_STARTS)
    return scales, [_internal_names(model, _scan_point(problem, fit_mass, *trial))
                    for trial in stage]


def _scan_point(problem: SimulationProblem, fit_mass: bool, level_N: float,
                deflection_m: float | None, shape: Mapping[str, float]) -> dict[str, float]:
    """The values of one point of a start scan: a friction level (with a Stribeck curve its
    peak, mu F_N static_ratio), the contact's characteristic deflection (None: Coulomb) and
    the shape's values."""
    replay = problem.train
    values = {"friction_coefficient": level_N / replay.rig.normal_force_N /
              shape.get("static_ratio", 1.0),
              "alpha": 1.0, "breakaway_ratio": 0.7, "bristle_damping_N_s_per_m": 0.0, **shape}
    if deflection_m is not None:
        k_t = level_N / deflection_m
        values["contact_stiffness_N_per_m"] = k_t
        if problem.law == "lugre":
            values["bristle_damping_N_s_per_m"] = lugre_default_bristle_damping(
                k_t, replay.rig.mass_kg)
    if fit_mass:
        values["mass_kg"] = replay.rig.mass_kg
    if "initial_velocity_m_per_s" in problem.state:
        values["initial_velocity_m_per_s"] = replay.initial_velocity_m_per_s
    return values


def _segmented_starts(problem: SimulationProblem, model: Model, say: ProgressFn
                      ) -> tuple[int, list[tuple[str, dict[str, float]]]]:
    """(stick phases, [(where it came from, start)]) for the whole-record fit of a stick-slip
    record, from its segmented replay: the multiple-shooting fit's first, then the segmented
    fits'.

    In stick-slip a slightly wrong static level shifts every later slip, and a fit over the
    whole record (single shooting) stays near its start (measured: a noise-free 0.2 s
    stick-slip record of the plugin's LuGre rig, static ratio 1.5, came back at 1.2 with the
    drive force 26 % off). Replayed as segments that start at its stick phases
    (``replay.stick_phase_steps``), an error carries over one slip at most and the cost is
    smooth around the true values (measured there: a single basin in the static ratio and
    the contact stiffness, where the whole record's cost has several). A scan of the level,
    the contact and the shape together (``SEGMENTED_SCAN_*``), ranked by the segmented cost,
    and segmented fits from its best points follow. The segments' starts are the record's
    estimates, which bias that fit a little (measured: the contact's damping 7.6 % off); a
    multiple-shooting fit (``shooting.MultipleShooting``: the start states fitted too, with
    continuity) from the best removes the bias. The whole-record fit from these starts
    decides, so the model fitted is always the one users simulate. (Not with a sensor lag:
    a lagged sensor's state at a segment's start is not in the record.)"""
    replay = problem.train
    steps = stick_phase_steps(replay)
    if len(steps) < MIN_SLIPS:
        return len(steps), []
    if "sensor_lag" in model.effects:
        say(f"baseline: {len(steps)} stick phases after a slip, not replayed as segments: a "
            "lagged sensor's state at a segment's start is not in the record")
        return len(steps), []
    segmented = SimulationProblem(replay, [], problem.law, problem.runner.threads,
                                  segment_steps=steps)
    segmented.noise, segmented.weights = dict(problem.noise), dict(problem.weights)
    try:
        _, levels = replay.start_levels(_LEVEL_SCAN)
        deflections = deflection_scan_m(_travel_m(replay))[::2] \
            if problem.law != "coulomb" else [None]
        shapes = [{}]
        if problem.law == "dupont":
            shapes = [{"breakaway_ratio": b} for b in _BREAKAWAY_SCAN]
        if problem.law == "dahl":  # (the shape of Dahl's loading curve, up to the slip)
            shapes = [{"alpha": a} for a in SEGMENTED_ALPHA_SCAN]
        if "stribeck" in model.effects:
            # The slips start where the spring's force reaches the static level (the peak
            # scanned): near the largest measured force.
            force = replay.measured.get("friction_force_N", replay.measured.get("drive_force_N"))
            levels = [float(np.max(np.abs(force))) * f for f in SEGMENTED_PEAK_SCAN]
            v_scale = next(p for p in model.params
                           if p.name == "stribeck_velocity_m_per_s").scale
            shapes = [{**shape, "static_ratio": ratio, "stribeck_velocity_m_per_s": r * v_scale}
                      for shape in shapes for ratio in SEGMENTED_SCAN_RATIOS
                      for r in SEGMENTED_SCAN_SPEEDS]
        fit_mass = "mass_kg" in model.names
        # The initial state as the record estimates it: fitted, the slider's initial velocity
        # (seen by the first segment only) took up what the others' fixed starts miss
        # (measured: -1.6 mm/s on a record starting at rest, a basin the whole-record fit
        # did not leave).
        fixed_state = replace(model, state=(), params=tuple(
            p for p in model.params if p.name not in model.state))
        trials = [_internal_names(model, _scan_point(problem, fit_mass, lv, x, shape))
                  for lv in levels for x in deflections for shape in shapes]
        rss = segmented.scan_rss(model, [model.internal(v) for v in trials])
        say(f"baseline: {len(steps)} stick phases after a slip: the record replayed as "
            f"{len(steps) + 1} segments started there; {len(trials)} scan points ranked by it")
        starts, fitted = [], []
        for i in np.argsort(rss)[:SEGMENTED_STARTS]:
            fit = segmented.fit(fixed_state, trials[int(i)], SEGMENTED_EVALUATIONS)
            starts.append({**trials[int(i)], **fixed_state.internal_values(fit.q)})
            fitted.append(fit.rss)
            say(f"baseline: segmented fit from scan point {len(starts)}: {problem.primary} "
                f"relerr {fit.train.relerr_pct:.3g} % ({fit.nfev} evaluations)")
    finally:
        problem.other_simulations += segmented.simulations
        segmented.close()
    # The segments' start states fitted too, from the best segmented fit: its bias removed
    shooting = MultipleShooting(problem, fixed_state, steps)
    try:
        best = starts[int(np.argmin(fitted))]
        started = time.monotonic()
        shot = [("multiple shooting", {**best, **shooting.fit(best)})]
        say(f"baseline: multiple shooting from the best, start states fitted "
            f"({time.monotonic() - started:.1f} s)")
    except ValueError as error:  # (least_squares on a non-finite residual)
        say(f"baseline: multiple shooting failed ({error}); the segmented fits start the "
            "whole-record fits alone")
        shot = []
    finally:
        problem.other_simulations += shooting.runner.simulations
        shooting.close()
    return len(steps), shot + [("a segmented replay", start) for start in starts]


# Two local optima whose predictions differ by less than this (rms, in noise sd) are one: starts
# that converged to the same model (up to a direction the record does not inform) are screened
# once.
SAME_OPTIMUM_SD = 0.05


def _distinct(problem: SimulationProblem, fits: Sequence[SimFit]) -> list[SimFit]:
    """``fits`` (best first) without the ones that predict what a better one predicts."""
    kept: list[SimFit] = []
    for fit in fits:
        if all(_prediction_distance(problem, fit, other) > SAME_OPTIMUM_SD for other in kept):
            kept.append(fit)
    return kept


def _prediction_distance(problem: SimulationProblem, a: SimFit, b: SimFit) -> float:
    """rms difference of two fits' predictions of the measured channels, in noise sd."""
    change = np.concatenate([(a.predicted[c] - b.predicted[c]) * problem.weights[c]
                             for c in problem.train.channels])
    return math.sqrt(float(change @ change) / len(change))


def _internal_names(model: Model, values: Mapping[str, float]) -> dict[str, float]:
    """Physical values as the model's named internal values (they coincide for the law)."""
    return {k: v for k, v in values.items() if k in model.names}


def _halved_change(problem: SimulationProblem, fit: SimFit) -> np.ndarray:
    """How the fit's prediction (channels stacked, in their units) changes at half the step."""
    replay = problem.train
    with Replayer(replay.halved(), problem.runner.threads) as runner:
        out = runner.run([problem.case(fit.model, fit.values)])[0]
    return np.concatenate([out[c] - fit.predicted[c] for c in replay.channels])


def _stacked(problem: SimulationProblem, weights: Mapping[str, float]) -> np.ndarray:
    n = problem.train.n
    return np.concatenate([np.full(n, weights[c]) for c in problem.train.channels])


# ----------------------------------------------------------------------------- candidates

def _screen(problem: SimulationProblem, current: SimFit, bases: Sequence[SimFit],
            effects: Sequence[str], scales: Scales) -> dict[str, tuple]:
    """Each candidate linearized at each of ``bases`` (fits of the current model):
    effect -> (start, linearized dBIC, seconds, base, linearized weighted RMSE drop). The
    residual is projected on the base's Jacobian columns together with the effect's
    signatures, so the gain is what the effect adds once the others adjust (a score test, in
    the spirit of Rao's); only candidates it favours are fitted in full. The dBIC is against
    the current fit, linearized too."""
    started = time.monotonic()
    n_eff = max(current.n_eff, 2.0)
    jacobians = [problem.jacobian(b.model, b.q, b.residual) for b in bases]
    r0 = current.residual
    jac0 = jacobians[bases.index(current)] if current in bases else \
        problem.jacobian(current.model, current.q, r0)
    coef, *_ = np.linalg.lstsq(jac0, -r0, rcond=None)
    rss0 = float(np.sum((r0 + jac0 @ coef) ** 2))
    base_seconds = time.monotonic() - started
    out: dict[str, tuple] = {}
    for effect in effects:
        begun = time.monotonic()
        for base, jacobian in zip(bases, jacobians):
            model = base.model.extended(effect, scales)
            start = dict(base.model.internal_values(base.q))
            values, rss, others = _effect_start(problem, base, effect, model, jacobian)
            start.update(values)
            start = {**start, _OTHER_STARTS: [{**start, **o} for o in others]}
            k_effect = model.k - base.model.k
            dbic = n_eff * math.log((rss + problem.floor) / (rss0 + problem.floor)) + \
                k_effect * math.log(n_eff)
            if effect not in out or dbic < out[effect][1]:
                drop = 1.0 - math.sqrt((rss + problem.floor) / (rss0 + problem.floor))
                out[effect] = (start, float(dbic), 0.0, base, drop)
        start, dbic, _, base, drop = out[effect]
        if effect == "stribeck" and "contact_stiffness_N_per_m" in bases[0].values:
            # one more start, whichever base won: the contact rescanned with the peak in
            # place, from the best base (it sets every value, so it starts any base's fit)
            start[_OTHER_STARTS].append(_stribeck_contact_start(
                problem, bases[0].model.extended(effect, scales), bases[0]))
        out[effect] = (start, dbic, time.monotonic() - begun + base_seconds / len(effects),
                       base, drop)
    return out


def _candidate(problem: SimulationProblem, current: SimFit, base: SimFit, effect: str,
               scales: Scales, index: int, min_improvement: float, bic_threshold: float,
               start: Mapping[str, float], screen_dbic: float,
               screen_seconds: float) -> SimCandidate:
    """Fit ``effect`` from ``start`` (linearized at ``base``) and judge it against
    ``current``."""
    started = time.monotonic() - screen_seconds
    model = current.model.extended(effect, scales)
    # The linearized step can overshoot (a Stribeck peak, a modulation): the best of a few
    # fractions of it, simulated in one batch, starts the fit.
    q_now = model.internal({**base.model.internal_values(base.q),
                            **{n: start[n] for n in effect_internals(effect) if n in start},
                            **{n: _off(n, model) for n in _linear_names(effect)}})
    others = start.get(_OTHER_STARTS, [])
    start = {k: v for k, v in start.items() if k != _OTHER_STARTS}
    q_step = model.internal(start) - q_now
    trials = [q_now + fraction * q_step for fraction in _STEP_FRACTIONS]
    residuals = problem.residuals(model, trials)
    best = int(np.argmin([float(r @ r) for r in residuals]))
    fit = min((problem.fit(model, s, CANDIDATE_EVALUATIONS,
                           label=f"round {index}: {effect}") for s in
               [model.internal_values(trials[best]), *others]), key=lambda f: f.rss)
    return _judge(problem, current, fit, effect, index, min_improvement, bic_threshold,
                  screen_dbic, started)


def _judge(problem: SimulationProblem, current: SimFit, fit: SimFit, effect: str, index: int,
           min_improvement: float, bic_threshold: float, screen_dbic: float | None,
           started: float) -> SimCandidate:
    """The verdict on ``fit`` (the current model plus ``effect``) against ``current``.
    n_eff is the current model's (conservative: a misfit the baseline's optimizer leaves in a
    valley is not counted as independent samples; measured, the candidate's own n_eff selected
    viscous in a noise-free Dahl record)."""
    floor = problem.floor
    n_eff = max(current.n_eff, 2.0)
    delta_bic = n_eff * math.log((fit.rss + floor) / (current.rss + floor)) + \
        (fit.k - current.k) * math.log(n_eff)
    drop = 1.0 - math.sqrt((fit.rss + floor) / (current.rss + floor))
    val_ratio = None
    if fit.validation:
        val_ratio = float(np.mean([math.log(a.rmse_N / b.rmse_N)
                                   for a, b in zip(fit.validation, current.validation)]))
    # (n_eff is of the residual of every channel stacked; the held-out RMSE, the primary's)
    held = held_out_evidence(n_eff, len(current.residual), [r.n for r in problem.validation],
                             fit.validation, current.validation)
    tone_dbic = tone_frequency = None
    if effect == "position_ripple" or effect in MODULATION_HARMONICS:
        tone_dbic, tone_frequency = _tone_competition(problem, current, fit, effect, n_eff)
    reasons = []
    if not delta_bic + held < bic_threshold:
        reasons.append(f"dBIC {delta_bic:.1f}" + (f" + held out {held:.1f}" if held else "")
                       + f" not below {bic_threshold:g}")
    if not drop >= min_improvement:
        reasons.append(f"weighted RMSE falls only {100 * drop:.2f} % "
                       f"(< {100 * min_improvement:g} %)")
    if val_ratio is not None and not val_ratio < 0:
        reasons.append(f"held-out RMSE does not fall ({100 * (math.exp(val_ratio) - 1):+.2f} %)")
    if tone_dbic is not None and not tone_dbic < bic_threshold:
        reasons.append(f"no better than an additive tone at {tone_frequency:.4g} Hz "
                       f"(dBIC {tone_dbic:.1f})")
    reason = "; ".join(reasons) if reasons else \
        f"dBIC {delta_bic:.1f}" + (f" + held out {held:.1f}" if held else "") + \
        f", weighted RMSE -{100 * drop:.1f} %"
    return SimCandidate(effect=effect, fit=fit, delta_bic=delta_bic, train_drop=drop,
                        validation_log_ratio=val_ratio, tone_delta_bic=tone_dbic,
                        tone_frequency_Hz=tone_frequency, round=index, justified=not reasons,
                        reason=reason, seconds=time.monotonic() - started,
                        screen_delta_bic=screen_dbic, held_out_evidence=held)


def _linear_names(effect: str) -> list[str]:
    """An effect's coordinates that its start projects on (the others are scanned; an own
    effect's log parameters start at their scale)."""
    own = own_effects.registered().get(effect)
    if own is not None:
        return own.linear_names
    if effect == "stribeck":
        return ["static_ratio"]
    if effect == "position_ripple":
        return ["ripple_cos", "ripple_sin"]
    return list(effect_internals(effect))


def _off(name: str, model: Model) -> float:
    p = next(p for p in model.params if p.name == name)
    if name == "static_ratio":
        return 1.0
    return p.scale if p.log else 0.0


def _effect_start(problem: SimulationProblem, current: SimFit, effect: str,
                  model: Model, base: np.ndarray
                  ) -> tuple[dict[str, float], float, list[dict[str, float]]]:
    """Start values of an effect: minus the residual projected on the effect's signatures
    (the change of the weighted prediction when a coordinate moves a little from "off"),
    all signatures of a scan simulated in one batch) together with the current model's
    Jacobian columns ``base``. Returns the values, the linearized weighted RSS and further
    starts worth a fit of their own (Stribeck's next best grid points; ``_screen`` adds
    ``_stribeck_contact_start``'s, once, from the best base)."""
    now = dict(current.model.internal_values(current.q))
    params = {p.name: p for p in model.params}
    names = _linear_names(effect)
    others: list[dict[str, float]] = []
    scans: list[dict[str, float]] = [{}]
    if effect == "stribeck":
        v_rms = params["stribeck_velocity_m_per_s"].scale
        scans = [{"stribeck_velocity_m_per_s": r * v_rms} for r in _STRIBECK_SCAN]
    elif effect == "position_ripple":
        scans = [{"position_ripple_wavelength_m": _ripple_wavelength(problem, current)}]
    batch = []
    for fixed in scans:
        off = {**now, **fixed, **{n: _off(n, model) for n in names}}
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
        both = np.hstack([base, columns])
        coef, *_ = np.linalg.lstsq(both, -r0, rcond=None)
        rss = float(np.sum((r0 + both @ coef) ** 2))
        if rss < best_rss:
            values = {n: _off(n, model) + float(c)
                      for n, c in zip(names, coef[base.shape[1]:])}
            # the current model's parameters move as the projection says, too
            lo, hi = current.model.bounds()
            moved = current.model.internal_values(
                np.clip(current.q + coef[:base.shape[1]], lo, hi))
            best, best_rss = {**moved, **fixed, **values}, rss
    if effect == "stribeck":
        # A Stribeck peak can turn sliding into stick-slip: far from linear. The curve is also
        # simulated directly on a grid, the other values as they are.
        grid = [{**now, "static_ratio": ratio, "stribeck_velocity_m_per_s": r * v_rms}
                for ratio in _STRIBECK_RATIOS for r in _STRIBECK_SCAN]
        # The same curves with the level lowered so that the mean friction over the record's
        # sliding speeds stays: a peak then takes friction from fast sliding instead of only
        # adding it (a machine whose viscous term is already fitted needs that to see it).
        # Their best is one more start of its own, never the first: from it a record whose
        # peak adds friction (the rig's breakaway) falls into another basin.
        speed = np.abs(current.predicted["relative_velocity_m_per_s"])
        compensated = []
        for point in grid:
            compensated.append({**point, "friction_coefficient": _mean_keeping_coefficient(
                now["friction_coefficient"], point["static_ratio"],
                point["stribeck_velocity_m_per_s"], speed)})
        scanned = problem.scan_rss(model, [model.internal(v) for v in grid + compensated])
        order = [int(j) for j in np.argsort(scanned[:len(grid)])[:_STRIBECK_STARTS]]
        # (the leaders again at the fit's own timestep, comparable with the projection's rss)
        rss = [float(r @ r) for r in problem.residuals(model, [model.internal(grid[j])
                                                                for j in order])]
        i = int(np.argmin(rss))
        if rss[i] < best_rss:
            best, best_rss = grid[order[i]], rss[i]
        # stick-slip makes the cost rugged: the next best grid points start fits too
        others = [grid[j] for j in order if grid[j] is not best]
        others.append(compensated[int(np.argmin(scanned[len(grid):]))])
    for n in list(best):
        p = params[n]
        if p.name in names:
            best[n] = min(max(best[n], p.lower), p.upper)
    if effect == "stribeck":
        best["static_ratio"] = min(max(best["static_ratio"], 1.0 + 1e-3), 3.0)
    return best, best_rss, others


def _mean_keeping_coefficient(mu: float, static_ratio: float, stribeck_velocity: float,
                              speed: np.ndarray) -> float:
    """The friction coefficient that keeps the mean friction over the sliding speeds ``speed``
    at ``mu``'s once a Stribeck peak (``static_ratio``, ``stribeck_velocity``) is added."""
    shape = 1 + (static_ratio - 1) * np.exp(-(speed / stribeck_velocity) ** 2)
    return mu / float(np.mean(shape))


def _stribeck_restarts(model: Model, best: SimFit) -> list[dict[str, float]]:
    """``best``'s values with the Stribeck curves of ``_STRIBECK_RESTARTS`` (mu moved to keep
    the model's level coordinate)."""
    names = model.names
    v_s = model.params[names.index("stribeck_velocity_m_per_s")]
    out = []
    for ratio, speed in _STRIBECK_RESTARTS:
        q = np.array(best.q, dtype=float)
        q[names.index("static_ratio")] = model.params[names.index("static_ratio")].to_internal(
            ratio)
        q[names.index("stribeck_velocity_m_per_s")] = v_s.to_internal(speed * v_s.scale)
        out.append(model.internal_values(q))
    return out


def _stribeck_contact_start(problem: SimulationProblem, model: Model,
                            base: SimFit) -> dict[str, float]:
    """The best of a grid over the contact's deflection and the Stribeck curve together. A
    baseline without the peak mimics stick-slip with a stiff contact, and a peak added there
    stays in that basin (a hidden-Stribeck lab record: k_t 580 N/um where it is 80); the
    contact's stiffness is scanned again with the peak in place, the level lowered so that the
    mean friction over the sliding speeds of ``base``'s prediction stays. ``model``: ``base``'s
    model with the Stribeck curve."""
    now = dict(base.model.internal_values(base.q))
    v_rms = next(p for p in model.params if p.name == "stribeck_velocity_m_per_s").scale
    speed = np.abs(base.predicted["relative_velocity_m_per_s"])
    level = now["friction_coefficient"] * problem.train.rig.normal_force_N
    trials = []
    for deflection in deflection_scan_m(_travel_m(problem.train))[::2]:
        contact = {"contact_stiffness_N_per_m": level / deflection}
        if "bristle_damping_N_s_per_m" in now and problem.law == "lugre":
            contact["bristle_damping_N_s_per_m"] = lugre_default_bristle_damping(
                level / deflection, now.get("mass_kg", problem.train.rig.mass_kg))
        for ratio in _STRIBECK_RATIOS:
            for v_s in v_rms * _STRIBECK_SCAN[::2]:  # (the fit from it refines v_s)
                trials.append({**now, **contact, "static_ratio": ratio,
                               "stribeck_velocity_m_per_s": v_s,
                               "friction_coefficient": _mean_keeping_coefficient(
                                   now["friction_coefficient"], ratio, v_s, speed)})
    return trials[int(np.argmin(problem.scan_rss(model, [model.internal(v) for v in trials])))]


def _ripple_wavelength(problem: SimulationProblem, current: SimFit) -> float:
    """Wavelength whose level-scaled sine/cosine best explains the force residual."""
    channel = problem.primary
    target = current.predicted[channel] - problem.train.measured[channel]
    friction = current.predicted["friction_force_N"]
    x = current.predicted["relative_position_m"]
    travel = float(np.ptp(x)) or 1e-3
    step = float(np.quantile(np.abs(np.diff(x)), 0.95)) or travel
    spacing = 0.25  # cycles over the travel between wavelengths tried
    # (at most one cycle per 4 samples, which a steady motion's step gives anyway: a record
    # that hardly moves has a tiny step and would ask for trillions of wavelengths)
    most = min(travel / (4 * step), len(x) / 4)
    cycles = np.arange(1.0, max(most, 1.0 + spacing), spacing)
    gains = []
    f2, ft = friction * friction, -friction * target
    # least squares on (f sin kx, f cos kx) for every wavelength: the gain is b' G^+ b with G
    # the pair's Gram matrix and b their products with the residual, from the sums of
    # f^2 e^(2ikx) and f t e^(ikx); e^(ikx) by recurrence along k within slices of 64
    turn = np.exp(2j * math.pi * spacing / travel * x)
    total = float(np.sum(f2))
    for chunk in (cycles[i:i + 64] for i in range(0, len(cycles), 64)):
        wave = np.empty((len(chunk), len(x)), dtype=complex)
        wave[0] = np.exp(2j * math.pi * chunk[0] / travel * x)
        for j in range(1, len(chunk)):
            np.multiply(wave[j - 1], turn, out=wave[j])
        double = (wave * wave) @ f2  # sum f^2 e^(2ikx)
        b = wave @ ft
        gram = np.empty((len(chunk), 2, 2))
        gram[:, 0, 0] = 0.5 * (total - double.real)  # sin^2
        gram[:, 1, 1] = 0.5 * (total + double.real)  # cos^2
        gram[:, 0, 1] = gram[:, 1, 0] = 0.5 * double.imag  # sin cos
        b = np.column_stack([b.imag, b.real])
        gains.extend(np.einsum("ki,kij,kj->k", b, np.linalg.pinv(gram), b))
    return travel / float(cycles[int(np.argmax(gains))])


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
    k_effect = len(effect_internals(effect))
    floor = problem.floor
    dbic = n_eff * math.log((fit.rss + floor) / (best_rss + floor)) + \
        (k_effect - k_tone) * math.log(n_eff)
    return float(dbic), best_f


def _residual_peaks(problem: SimulationProblem, fit: SimFit) -> list[float]:
    channel = problem.primary
    residual = fit.predicted[channel] - problem.train.measured[channel]
    if len(residual) < 64:
        return []
    dt = float(np.median(np.diff(problem.train.time_s)))
    return [round(f, 6) for f in uniform_spectrum(residual, dt).peaks_Hz]


__all__ = ["identify_by_simulation", "SimIdentification", "SimFit", "SimCandidate",
           "SimulationProblem"]
