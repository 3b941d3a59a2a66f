"""Periodic steady states by shooting: solve for the orbit instead of waiting for it.

A scene driven periodically (period T) settles into a periodic orbit: its state after one
period -- or a few, for a subharmonic response -- is the state it started from, up to a known
drift (coordinates that advance by a fixed amount every period: the rig's drive end and the
slider pulled behind it move on by v_d T). ``periodic`` finds that state with Newton's method
on the residual of the period map,

    G(x) = P(x) - x - drift,   P: the state after K MuJoCo steps (K dt = T) from x at time t0,

over the coordinates that carry the dynamics (qpos, qvel, act and plugin states; coordinates
prescribed by a motion plugin can be left out). The Jacobian of P comes from finite differences
of the map (one rollout of the perturbed states together: the state is small), then from
Broyden updates; a step that does not reduce the residual is halved (line search) and the
Jacobian recomputed. The eigenvalues of the Jacobian are the orbit's Floquet multipliers: an
orbit with a multiplier on or outside the unit circle is not what a run settles into, and is
rejected. A response that repeats only after 2, 3 or 4 periods (period doubling) is tried next,
from a state further along the run; a response that is not periodic at all (stick-slip at its
own frequency, chaos) fails every multiple and says so (``PeriodicOrbit.converged`` False,
``message``).

The means of every sensor over the orbit come with it; the error of the means is estimated
from the last Newton correction and their finite-difference gradient (``mean_residual``).

``solve_rig`` / ``run_periodic`` apply it to the paper's rig (``rigs.rig``): a short start
with the drive spring preloaded to a guess of the answer, Newton on one vibration period on a
grid of a whole number of steps, then -- so that the phase of every switch of the force is
averaged as the transient's sliding grid does (``rig.STEP_PHASE_SLIDE``) -- a few chord steps
on the map of 13 periods with 13 N + 5 steps (N + 0.385 a period); with ``fallback`` a case
whose orbit is not found runs to steady state by ``steady.run_until_steady`` and its result
says so (``Convergence.method``).
"""
from __future__ import annotations

import contextlib
import math
import threading
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from .. import sim
from ..params import FrictionParameters, ParameterError, RigParameters, plain_value
from ..summary import RunSummary
from . import rig_model

DEFAULT_STATE_TOLERANCE = 1e-8  # |G(x)| / orbit scale of each coordinate, at convergence
DEFAULT_MULTIPLES = (1, 2, 3, 4)
DEFAULT_MAX_ITERATIONS = 12
FD_RELATIVE_STEP = 1e-6  # finite-difference step, relative to each coordinate's scale
# A multiplier within this of the unit circle is neutral (not proof of stability; the
# finite-difference Jacobian is good to about 1e-5 here)
STABILITY_MARGIN = 1e-4
_FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
# Sliding grid of the averaging map: 13 periods in 13 N + 5 steps (5/13 = 0.385 ~ 0.382).
SLIDE_PERIODS = 13
SLIDE_EXTRA_STEPS = 5
WINDOW_PERIODS = 48  # Coulomb's final window on the rule's sliding grid
SLIDE_STATE_TOLERANCE = 1e-4  # the averaging map's state residual (its mean: ~1e-7 relative)
FIRST_STATE_TOLERANCE = 1e-6  # the one-period orbit's (a start for the averaging map)


class PeriodicError(ParameterError):
    """Bad input to the periodic solver (not a failure to find an orbit: that is a result)."""


# ----------------------------------------------------------------------------- the state
def state_layout(model: mujoco.MjModel) -> dict[str, slice]:
    """Where time, qpos, qvel, act and plugin states lie in the mjSTATE_FULLPHYSICS vector."""
    names = [("time", "mjSTATE_TIME"), ("qpos", "mjSTATE_QPOS"), ("qvel", "mjSTATE_QVEL"),
             ("act", "mjSTATE_ACT"), ("history", "mjSTATE_HISTORY"),
             ("mocap_pos", "mjSTATE_MOCAP_POS"), ("mocap_quat", "mjSTATE_MOCAP_QUAT"),
             ("plugin", "mjSTATE_PLUGIN")]
    full = int(_FULL)
    bits = []
    for name, attr in names:
        flag = getattr(mujoco.mjtState, attr, None)
        if flag is not None and int(flag) & full:
            bits.append((int(flag), name, flag))
    out, start = {}, 0
    for _, name, flag in sorted(bits):
        size = mujoco.mj_stateSize(model, flag)
        out[name] = slice(start, start + size)
        start += size
    if start != mujoco.mj_stateSize(model, _FULL):  # pragma: no cover - a MuJoCo change
        raise RuntimeError("unexpected layout of mjSTATE_FULLPHYSICS")
    return out


def default_coordinates(model: mujoco.MjModel) -> np.ndarray:
    """Every qpos, qvel, act and plugin-state entry (indices into the full physics state)."""
    lay = state_layout(model)
    idx = []
    for name in ("qpos", "qvel", "act", "history", "plugin"):
        if name in lay:
            idx.extend(range(lay[name].start, lay[name].stop))
    return np.asarray(idx, dtype=int)


