"""The friction laws driven along a given relative-velocity history, from Python.

This calls the plugin's own C++ law code (plugin/cpp/laws/friction_law.cc) through its C API, so
identification, plots and the MuJoCo plugin share one implementation. The force at sample i
uses the state z_i; z_{i+1} advances over [t_i, t_{i+1}] with the input at t_{i+1} -- exactly
the plugin's step order.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass, replace

import numpy as np

from ._native import LawLists, LawParameters, load
from ..params import PAPER_NORMAL_FORCE_N, FrictionParameters, ParameterError
from ..vocabulary import ALL_LAWS, FRICTION_TERMS


@dataclass(frozen=True)
class LawRun:
    """What ``run_law`` returns: per sample, the friction force (N) and the deflection z (m);
    for law gms also each element's deflection, shape (samples, elements)."""

    friction_force_N: np.ndarray
    # z; law gms: the one deflection with the elements' force, sum k_i z_i / sum k_i (as the
    # element's sensor reports it)
    deflection_m: np.ndarray
    element_deflection_m: np.ndarray | None = None  # law gms: (n, elements) z_i, else None


def c_law_parameters(friction: FrictionParameters, normal_force_N: float) -> LawParameters:
    """The C API's parameter struct for a friction law.

    Parameters
    ----------
    friction : FrictionParameters
        The law and its parameters (SI units); the list-valued ones (gms elements, level maps)
        go in ``LawLists`` instead.
    normal_force_N : float
        Constant normal force (N); 0 where the C call gets a normal force per sample.

    Returns
    -------
    LawParameters
        The struct, with the law as its index in ``ALL_LAWS``.
    """
    return LawParameters(
        law=ALL_LAWS.index(friction.law),
        normal_force=normal_force_N,
        **{term.law_field: getattr(friction, term.name) for term in FRICTION_TERMS
           if term.law_field})


def c_array(values, n: int, name: str) -> np.ndarray:
    """A contiguous float64 copy (or view) of ``values`` to pass to the C API, checked.

    Parameters
    ----------
    values : array_like
        The samples.
    n : int
        The number of samples expected: the array must have shape ``(n,)``.
    name : str
        The argument's name, for the error message.

    Returns
    -------
    numpy.ndarray
        C-contiguous float64 array of shape ``(n,)``.

    Raises
    ------
    ParameterError
        For another shape, or a NaN or inf (the first one's index is named).
    """
    array = np.ascontiguousarray(values, dtype=np.float64)
    if array.shape != (n,):
        raise ParameterError(f"{name} has shape {array.shape}, expected ({n},)")
    if not np.all(np.isfinite(array)):
        raise ParameterError(f"{name} contains NaN or inf at index {int(np.argmin(np.isfinite(array)))}")
    return array


def c_time_argument(time_s) -> np.ndarray:
    """The sample times as a C array, checked strictly increasing."""
    t = np.ascontiguousarray(time_s, dtype=np.float64)
    t = c_array(t, t.shape[0], "time_s")
    if t.shape[0] > 1 and not np.all(np.diff(t) > 0):
        raise ParameterError("time_s must be strictly increasing")
    return t


def c_normal_argument(normal_force_N, n: int) -> tuple[float, np.ndarray | None]:
    """(constant normal force, None) for a scalar, (0, C array of n samples) for an array."""
    if np.ndim(normal_force_N) == 0:
        return float(normal_force_N), None
    return 0.0, c_array(normal_force_N, n, "normal_force_N")


def run_law(friction: FrictionParameters, time_s, relative_velocity_m_per_s, *,
            normal_force_N=PAPER_NORMAL_FORCE_N, position_m=None,
            initial_deflection_m: float | tuple[float, ...] = 0.0) -> LawRun:
    """Friction force and deflection along a prescribed history (kinematic driving).

    ``normal_force_N`` is a constant or an array over the samples; ``position_m`` (relative
    position on the support) feeds the position ripple and the position map. Coulomb has no
    stick solve here (the velocity is given): F = g(v) sgn(v) + sigma2 v, and 0 at v = 0
    exactly. There is no vibration here, so normal_force_modulation_frequency_Hz = 0 is 0 Hz
    (as in MJCF), not the vibration frequency it means in the rigs. Law gms takes one initial
    deflection per element (a number: the same for each) and starts with every element stuck.
    """
    friction.validate()
    lib = load()
    t = c_time_argument(time_s)
    n = t.shape[0]
    v = c_array(relative_velocity_m_per_s, n, "relative_velocity_m_per_s")
    constant_normal, normal_array = c_normal_argument(normal_force_N, n)
    position = None if position_m is None else c_array(position_m, n, "position_m")
    stiffness = np.ascontiguousarray(friction.gms_stiffness_N_per_m, dtype=np.float64)
    count = stiffness.shape[0] if friction.law == "gms" else 1
    if np.ndim(initial_deflection_m) == 0:
        z0 = np.full(count, float(initial_deflection_m))
    else:
        z0 = c_array(initial_deflection_m, count, "initial_deflection_m")
    force = np.empty(n)
    deflection = np.empty((n, count))
    lists, keep = _c_lists(friction)
    params = c_law_parameters(friction, constant_normal)
    status = lib.vf_run_law_with_lists(ctypes.byref(params), ctypes.byref(lists), n, _ptr(t),
                                       _ptr(v), _ptr(position), _ptr(normal_array), _ptr(z0),
                                       _ptr(force), _ptr(deflection))
    del keep
    if status != 0:
        raise ParameterError("the friction-law C API rejected its arguments")
    if friction.law != "gms":
        return LawRun(friction_force_N=force, deflection_m=deflection[:, 0])
    return LawRun(friction_force_N=force, deflection_m=deflection @ stiffness / stiffness.sum(),
                  element_deflection_m=deflection)


