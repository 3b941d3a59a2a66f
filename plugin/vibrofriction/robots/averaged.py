"""Robot-timestep mode: the friction law averaged over the support vibration.

A support vibrating along an in-plane axis e at u'(t) = v_a cos(2 pi f t) under a body sliding
at mean velocity V gives the relative velocity v_r(t) = V - u'(t) e. When the vibration period
is short against every time scale of the robot (and of the body's own motion), the body feels
only the period mean of the friction force, a function of V alone:

    F(V) = mu F_N R f(|V| / v_a, angle(V, e)) + sigma2 V.

:func:`build_table` computes f from the resolved planar law itself (the plugin's C++ code,
driven kinematically by :func:`vibrofriction.rigs.planar.run_planar_law`: the heavy-body limit, in
which the body's velocity ripple over a period is negligible) on a grid of xi = |V|/v_a and of
the angle of V from the vibration axis, and :class:`AveragedTable` turns it into the config of
the ``vibrofriction.averaged`` plugin, which applies F implicitly at robot timesteps.

Valid when (docs/robots.md): the vibration period is much shorter than the robot's time
scales and the timestep is not needed to resolve it; the body is heavy against the contact
(m (2 pi f)^2 >> k_t) and its velocity ripple mu F_N / (m 2 pi f) << v_a; F_N, v_a and f change
slowly over a period. The table is normalized by mu F_N at the F_N it was made for: exact in F_N
for rigid Coulomb, approximate for the elastic laws (their pre-slip length changes with F_N).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .. import sim
from ..params import FrictionParameters, ParameterError
from ..rigs.planar import check_planar, run_planar_law
from ..vocabulary import element_keys

# FrictionParameters field -> MJCF config key of vibrofriction.averaged (vocabulary.FRICTION_TERMS):
# the law's other terms are not keys there, their effect is in the table.
AVERAGED_MJCF_KEYS = element_keys("averaged")


def default_xi_grid() -> np.ndarray:
    """xi = |V| / v_a: 0, fine near 0 (log), dense around 1 (the Coulomb kink), coarse to 20."""
    return np.unique(np.concatenate([
        [0.0], np.geomspace(2e-3, 0.45, 18), np.linspace(0.5, 1.5, 21),
        np.geomspace(1.6, 20.0, 10)]))


def default_angle_grid() -> np.ndarray:
    """Angle of V from the vibration axis, 0 ... pi in 15 degree steps."""
    return np.linspace(0.0, math.pi, 13)


@dataclass(frozen=True)
class Vibration:
    """Support vibration along an in-plane axis: u' = v_a cos(2 pi f t) along axis_angle_rad."""

    frequency_Hz: float
    velocity_amplitude_m_per_s: float
    axis_angle_rad: float = 0.0

    def validate(self) -> "Vibration":
        if not (self.frequency_Hz > 0 and math.isfinite(self.frequency_Hz)):
            raise ParameterError(f"vibration frequency_Hz={self.frequency_Hz!r} must be > 0")
        if not (self.velocity_amplitude_m_per_s > 0
                and math.isfinite(self.velocity_amplitude_m_per_s)):
            raise ParameterError("vibration velocity_amplitude_m_per_s="
                                 f"{self.velocity_amplitude_m_per_s!r} must be > 0")
        return self