def _quaternion_indices(model: mujoco.MjModel) -> set[int]:
    """Full-state indices of qpos entries of ball and free joints (not vector coordinates)."""
    lay = state_layout(model)
    out = set()
    for j in range(model.njnt):
        kind = model.jnt_type[j]
        adr = model.jnt_qposadr[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            out.update(lay["qpos"].start + adr + k for k in range(3, 7))
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            out.update(lay["qpos"].start + adr + k for k in range(4))
    return out


# ----------------------------------------------------------------------------- the result
@dataclass(frozen=True)
class PeriodicOrbit:
    """The outcome of ``periodic``. ``converged``: a stable periodic orbit was found; else
    ``message`` says why not (and the other fields describe the last attempt)."""

    converged: bool
    message: str
    state: np.ndarray  # full physics state at the orbit's start (time t0)
    period_s: float  # the orbit's period: multiple x the drive's period
    multiple: int
    steps: int  # MuJoCo steps in one orbit
    residual: float  # max over coordinates of |G(x)| / scale at the returned state
    mean_residual: np.ndarray  # estimated |error| of sensor_means (from the last correction)
    multipliers: np.ndarray  # Floquet multipliers (eigenvalues of the map's Jacobian)
    iterations: int  # Newton steps taken (all multiples tried)
    evaluations: int  # period maps evaluated, finite-difference columns included
    steps_run: int  # MuJoCo steps run in all (the cost)
    sensordata: np.ndarray  # (steps, nsensordata): the orbit, row i at t0 + i dt
    coordinates: np.ndarray
    jacobian: np.ndarray | None = None  # of the map, in scaled coordinates
    scale: np.ndarray | None = None
    mean_gradient: np.ndarray | None = None  # d sensor_means / d scaled coordinates
    attempts: tuple[str, ...] = ()

    @property
    def sensor_means(self) -> np.ndarray:
        """Mean of every sensor over the orbit (all its steps: a periodic orbit's exact mean
        on its grid)."""
        return self.sensordata.mean(axis=0)

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0


def _ignore_warning(message: str) -> None:
    del message


_held_lock = threading.Lock()
_held = {"count": 0, "installed": False}  # solves in flight; whether we set the handler


@contextlib.contextmanager
def _trial_warnings_held():
    """MuJoCo's warnings of a trial state (a Newton step or a finite-difference column that
    diverged) kept from MUJOCO_LOG.TXT in the user's folder: the map marks such a trial NaN and
    the solver steps back. A handler the user set stays in charge. The handler is
    process-wide: counted across threads, set by the first solve, restored by the last."""
    with _held_lock:
        if _held["count"] == 0:
            _held["installed"] = mujoco.get_mju_user_warning() is None
            if _held["installed"]:
                mujoco.set_mju_user_warning(_ignore_warning)
        _held["count"] += 1
    try:
        yield
    finally:
        with _held_lock:
            _held["count"] -= 1
            if _held["count"] == 0 and _held["installed"] and \
                    mujoco.get_mju_user_warning() is _ignore_warning:
                mujoco.set_mju_user_warning(None)


def not_periodic_reason(rig: RigParameters, friction: FrictionParameters) -> str | None:
    """Why the rig's steady state cannot be a periodic orbit (the forcing itself is not
    periodic), or None."""
    if friction.time_map_knots_s:
        return "a time map changes the friction level over time"
    if rig.drive_velocity_m_per_s != 0 and (friction.position_ripple
                                            or friction.position_map_knots_m):
        return ("friction that varies along the travel (a position ripple or map) changes "
                "as the drive moves on")
    f_m = friction.normal_force_modulation_frequency_Hz
    if friction.normal_force_modulation and f_m > 0:
        ratio = f_m / rig.vibration_frequency_Hz if is_vibrating(rig) else math.inf
        if not abs(ratio - round(ratio)) <= 1e-9 * max(1.0, ratio) or round(ratio) == 0:
            return (f"the normal load is modulated at {f_m:g} Hz, not a multiple of the "
                    "vibration's frequency")
    return None


@dataclass
class _Map:
    """The period map of ``multiple`` periods from a full-state template at time t0."""

    model: mujoco.MjModel
    data: mujoco.MjData
    template: np.ndarray
    coordinates: np.ndarray
    drift: np.ndarray  # per orbit, over the coordinates
    steps: int
    fd_step: float = FD_RELATIVE_STEP
    evaluations: int = 0
    steps_run: int = 0

    def states(self, xs: np.ndarray) -> np.ndarray:
        out = np.repeat(self.template[None], xs.shape[0], axis=0)
        out[:, self.coordinates] = xs
        return out

    def __call__(self, xs: np.ndarray, keep: bool = False):
        """(end coordinates (n, k), sensor means (n, nsensordata), orbit sensordata of the
        first state if keep)."""
        xs = np.atleast_2d(xs)
        with _trial_warnings_held():
            state, sensordata = mj_rollout.rollout(self.model, self.data, self.states(xs),
                                                   nstep=self.steps)
        self.evaluations += xs.shape[0]
        self.steps_run += xs.shape[0] * self.steps
        end = state[:, -1, :]
        t_expected = self.template[0] + self.steps * self.model.opt.timestep
        bad = ~np.all(np.isfinite(end), axis=1) | ~np.all(np.isfinite(sensordata), axis=(1, 2))
        bad |= ~np.isclose(end[:, 0], t_expected, rtol=1e-9, atol=1e-12)
        ends = end[:, self.coordinates].copy()
        ends[bad] = np.nan
        return ends, sensordata.mean(axis=1), (sensordata[0] if keep else None)


def _scales(orbit: np.ndarray, x: np.ndarray, drift: np.ndarray) -> np.ndarray:
    """Each coordinate's scale: its range over the orbit (drift removed), at least 1e-2 of
    its size (an equilibrium: finite differences above the rounding) and a floor for
    coordinates that do not move."""
    n = orbit.shape[0]
    detrended = orbit - np.outer(np.arange(n) / max(n, 1), drift)
    span = np.ptp(detrended, axis=0)
    size = np.maximum(np.abs(x), np.abs(detrended).max(axis=0))
    scale = np.maximum(span, 1e-2 * size)
    floor = max(float(scale.max()) * 1e-12, 1e-300)
    return np.maximum(scale, floor)


@_trial_warnings_held()
def periodic(model: mujoco.MjModel, data: mujoco.MjData, period_s: float, *,
             drift: np.ndarray | None = None, coordinates: Sequence[int] | None = None,
             multiples: Sequence[int] = DEFAULT_MULTIPLES,
             tolerance: float = DEFAULT_STATE_TOLERANCE,
             max_iterations: int = DEFAULT_MAX_ITERATIONS, settle_periods: int = 8,
             jacobian: np.ndarray | None = None, scale: np.ndarray | None = None,
             refresh_jacobian: bool = True, accept_neutral: bool = False,
             mean_gradient: np.ndarray | None = None,
             fd_step: float = FD_RELATIVE_STEP) -> PeriodicOrbit:
    """The periodic orbit of a scene driven with period ``period_s`` (see the module
    docstring), by shooting from ``data``'s state.

    ``period_s`` must be a whole number of ``model.opt.timestep`` (the map is a number of
    steps). ``drift``: the advance of each full-state entry over one period (default none;
    the rig: v_d T on the slider's and the drive end's joints). ``coordinates``: the full-state
    indices solved for (default ``default_coordinates``; the others are taken from ``data`` at
    every start: prescribed or irrelevant). ``multiples``: the orbit periods tried, in
    periods; between two, the start moves ``settle_periods`` x multiple periods along the run.
    ``jacobian`` / ``scale``: a known Jacobian of the first multiple's map in scaled
    coordinates (and the scales), used instead of a finite-difference one until the
    residual stops falling. ``data`` is left at the returned orbit's start."""
    dt = model.opt.timestep
    if not (period_s > 0 and math.isfinite(period_s)):
        raise PeriodicError(f"period {plain_value(period_s)!r} must be a positive number of seconds")
    steps = int(round(period_s / dt))
    if steps < 1 or not math.isclose(steps * dt, period_s, rel_tol=1e-6):
        raise PeriodicError(
            f"period {plain_value(period_s)} s is not a whole number of timesteps ({plain_value(dt)} s: "
            f"{period_s / dt:.6g} steps); set the timestep to period / N")
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise PeriodicError(f"tolerance {plain_value(tolerance)!r} must be a positive number")
    mults = [int(m) for m in multiples]
    if not mults or any(m < 1 for m in mults):
        raise PeriodicError(f"multiples {list(multiples)!r} must be whole numbers >= 1")
    nfull = mujoco.mj_stateSize(model, _FULL)
    coords = (default_coordinates(model) if coordinates is None
              else np.asarray(list(coordinates), dtype=int))
    if coords.size == 0 or coords.min() < 1 or coords.max() >= nfull or \
            len(set(coords.tolist())) != coords.size:
        raise PeriodicError(f"coordinates must be distinct indices 1..{nfull - 1} of the full "
                            "physics state (0 is time)")
    quats = _quaternion_indices(model) & set(coords.tolist())
    if quats:
        raise PeriodicError("the coordinates include quaternions of ball or free joints, "
                            "which a period map cannot difference as vectors; leave them out "
                            "(coordinates=...) or drive a scene without them")
    drift_full = np.zeros(nfull) if drift is None else np.asarray(drift, dtype=float)
    if drift_full.shape != (nfull,) or not np.all(np.isfinite(drift_full)):
        raise PeriodicError(f"drift must be {nfull} finite numbers (one per full-state entry)")
    start = sim.full_state(model, data)
    attempts: list[str] = []
    iterations = evaluations = steps_run = 0
    last: PeriodicOrbit | None = None
    for k, multiple in enumerate(mults):
        if k > 0:  # further along the run: closer to a subharmonic attractor
            n_settle = settle_periods * multiple * steps
            state, _ = mj_rollout.rollout(model, data, start[None], nstep=n_settle)
            steps_run += n_settle
            start = state[0, -1].copy()
            if not np.all(np.isfinite(start)):
                attempts.append(f"the run from the start diverged within {n_settle} steps")
                break
        pmap = _Map(model=model, data=data, template=start.copy(), coordinates=coords,
                    drift=drift_full[coords] * multiple, steps=steps * multiple,
                    fd_step=fd_step)
        orbit = _newton(pmap, start[coords].copy(), tolerance, max_iterations,
                        jacobian if k == 0 else None, scale if k == 0 else None,
                        refresh_jacobian, accept_neutral, mean_gradient if k == 0 else None)
        iterations += orbit.iterations
        evaluations += pmap.evaluations
        steps_run += pmap.steps_run
        orbit = replace(orbit, period_s=period_s * multiple, multiple=multiple,
                        iterations=iterations, evaluations=evaluations, steps_run=steps_run)
        attempts.append(f"{multiple} period(s): {orbit.message}")
        last = replace(orbit, attempts=tuple(attempts))
        if orbit.converged:
            break
    assert last is not None
    mujoco.mj_setState(model, data, last.state, _FULL)
    if not last.converged:
        last = replace(last, message="no stable periodic orbit of " + ", ".join(
            str(m) for m in mults) + " period(s): " + "; ".join(attempts))
    return last


def _newton(pmap: _Map, x: np.ndarray, tolerance: float, max_iterations: int,
            jacobian: np.ndarray | None, scale: np.ndarray | None,
            refresh_jacobian: bool = True, accept_neutral: bool = False,
            mean_gradient: np.ndarray | None = None) -> PeriodicOrbit:
    """Damped Newton (Broyden between finite-difference Jacobians) on G(x) = 0 in
    coordinates scaled by the orbit's ranges; the verdict's multipliers from a fresh
    finite-difference Jacobian at the solution."""
    n = x.size
    ends, means, orbit_data = pmap(x[None], keep=True)
    if not np.all(np.isfinite(ends)):
        return _failed(pmap, x, "the run from the start diverged", 0)
    if scale is None or scale.shape != (n,):
        # the coordinates over the orbit: from a rerun keeping every state (cheap: one map)
        full, _ = mj_rollout.rollout(pmap.model, pmap.data, pmap.states(x[None]),
                                     nstep=pmap.steps)
        pmap.steps_run += pmap.steps
        scale = _scales(full[0][:, pmap.coordinates], x, pmap.drift)
    residual = (ends[0] - x - pmap.drift) / scale
    norm = float(np.max(np.abs(residual)))
    eye = np.eye(n)
    J = grad = None
    fresh = False  # J is a finite-difference Jacobian at the current x
    if jacobian is not None and jacobian.shape == (n, n):
        J = np.array(jacobian, dtype=float)
    iterations = 0
    mean_change = None  # change of the means over the last step taken
    while norm > tolerance and iterations < max_iterations:
        if J is None and not refresh_jacobian:
            break
        if J is None:
            J, grad = _fd_jacobian(pmap, x, scale, ends[0], means[0])
            if J is None:
                return _failed(pmap, x, "a perturbed run diverged", iterations)
            fresh = True
        B = J - eye
        dy = _solve(B, -residual)
        lam, accepted = 1.0, False
        for _ in range(5):  # backtracking line search on max |G| / scale
            x_new = x + lam * dy * scale
            ends_new, means_new, data_new = pmap(x_new[None], keep=True)
            if np.all(np.isfinite(ends_new)):
                res_new = (ends_new[0] - x_new - pmap.drift) / scale
                norm_new = float(np.max(np.abs(res_new)))
                if norm_new < norm:
                    accepted = True
                    break
            lam *= 0.5
        iterations += 1
        if not accepted:
            if fresh:
                break  # no descent along a fresh Jacobian's step: give up
            J = None  # a stale Broyden Jacobian: recompute it here
            continue
        s = lam * dy  # Broyden's update of B along the step taken
        B = B + np.outer(res_new - residual - B @ s, s) / float(s @ s)
        slow = norm_new > 0.5 * norm
        x, ends, residual, norm = x_new, ends_new, res_new, norm_new
        mean_change = np.abs(means_new[0] - means[0])
        means, orbit_data = means_new, data_new
        J, fresh = B + eye, False
        if slow and refresh_jacobian:
            J = None  # slow progress: a fresh Jacobian at the next step
    if not fresh and np.isfinite(norm) and refresh_jacobian:
        # the multipliers and the means' gradient from finite differences at the solution
        J_fd, grad = _fd_jacobian(pmap, x, scale, ends[0], means[0])
        if J_fd is not None:
            J = J_fd
    multipliers = _multipliers(J) if J is not None else np.zeros(0)
    radius = float(np.max(np.abs(multipliers))) if multipliers.size else 0.0
    if J is None:
        radius = math.inf
    # the error of the means: their gradient along the Newton correction still due
    if grad is None and mean_gradient is not None and mean_gradient.shape == (means[0].size, n):
        grad = mean_gradient
    mean_residual = _mean_residual(means[0], grad, J, residual, mean_change)
    converged, message = _verdict(norm, tolerance, radius, iterations, accept_neutral)
    return PeriodicOrbit(
        converged=converged, message=message, state=pmap.states(x[None])[0],
        period_s=0.0, multiple=1, steps=pmap.steps, residual=norm,
        mean_residual=mean_residual, multipliers=multipliers, iterations=iterations,
        evaluations=pmap.evaluations, steps_run=pmap.steps_run, sensordata=orbit_data,
        coordinates=pmap.coordinates, jacobian=J, scale=scale, mean_gradient=grad)


def _mean_residual(mean: np.ndarray, grad: np.ndarray | None, J: np.ndarray | None,
                   residual: np.ndarray, mean_change: np.ndarray | None) -> np.ndarray:
    """The error of the orbit's means (N): their gradient along the Newton correction still
    due; without the gradient, their change over the last step (an overestimate); else inf."""
    if grad is not None and J is not None:
        return np.abs(grad @ _solve(J - np.eye(J.shape[0]), -residual))
    if mean_change is not None:
        return mean_change
    return np.full_like(mean, np.inf)


def _verdict(norm: float, tolerance: float, radius: float, iterations: int,
             accept_neutral: bool) -> tuple[bool, str]:
    """(converged, why) of a Newton solve: the residual within tolerance (of the orbit's
    scale) and the orbit attracting (largest Floquet multiplier ``radius`` below 1; a neutral
    one only with ``accept_neutral``)."""
    if not np.isfinite(norm):
        return False, "the residual is not finite"
    elif norm > tolerance:
        converged = False
        message = (f"Newton did not converge in {iterations} iterations (residual "
                   f"{norm:.2g} of the orbit's scale)")
    elif radius >= 1.0 + STABILITY_MARGIN:
        converged = False
        message = (f"an orbit was found but it is unstable (largest Floquet multiplier "
                   f"{radius:.6g}): a run does not settle into it")
    elif radius >= 1.0 - STABILITY_MARGIN and accept_neutral:
        converged = True
        message = (f"converged in {iterations} iterations (residual {norm:.2g}) to a neutral "
                   f"orbit (largest Floquet multiplier {radius:.6g}: a ringing nothing damps, "
                   "whose mean is the orbit's)")
    elif radius >= 1.0 - STABILITY_MARGIN:
        converged = False
        message = (f"an orbit was found but it is neutral (largest Floquet multiplier "
                   f"{radius:.6g}: a ringing nothing damps), not proven to be where a run "
                   "settles")
    else:
        converged = True
        message = (f"converged in {iterations} iterations (residual {norm:.2g}, largest "
                   f"Floquet multiplier {radius:.4g})")
    return converged, message


def _multipliers(J: np.ndarray) -> np.ndarray:
    """Eigenvalues of the map's Jacobian, without those of inert coordinates (a state the map
    carries over unchanged and nothing else reads: an unused act slot)."""
    n = J.shape[0]
    eye = np.eye(n)
    inert = [j for j in range(n) if np.allclose(J[:, j], eye[:, j], rtol=0, atol=1e-9)
             and np.allclose(J[j, :], eye[j, :], rtol=0, atol=1e-9)]
    keep = [j for j in range(n) if j not in inert]
    return np.linalg.eigvals(J[np.ix_(keep, keep)]) if keep else np.zeros(0)


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(a, b, rcond=None)[0]


def _fd_jacobian(pmap: _Map, x: np.ndarray, scale: np.ndarray, end: np.ndarray,
                 mean: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Forward differences of the map (and of the sensor means) in scaled coordinates, all
    perturbed states in one rollout."""
    n = x.size
    h = pmap.fd_step
    xs = np.repeat(x[None], n, axis=0) + np.diag(h * scale)
    ends, means, _ = pmap(xs)
    if not np.all(np.isfinite(ends)):
        return None, None
    J = ((ends - end[None]) / scale[None, :]).T / h  # column j: d P / d y_j
    grad = ((means - mean[None]) / h).T  # (nsensordata, n)
    return J, grad


def _failed(pmap: _Map, x: np.ndarray, message: str, iterations: int) -> PeriodicOrbit:
    return PeriodicOrbit(
        converged=False, message=message, state=pmap.states(x[None])[0], period_s=0.0,
        multiple=1, steps=pmap.steps, residual=math.inf,
        mean_residual=np.zeros(pmap.model.nsensordata), multipliers=np.zeros(0),
        iterations=iterations, evaluations=pmap.evaluations, steps_run=pmap.steps_run,
        sensordata=np.zeros((0, pmap.model.nsensordata)), coordinates=pmap.coordinates)


# ----------------------------------------------------------------------------- the rig
def _joint_index(model: mujoco.MjModel, name: str) -> tuple[int, int]:
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    return int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])


def guess_force_N(rig: RigParameters, friction: FrictionParameters) -> float:
    """A start for the mean drive force: the rigid Coulomb kinematic limit (2/pi) arcsin(1 /
    kappa_v) mu F_N (mu F_N without vibration or below kappa_v = 1)."""
    level = friction.friction_coefficient * rig.normal_force_N
    kappa = rig.kappa if rig.vibration_velocity_amplitude_m_per_s > 0 else 0.0
    return level * (2 / math.pi * math.asin(1.0 / kappa) if kappa > 1 else 1.0)


def is_vibrating(rig: RigParameters) -> bool:
    """Whether the rig's table vibrates at all: a frequency (Hz) and a velocity amplitude (m/s)
    both above 0."""
    return rig.vibration_frequency_Hz > 0 and rig.vibration_velocity_amplitude_m_per_s > 0


def static_period_s(rig: RigParameters, timestep_s: float) -> float:
    """The map's period without vibration (an equilibrium in the drive's frame is periodic
    with any period): a quarter of the slider's period on the drive spring, so that its
    ringing turns by 90 degrees per map, whole steps."""
    omega = math.sqrt(rig.drive_chain_stiffness_N_per_m / rig.mass_kg)
    steps = max(8, int(round(0.25 * 2 * math.pi / omega / timestep_s)))
    return steps * timestep_s


def rig_start(model: mujoco.MjModel, data: mujoco.MjData, rig: RigParameters,
              friction: FrictionParameters, force_N: float) -> None:
    """``data`` two steps after the start of the vibration (after its ramp, if any), the drive
    spring loaded to ``force_N``, the slider moving at v_d and the law's state at the
    deflection that carries that force."""
    mujoco.mj_resetData(model, data)
    dt = model.opt.timestep
    t_start = 0.0
    if is_vibrating(rig) and rig.vibration_from_s > 0:
        t_start = rig.vibration_from_s + rig_model.VIBRATION_RAMP_PERIODS / \
            rig.vibration_frequency_Hz
    data.time = t_start
    mujoco.mj_step(model, data, 2)  # the motion plugins put the table and drive end in place
    q_s, v_s = _joint_index(model, "slider_on_table")
    q_t, v_t = _joint_index(model, "table_slide")
    q_b, _ = _joint_index(model, "drive_end_slide")
    v_d = rig.drive_velocity_m_per_s
    pull = math.copysign(1.0, v_d)
    extension = -pull * force_N / rig.drive_chain_stiffness_N_per_m
    if rig.drive_backlash_m > 0:  # beyond the play's face the spring pulls on
        extension += rig.drive_backlash_centre_m - pull * 0.5 * rig.drive_backlash_m
    data.qpos[q_s] = extension + data.qpos[q_b] - data.qpos[q_t]
    data.qvel[v_s] = v_d - data.qvel[v_t]
    if friction.law in ("dahl", "lugre", "dupont") and model.na >= 1:
        data.act[0] = pull * force_N / friction.contact_stiffness_N_per_m
    mujoco.mj_forward(model, data)


def rig_coordinates(model: mujoco.MjModel, data: mujoco.MjData, probe_steps: int,
                    law_uses_act: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(coordinates, drift per unit of v_d T): the slider's position and velocity, the law's
    state in act, and plugin states that move (a lagged sensor, a lagged dynamometer); the
    table and the drive end follow their prescribed motion whatever their start."""
    lay = state_layout(model)
    q_s, v_s = _joint_index(model, "slider_on_table")
    q_b, _ = _joint_index(model, "drive_end_slide")
    coords = [lay["qpos"].start + q_s, lay["qvel"].start + v_s]
    if law_uses_act:  # (Coulomb keeps no deflection: its act slot is unused)
        coords += list(range(lay["act"].start, lay["act"].stop))
    plugin = lay.get("plugin")
    instance = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, "friction")
    if plugin is not None and instance >= 0 and model.plugin_statenum[instance] > 0:
        # the friction element's own states (contact load, lagged force, gms slip flags) when
        # they move; the dynamometer's (no lag in the rig) only record
        adr = plugin.start + int(model.plugin_stateadr[instance])
        own = np.arange(adr, adr + int(model.plugin_statenum[instance]))
        start = sim.full_state(model, data)
        state, _ = mj_rollout.rollout(model, data, start[None], nstep=probe_steps)
        moving = np.ptp(state[0][:, own], axis=0) > 0
        coords += [int(i) for i in own[moving]]
        mujoco.mj_setState(model, data, start, _FULL)
    drift = np.zeros(mujoco.mj_stateSize(model, _FULL))
    drift[lay["qpos"].start + q_s] = 1.0
    drift[lay["qpos"].start + q_b] = 1.0
    return np.asarray(coords, dtype=int), drift