# Travel of the pre-roll that puts a law at its steady sliding state, in units of its
# deflection scale level/stiffness: the constant-velocity step is exact, so a few steps span it;
# Dahl with alpha > 1 approaches its limit algebraically (1 - z/z_max ~ travel^(-1/(alpha-1))),
# so the travel is long (alpha 3.5: 2.5e-4 of the level short; alpha <= 1 and the other laws: exact).
STEADY_TRAVEL_DEFLECTIONS = 1e9


def steady_deflection_m(friction: FrictionParameters, relative_velocity_m_per_s: float, *,
                        normal_force_N: float = PAPER_NORMAL_FORCE_N,
                        position_m: float | None = None,
                        time_s: float = 0.0) -> float | tuple[float, ...]:
    """The deflection z of the law sliding steadily at ``relative_velocity_m_per_s`` (law gms:
    one per element), found by the plugin's own law: a long slide at that velocity (the state
    a record that starts in motion had when it started). 0 for Coulomb or a body at rest.
    A time map is held at its factor at ``time_s`` (the slide's own times run far past it)."""
    count = len(friction.gms_stiffness_N_per_m) if friction.law == "gms" else 1
    v = float(relative_velocity_m_per_s)
    if friction.law == "coulomb" or v == 0.0 or normal_force_N <= 0.0:
        return tuple([0.0] * count) if friction.law == "gms" else 0.0
    if friction.time_map_knots_s:  # the map's factor at time_s (the plugin's) folded into mu
        probe = FrictionParameters(law="coulomb", friction_coefficient=1.0,
                                   time_map_knots_s=friction.time_map_knots_s,
                                   time_map_factors=friction.time_map_factors)
        factor = float(run_law(probe, [float(time_s)], [1.0], normal_force_N=1.0)
                       .friction_force_N[0])
        friction = replace(friction, friction_coefficient=friction.friction_coefficient * factor,
                           time_map_knots_s=(), time_map_factors=())
    if friction.law == "gms":
        stiffness = min(friction.gms_stiffness_N_per_m)
    else:
        stiffness = friction.contact_stiffness_N_per_m
    level = friction.friction_coefficient * max(1.0, friction.static_ratio) * normal_force_N
    travel_m = STEADY_TRAVEL_DEFLECTIONS * level / stiffness + friction.contact_play_m
    if travel_m <= 0.0:  # no level and no play: nothing deflects
        return tuple([0.0] * count) if friction.law == "gms" else 0.0
    t = np.linspace(0.0, travel_m / abs(v), 5)
    position = None if position_m is None else np.full(t.shape, float(position_m))
    run = run_law(friction, t, np.full(t.shape, v), normal_force_N=float(normal_force_N),
                  position_m=position)
    if friction.law == "gms":
        return tuple(float(z) for z in run.element_deflection_m[-1])
    return float(run.deflection_m[-1])


def _ptr(array: np.ndarray | None):
    return None if array is None else array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _c_lists(friction: FrictionParameters) -> tuple[LawLists, list[np.ndarray]]:
    """The C lists struct and the arrays it points into (keep them alive through the call)."""
    def array(values) -> np.ndarray:
        return np.ascontiguousarray(values, dtype=np.float64)

    gms = friction.law == "gms"
    keep = [array(friction.gms_stiffness_N_per_m if gms else ()),
            array(friction.gms_element_weights if gms else ()),
            array(friction.position_map_knots_m), array(friction.position_map_factors),
            array(friction.velocity_map_knots_m_per_s), array(friction.velocity_map_factors),
            array(friction.time_map_knots_s), array(friction.time_map_factors)]
    lists = LawLists(
        gms_count=len(keep[0]), gms_stiffness=_ptr(keep[0]), gms_weight=_ptr(keep[1]),
        gms_relaxation_time=float(friction.gms_relaxation_time_s),
        position_map_count=len(keep[2]), position_map_knots=_ptr(keep[2]),
        position_map_factors=_ptr(keep[3]),
        position_map_period=float(friction.position_map_period_m),
        velocity_map_count=len(keep[4]), velocity_map_knots=_ptr(keep[4]),
        velocity_map_factors=_ptr(keep[5]),
        time_map_count=len(keep[6]), time_map_knots=_ptr(keep[6]),
        time_map_factors=_ptr(keep[7]))
    return lists, keep


def kinematic_mean_ratio(friction: FrictionParameters, *, drive_velocity_m_per_s: float,
                         vibration_velocity_amplitude_m_per_s: float,
                         vibration_frequency_Hz: float, normal_force_N: float,
                         periods: int = 200, samples_per_period: int = 2000) -> float:
    """F_mean / (mu F_N) for a body moving exactly at v_d over a vibrating support (heavy-body
    limit): v_r = v_d - v_a cos(omega t). The last half of the periods is averaged."""
    omega = 2 * np.pi * vibration_frequency_Hz
    n = periods * samples_per_period
    t = np.arange(n + 1) * (1.0 / vibration_frequency_Hz) / samples_per_period
    v = drive_velocity_m_per_s - vibration_velocity_amplitude_m_per_s * np.cos(omega * t)
    run = run_law(friction, t, v, normal_force_N=normal_force_N)
    half = n // 2
    mean = np.trapezoid(run.friction_force_N[half:], t[half:]) / (t[-1] - t[half])
    return float(mean / (friction.friction_coefficient * normal_force_N))