@dataclass(frozen=True)
class AveragedTable:
    """Mean friction over mu F_N in the vibration frame (along, across the vibration axis)."""

    friction: FrictionParameters
    vibration: Vibration
    normal_force_N: float
    xi: np.ndarray = field(repr=False)       # (n_xi,)
    angle_rad: np.ndarray = field(repr=False)  # (n_angle,)
    along: np.ndarray = field(repr=False)    # (n_xi, n_angle)
    across: np.ndarray = field(repr=False)   # (n_xi, n_angle)

    def config(self, *, normal_force_N: float | None = None,
               contact_geoms: tuple[str, str] | None = None,
               use_ctrl: bool = False) -> dict[str, str]:
        """Config of a vibrofriction.averaged instance (MJCF keys, string values)."""
        # mu and viscous; static_ratio and stribeck_velocity shape only the law without
        # vibration (v_a = 0, or use_ctrl with ctrl <= 0): with vibration the table holds them.
        law = {key: repr(float(getattr(self.friction, name)))
               for name, key in AVERAGED_MJCF_KEYS.items()}
        config = {
            "mu": law.pop("mu"),  # then the normal load: the order of plate_push_table.xml
            "normal": repr(float(self.normal_force_N if normal_force_N is None
                                 else normal_force_N)),
            **law,
            "velocity_amplitude": repr(float(self.vibration.velocity_amplitude_m_per_s)),
            "axis_angle": repr(float(self.vibration.axis_angle_rad)),
            "table_xi": _numbers(self.xi, 17),
            "table_angle": _numbers(self.angle_rad, 17),
            "table_along": _numbers(self.along.ravel()),
            "table_across": _numbers(self.across.ravel()),
        }
        config["table_checksum"] = table_checksum(
            *(config[key] for key in ("table_xi", "table_angle", "table_along", "table_across")))
        if contact_geoms is not None:
            config["contact_geom1"], config["contact_geom2"] = contact_geoms
        if use_ctrl:
            config["use_ctrl"] = "true"
        return config

    def contact_config(self, support: str, *,
                       axis: tuple[float, float, float] | None = None,
                       torsion_radius_m: float | None = None,
                       support_geom: tuple[str, ...] | None = None) -> dict[str, str]:
        """Config of a vibrofriction.contact_averaged instance: the drop-in element for a free
        body on ``support`` vibrating along ``axis`` (the support body's frame; default: the
        table's vibration angle in the support's x-y plane). The normal load is MuJoCo's
        contact force, so the table's normal_force_N only shaped the table. ``support_geom``:
        the names of the support's geoms that form the surface the part rests on (its other
        geoms, walls and end stops, stay ordinary MuJoCo contacts); default: all of them."""
        if axis is None:
            angle = self.vibration.axis_angle_rad
            axis = (math.cos(angle), math.sin(angle), 0.0)
        config = self.config()
        for key in ("normal", "axis_angle"):
            config.pop(key)
        config["support"] = support
        config["axis"] = " ".join(repr(float(a)) for a in axis)
        if torsion_radius_m is not None:
            config["torsion_radius"] = repr(float(torsion_radius_m))
        if support_geom:
            config["support_geom"] = " ".join(support_geom)
        return config

    def mjcf_instance(self, name: str, **kwargs) -> str:
        """<instance> element text for an MJCF <extension><plugin plugin="vibrofriction.averaged">
        (its keys checked against the table: sim.instance_xml)."""
        return sim.instance_xml("averaged", name, self.config(**kwargs))

    def to_json(self, path: str | Path) -> None:
        payload = {"friction": asdict(self.friction), "vibration": asdict(self.vibration),
                   "normal_force_N": self.normal_force_N, "xi": self.xi.tolist(),
                   "angle_rad": self.angle_rad.tolist(), "along": self.along.tolist(),
                   "across": self.across.tolist()}
        Path(path).write_text(json.dumps(payload))

    @classmethod
    def from_json(cls, path: str | Path) -> "AveragedTable":
        payload = json.loads(Path(path).read_text())
        return cls(friction=FrictionParameters(**payload["friction"]),
                   vibration=Vibration(**payload["vibration"]),
                   normal_force_N=float(payload["normal_force_N"]),
                   xi=np.asarray(payload["xi"]), angle_rad=np.asarray(payload["angle_rad"]),
                   along=np.asarray(payload["along"]), across=np.asarray(payload["across"]))