WARMUP_PERIODS = 2  # vibration periods run from the preloaded start before shooting


@dataclass(frozen=True)
class RigOrbit:
    """The rig's periodic steady state (``solve_rig``) or why there is none."""

    converged: bool
    message: str
    timestep_s: float  # of the averaging map (sliding grid)
    summary: RunSummary | None
    mean_residual: float  # estimated |error| of the mean drive force (N)
    residual: float  # state residual of the orbit (relative to its scale)
    multiple: int  # periods of the response (2: period doubling)
    simulated_s: float  # simulated time of every step run (the cost)
    steps_run: int
    orbit: PeriodicOrbit | None = None  # the averaging map's solution
    model: mujoco.MjModel | None = None


def _law_uses_act(friction: FrictionParameters) -> bool:
    return friction.law != "coulomb"


def neutral_is_safe(friction: FrictionParameters) -> bool:
    """A neutral orbit (the slider ringing undamped on the drive spring while the friction
    force stays at its sliding level) is the steady state when the law has no static peak to
    turn the ringing into stick-slip (``static_ratio`` 1)."""
    return friction.static_ratio == 1


def _shooting_grid(rig: RigParameters, timestep_s: float,
                   vibrating: bool) -> tuple[float, int, float, float]:
    """(T the vibration period in s, N steps a period, the timestep dt1 = T / N in s, the
    shooting period in s); without vibration T = N = 0 and the period is a quarter period of
    the slider on the drive spring (``static_period_s``) at ``timestep_s``."""
    if not vibrating:
        return 0, 0, timestep_s, static_period_s(rig, timestep_s)
    T = 1.0 / rig.vibration_frequency_Hz
    ratio = T / timestep_s
    N = int(round(ratio)) if abs(ratio - round(ratio)) < 1e-6 else int(math.floor(ratio))
    if N < 8:
        raise ParameterError(
            f"timestep {plain_value(timestep_s)} s leaves {ratio:.3g} steps per vibration period; "
            "the periodic solver needs at least 8 (use a smaller timestep)")
    return T, N, T / N, T


def _averaging_map_guess(first: PeriodicOrbit) -> tuple[np.ndarray, np.ndarray | None]:
    """The averaging map's Jacobian guessed from the one-period orbit's (its SLIDE_PERIODS-th
    power), and the gradient of the means over it: the mean of the one-period means along it
    (None without the one-period gradient)."""
    guess = np.linalg.matrix_power(first.jacobian, SLIDE_PERIODS)
    if first.mean_gradient is None:
        return guess, None
    powers = np.zeros_like(guess)
    power = np.eye(guess.shape[0])
    for _ in range(SLIDE_PERIODS):
        powers += power
        power = power @ first.jacobian
    return guess, first.mean_gradient @ powers / SLIDE_PERIODS


@_trial_warnings_held()
def solve_rig(rig: RigParameters, friction: FrictionParameters, *,
              timestep_s: float | None = None, tolerance: float = 1e-3,
              multiples: Sequence[int] = DEFAULT_MULTIPLES) -> RigOrbit:
    """The rig's periodic steady state by shooting (module docstring). ``timestep_s`` (default
    the rule's, ``rig.recommended_timestep``) sets N = floor(T / dt) steps a period: Newton
    on one period of N steps, then chord steps on 13 periods of 13 N + 5 steps, whose orbit's
    mean is the answer. Without vibration the orbit is the equilibrium of steady sliding,
    shot over a quarter period of the slider on the drive spring at ``timestep_s`` (default
    rig.DEFAULT_TIMESTEP_S). ``tolerance``: the estimated relative error of the mean drive
    force at which the orbit counts as converged."""
    vibrating = is_vibrating(rig)
    if timestep_s is None:
        timestep_s = rig_model.recommended_timestep(rig)
    if not (timestep_s > 0 and math.isfinite(timestep_s)):
        raise ParameterError(f"timestep {plain_value(timestep_s)!r} must be a positive number of "
                             "seconds")
    T, N, dt1, period1 = _shooting_grid(rig, timestep_s, vibrating)
    if not vibrating:
        multiples = (1,)
    model = rig_model.build_model(rig, friction, dt1)
    data = mujoco.MjData(model)
    rig_start(model, data, rig, friction, guess_force_N(rig, friction))
    steps1 = int(round(period1 / dt1))
    coords, drift_unit = rig_coordinates(model, data, steps1, _law_uses_act(friction))
    warm = WARMUP_PERIODS * steps1
    mujoco.mj_step(model, data, warm)
    steps_run = warm + 2
    accept_neutral = neutral_is_safe(friction)
    drift = drift_unit * rig.drive_velocity_m_per_s * period1
    first = periodic(model, data, period1, drift=drift, coordinates=coords, multiples=multiples,
                     accept_neutral=accept_neutral, fd_step=fd_step(friction),
                     tolerance=FIRST_STATE_TOLERANCE if vibrating else DEFAULT_STATE_TOLERANCE)
    steps_run += first.steps_run
    simulated = steps_run * dt1
    if not first.converged:
        return RigOrbit(converged=False, message=first.message, timestep_s=dt1, summary=None,
                        mean_residual=math.inf, residual=first.residual,
                        multiple=first.multiple, simulated_s=simulated, steps_run=steps_run,
                        orbit=first, model=model)
    final, dt_final = first, dt1
    if vibrating:
        # the averaging map: 13 x multiple periods on the sliding grid, from the orbit found
        mult = first.multiple
        steps13 = (SLIDE_PERIODS * N + SLIDE_EXTRA_STEPS) * mult
        dt_final = SLIDE_PERIODS * mult * T / steps13
        model.opt.timestep = dt_final
        mujoco.mj_setState(model, data, first.state, _FULL)
        guess, gradient = _averaging_map_guess(first)
        period13 = SLIDE_PERIODS * mult * T
        settings = dict(drift=drift_unit * rig.drive_velocity_m_per_s * period13,
                        coordinates=coords, multiples=(1,), accept_neutral=True,
                        tolerance=SLIDE_STATE_TOLERANCE)
        final = periodic(model, data, period13, jacobian=guess, scale=first.scale,
                         refresh_jacobian=False, mean_gradient=gradient, **settings)
        if not final.converged:  # the one-period Jacobian does not carry over: its own
            steps_run += final.steps_run
            simulated += final.steps_run * dt_final
            mujoco.mj_setState(model, data, first.state, _FULL)
            final = periodic(model, data, period13, scale=first.scale, **settings)
        steps_run += final.steps_run
        simulated += final.steps_run * dt_final
        if not final.converged:
            return RigOrbit(converged=False, message="the orbit of the sliding grid was not "
                            f"found from the one-period orbit ({final.message})",
                            timestep_s=dt_final, summary=None, mean_residual=math.inf,
                            residual=final.residual, multiple=mult, simulated_s=simulated,
                            steps_run=steps_run, orbit=final, model=model)
    summary, mean_residual = _orbit_summary(model, rig, final, dt_final)
    window = window_periods(friction) if vibrating else 0
    if window:
        # a force that jumps (Coulomb's switch) depends on where each switch falls between two
        # steps: average the orbit over a window of many phases, as the transient does
        dt_window = rig_model.period_timestep(rig.vibration_frequency_Hz, N)
        model.opt.timestep = dt_window
        nstep = int(math.ceil(window * T / dt_window)) + 1
        state, sensordata = mj_rollout.rollout(model, data, final.state[None], nstep=nstep)
        steps_run += nstep
        simulated += nstep * dt_window
        summary = _window_summary(model, rig, sensordata[0], float(final.state[0]), dt_window,
                                  window * T)
    relative = mean_residual / abs(summary.mean_drive_force_N) \
        if summary.mean_drive_force_N != 0 else mean_residual
    converged = bool(relative <= tolerance)
    message = first.message if vibrating is False else (
        f"{first.message}; on the sliding grid: {final.message}")
    if not converged:
        message = (f"the orbit's mean drive force is uncertain by {relative:.2g} of itself "
                   f"(tolerance {tolerance:g}): {message}")
    return RigOrbit(converged=converged, message=message, timestep_s=dt_final, summary=summary,
                    mean_residual=mean_residual, residual=final.residual,
                    multiple=first.multiple, simulated_s=simulated, steps_run=steps_run,
                    orbit=final, model=model)