def table_checksum(*lists_text: str) -> str:
    """The ``table_checksum`` of table lists written as MJCF text: FNV-1a (64 bit) over each
    list's length and its numbers' IEEE bit patterns, least significant byte first, as 16 hex
    digits (the plugin's NumberListChecksum). With it the element compares the table's few
    other bytes each step instead of its 16 kB of text, and refuses a table edited by hand."""
    digest = 0xCBF29CE484222325
    for text in lists_text:
        numbers = np.array(text.split(), dtype=np.float64)
        words = np.concatenate([[np.uint64(numbers.size)], numbers.view(np.uint64)])
        for byte in words.astype("<u8").tobytes():
            digest = ((digest ^ byte) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return f"{digest:016x}"


def _numbers(values, digits: int = 9) -> str:
    return " ".join(f"{float(v):.{digits}g}" for v in np.asarray(values).ravel())


def mean_force_ratio(friction: FrictionParameters, vibration: Vibration, normal_force_N: float,
                     velocity_m_per_s, *, samples_per_period: int = 800,
                     average_periods: int = 4, max_settle_periods: int = 400) -> np.ndarray:
    """Period-mean friction force over mu F_N (vibration frame: along, across) at the mean
    sliding velocity V (vibration frame, m/s), viscous part excluded: the resolved law driven
    kinematically along v_r = V - v_a cos(2 pi f t) e.

    The transient is skipped over max(2, 10 z_c / (|V| T)) periods (z_c = F_s / k_t: the state
    forgets over a few pre-slip lengths of travel), at most max_settle_periods.
    """
    V = np.asarray(velocity_m_per_s, dtype=float)
    va, f = vibration.velocity_amplitude_m_per_s, vibration.frequency_Hz
    period = 1.0 / f
    speed = float(np.hypot(V[0], V[1]))
    if friction.law == "coulomb":
        settle = 0
    else:
        z_c = friction.friction_coefficient * normal_force_N * friction.static_ratio / \
            friction.contact_stiffness_N_per_m
        travel = max(speed, 1e-300) * period
        settle = int(min(max_settle_periods, max(2, math.ceil(10 * z_c / travel))))
    n = (settle + average_periods) * samples_per_period
    t = np.arange(n + 1) * (period / samples_per_period)
    v = np.empty((n + 1, 2))
    v[:, 0] = V[0] - va * np.cos(2 * math.pi * f * t)
    v[:, 1] = V[1]
    run = run_planar_law(friction, t, v, normal_force_N=normal_force_N)
    start = settle * samples_per_period
    window_t = t[start:]
    mean = np.trapezoid(run.force_N[start:], window_t, axis=0) / (window_t[-1] - window_t[0])
    mean -= friction.viscous_N_s_per_m * V
    return mean / (friction.friction_coefficient * normal_force_N)


def build_table(friction: FrictionParameters, vibration: Vibration, normal_force_N: float, *,
                xi=None, angle_rad=None, samples_per_period: int = 800,
                average_periods: int = 4) -> AveragedTable:
    """The averaged law of ``friction`` under ``vibration`` at ``normal_force_N``."""
    check_planar(friction)
    vibration.validate()
    if not (normal_force_N > 0 and friction.friction_coefficient > 0):
        raise ParameterError("build_table needs normal_force_N > 0 and friction_coefficient > 0")
    xi = default_xi_grid() if xi is None else np.asarray(xi, dtype=float)
    angle = default_angle_grid() if angle_rad is None else np.asarray(angle_rad, dtype=float)
    if xi[0] != 0 or np.any(np.diff(xi) <= 0):
        raise ParameterError("xi grid must start at 0 and increase strictly")
    if angle[0] != 0 or abs(angle[-1] - math.pi) > 1e-12 or np.any(np.diff(angle) <= 0):
        raise ParameterError("angle grid must increase strictly from 0 to pi")
    va = vibration.velocity_amplitude_m_per_s
    along = np.zeros((xi.size, angle.size))
    across = np.zeros((xi.size, angle.size))
    modulated = friction.normal_force_modulation != 0
    for i, x in enumerate(xi):
        if x == 0:
            if modulated:  # a modulated normal load can push the body at V = 0 (feeders)
                along[i, :] = mean_force_ratio(friction, vibration, normal_force_N, (0.0, 0.0),
                                               samples_per_period=samples_per_period,
                                               average_periods=average_periods)[0]
            continue
        for j, a in enumerate(angle):
            V = x * va * np.array([math.cos(a), math.sin(a)])
            if abs(V[1]) < 1e-15 * va:
                V[1] = 0.0
            ratio = mean_force_ratio(friction, vibration, normal_force_N, V,
                                     samples_per_period=samples_per_period,
                                     average_periods=average_periods)
            along[i, j] = ratio[0]
            across[i, j] = ratio[1] if V[1] != 0 else 0.0
    return AveragedTable(friction=friction, vibration=vibration,
                         normal_force_N=float(normal_force_N), xi=xi, angle_rad=angle,
                         along=along, across=across)


__all__ = ["AVERAGED_MJCF_KEYS", "AveragedTable", "Vibration", "build_table",
           "default_angle_grid", "default_xi_grid", "mean_force_ratio"]