SWITCH_FD_STEP = 1e-2  # Coulomb: moves each switch by several steps (a secant Jacobian)


def fd_step(friction: FrictionParameters) -> float:
    """The finite-difference step of the rig's Jacobian (``periodic``'s ``fd_step``)."""
    return SWITCH_FD_STEP if friction.law == "coulomb" else FD_RELATIVE_STEP


def window_periods(friction: FrictionParameters) -> int:
    """Periods of the final averaging window on the rule's sliding grid: for a law whose force
    jumps (Coulomb), none for the continuous ones (the 13-period orbit averages them)."""
    return WINDOW_PERIODS if friction.law == "coulomb" else 0


def _window_summary(model: mujoco.MjModel, rig: RigParameters, sensordata: np.ndarray,
                    t0: float, dt: float, length_s: float) -> RunSummary:
    from .steady import hann_mean
    t = t0 + np.arange(sensordata.shape[0]) * dt
    drive = rig_model.drive_force_columns(model, rig, sensordata)
    friction = sim.sensor_columns(model, sensordata, "friction_state")[:, 4]
    inside = (t >= t0) & (t <= t0 + length_s + 1e-12)
    return RunSummary(
        mean_drive_force_N=hann_mean(t, drive, t0, t0 + length_s),
        mean_friction_force_N=hann_mean(t, friction, t0, t0 + length_s),
        friction_min_N=float(friction[inside].min()),
        friction_max_N=float(friction[inside].max()),
        sign_change=bool(friction[inside].min() < 0 < friction[inside].max()),
        window_start_s=t0, window_end_s=t0 + length_s,
        periods_averaged=int(round(length_s * rig.vibration_frequency_Hz)))


def _orbit_summary(model: mujoco.MjModel, rig: RigParameters, orbit: PeriodicOrbit,
                   dt: float) -> tuple[RunSummary, float]:
    """The orbit's summary (means over it, the friction force's extremes) and the estimated
    error of its mean drive force (N)."""
    drive = rig_model.drive_force_columns(model, rig, orbit.sensordata)
    friction = sim.sensor_columns(model, orbit.sensordata, "friction_state")[:, 4]
    t0 = float(orbit.state[0])
    periods = int(round(orbit.period_s * rig.vibration_frequency_Hz)) if is_vibrating(rig) \
        else 0
    summary = RunSummary(
        mean_drive_force_N=float(drive.mean()), mean_friction_force_N=float(friction.mean()),
        friction_min_N=float(friction.min()), friction_max_N=float(friction.max()),
        sign_change=bool(friction.min() < 0 < friction.max()), window_start_s=t0,
        window_end_s=t0 + orbit.steps * dt, periods_averaged=periods)
    # the drive force's error: from the sensor means' (the drive actuator's force sensor,
    # and with backlash the dynamometer's extension)
    s = sim.sensor_slices(model)
    err = float(orbit.mean_residual[s["drive_force"]][0])
    if rig.drive_backlash_m > 0:
        err += rig.drive_chain_stiffness_N_per_m * float(
            orbit.mean_residual[s["drive_spring_extension"]][0])
    return summary, err


def run_periodic(cases: Sequence[tuple[RigParameters, FrictionParameters]], *,
                 timesteps: Sequence[float] | None = None, tolerance: float = 1e-3,
                 fallback: bool = True, max_duration_s: float | None = None,
                 nthread: int | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list:
    """Each case's steady state by ``solve_rig``, as ``steady.SteadyRun`` records (the same
    summary type as the transient's), in the cases' order. ``Convergence.method`` says which
    route gave it: "periodic"; with ``fallback``, a case whose orbit is not found runs to
    steady state by ``steady.run_until_steady`` ("transient", its ``note`` saying why);
    without it the case is flagged unconverged (its numbers those of the last orbit tried, or
    NaN)."""
    from .steady import Convergence, SteadyRun, case_timesteps, run_until_steady
    # (every timestep checked first: a fallback would refuse one only after the solve)
    dts = case_timesteps(cases, timesteps, tolerance)
    out: list = [None] * len(cases)
    failed: dict[int, str] = {}  # case -> why it goes to the transient
    done = 0

    def finish(i: int, run) -> None:
        nonlocal done
        out[i] = run
        done += 1
        if progress:
            progress(done, len(cases))

    def flagged(i: int, dt: float, simulated_s: float, note: str):
        """A case without an orbit, unconverged, its numbers NaN (no fallback asked)."""
        nan = math.nan
        (r, f) = cases[i]
        return SteadyRun(rig=r, friction=f, timestep_s=dt,
                         summary=RunSummary(nan, nan, nan, nan, False, nan, nan, 0),
                         convergence=Convergence(
                             converged=False, tolerance=tolerance, window_s=nan, windows=0,
                             relative_change=math.inf, estimated_remaining_error=math.inf,
                             simulated_s=simulated_s, method="periodic", note=note))

    for i, ((r, f), dt) in enumerate(zip(cases, dts)):
        reason = not_periodic_reason(r, f)
        if reason is not None:
            if fallback:
                failed[i] = f"not periodic: {reason}"
            else:
                finish(i, flagged(i, dt, 0.0, f"not periodic: {reason}"))
            continue
        orbit = solve_rig(r, f, timestep_s=dt, tolerance=tolerance)
        if orbit.summary is not None and (orbit.converged or not fallback):
            relative = orbit.mean_residual / max(abs(orbit.summary.mean_drive_force_N), 1e-300)
            finish(i, SteadyRun(rig=r, friction=f, timestep_s=orbit.timestep_s,
                                summary=orbit.summary, convergence=Convergence(
                                    converged=orbit.converged, tolerance=tolerance,
                                    window_s=orbit.summary.window_end_s
                                    - orbit.summary.window_start_s,
                                    windows=orbit.multiple, relative_change=relative,
                                    estimated_remaining_error=relative,
                                    simulated_s=orbit.simulated_s, method="periodic",
                                    note=orbit.message)))
        elif fallback:
            failed[i] = f"periodic orbit not found ({orbit.message})"
        else:
            finish(i, flagged(i, orbit.timestep_s, orbit.simulated_s, orbit.message))
    if failed:
        runs = run_until_steady([cases[i] for i in failed], timesteps=[dts[i] for i in failed],
                                tolerance=tolerance, max_duration_s=max_duration_s,
                                nthread=nthread)
        for (i, why), run in zip(failed.items(), runs):
            finish(i, replace(run, convergence=replace(
                run.convergence, note=f"{why}; ran the transient")))
    return out


__all__ = ["periodic", "PeriodicOrbit", "PeriodicError", "state_layout", "default_coordinates",
           "solve_rig", "run_periodic", "RigOrbit", "guess_force_N", "rig_start",
           "rig_coordinates", "static_period_s", "neutral_is_safe", "not_periodic_reason"]
