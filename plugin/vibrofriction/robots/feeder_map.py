"""The feeder map: parts on a linear vibratory feeder at robot timesteps (1-2 ms).

A light part on a feeder does not average like a heavy body: it sticks, slips and flies within
each period, and that stick-slip is what conveys it. At robot timesteps the track is simulated
still, and `vibrofriction.contact_feeder` applies, along the conveying direction, the mean
friction the vibrating track would give the part at its mean velocity. This module makes that
map from the exact event-driven reference (`vibrofriction.oracle.feeder_reference`):

* a constant push a along the track (per unit mass) gives a periodic motion with mean
  relative velocity V(a), at which the mean friction per unit mass is -a;
* so the pairs (V(a_k), -a_k / g) over pushes |a_k| < mu g are the mean friction over the
  weight against the part's mean velocity relative to the track: positive (forward) below the
  conveying velocity V(0), negative above, saturating at -+mu where the part slides one way
  through every period.

The element multiplies the ratio by the contact's normal force F_N (the part's weight on a
still track) and solves the end-of-step velocity implicitly, so the map's steep parts are stable
at 1-2 ms. V/(A w cos b) and the ratio depend only on (Gamma, b, mu) (the reference's
frequency independence), so one map serves the same feeder at any frequency
(``FeederMap.at_frequency``). The quasi-
steady assumption: the part's mean velocity changes little over one period (checked against
the reference's own start-up in tests/test_feeder_map.py). Across the track and in spin the
element holds the part by rigid Coulomb within what the conveying leaves of the cone.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..oracle.feeder_reference import Feeder, convey
from .. import sim
from ..params import ParameterError

# Pushes over mu g: dense where the map bends near the ends (one-way sliding sets in) and
# uniform between (its kinks where flight or backward slip start and stop move with Gamma).
DEFAULT_PUSH_RATIOS = np.concatenate([[-0.999, -0.995, -0.98], np.linspace(-0.95, 0.95, 39),
                                      [0.98, 0.995, 0.999]])


@dataclass(frozen=True)
class FeederMap:
    """Mean friction over the weight against the part's mean velocity, for one feeder."""

    feeder: Feeder
    push_ratio: np.ndarray = field(repr=False)        # a / (mu g) of each reference run
    # its mean velocity relative to the track: increasing, but for two zeros that bound the
    # static band of a part stuck through every period (a vertical step)
    velocity_m_per_s: np.ndarray = field(repr=False)
    force_ratio: np.ndarray = field(repr=False)       # mean friction along the track / (m g)

    def __post_init__(self) -> None:
        # read-only copies: a map is shared (scenes.feeder_map caches one) and must not change
        for name in ("push_ratio", "velocity_m_per_s", "force_ratio"):
            values = np.array(getattr(self, name), dtype=float)
            values.setflags(write=False)
            object.__setattr__(self, name, values)

    @property
    def conveying_velocity_m_per_s(self) -> float:
        """The mean velocity without push: where the mean friction is zero."""
        return float(np.interp(0.0, -self.force_ratio, self.velocity_m_per_s))

    def at_frequency(self, frequency_Hz: float) -> "FeederMap":
        """The map of the same feeder (Gamma, throw angle, mu) run at another frequency: the
        amplitude scales as 1/f^2, so A w and the velocities as 1/f; the force ratios stay."""
        f = self.feeder
        moved = Feeder.from_throw_number(f.throw_number, f.throw_angle_rad, frequency_Hz,
                                         f.friction_coefficient, f.gravity_m_per_s2)
        scale = moved.along_velocity_amplitude / f.along_velocity_amplitude
        return FeederMap(moved, self.push_ratio.copy(), self.velocity_m_per_s * scale,
                         self.force_ratio.copy())

    def mean_force_ratio(self, velocity_m_per_s) -> np.ndarray:
        """The map read as the element reads it (linear between its points, its end values
        beyond them): for plots and checks, not for simulation."""
        return np.interp(velocity_m_per_s, self.velocity_m_per_s, self.force_ratio)

    def contact_config(self, support: str, *,
                       axis: tuple[float, float, float] | None = None,
                       torsion_radius_m: float | None = None,
                       support_geom: tuple[str, ...] | None = None) -> dict[str, str]:
        """Config of a vibrofriction.contact_feeder instance for a part on ``support``. ``axis``:
        the throw line in the support's frame (its in-plane part is the conveying direction);
        default (cos b, 0, sin b), a track along the support's x axis. ``support_geom``: the
        names of the support's geoms that form the track's surface (its other geoms, walls and
        end stops, stay ordinary MuJoCo contacts); default: all of them."""
        if axis is None:
            b = self.feeder.throw_angle_rad
            axis = (math.cos(b), 0.0, math.sin(b))
        config = {
            "mu": repr(float(self.feeder.friction_coefficient)),
            "support": support,
            "axis": " ".join(repr(float(a)) for a in axis),
            "map_velocity": " ".join(repr(float(v)) for v in self.velocity_m_per_s),
            "map_force": " ".join(repr(float(f)) for f in self.force_ratio),
        }
        if torsion_radius_m is not None:
            config["torsion_radius"] = repr(float(torsion_radius_m))
        if support_geom:
            config["support_geom"] = " ".join(support_geom)
        return config

    def mjcf_instance(self, name: str, support: str, **kwargs) -> str:
        """<instance> element text for <extension><plugin plugin="vibrofriction.contact_feeder">
        (its keys checked against the table: sim.instance_xml)."""
        return sim.instance_xml("contact_feeder", name, self.contact_config(support, **kwargs))

    def to_json(self, path: str | Path) -> None:
        payload = {"feeder": asdict(self.feeder), "push_ratio": self.push_ratio.tolist(),
                   "velocity_m_per_s": self.velocity_m_per_s.tolist(),
                   "force_ratio": self.force_ratio.tolist()}
        Path(path).write_text(json.dumps(payload))

    @classmethod
    def from_json(cls, path: str | Path) -> "FeederMap":
        payload = json.loads(Path(path).read_text())
        return cls(Feeder(**payload["feeder"]), np.asarray(payload["push_ratio"]),
                   np.asarray(payload["velocity_m_per_s"]), np.asarray(payload["force_ratio"]))


def build_map(feeder: Feeder, *, push_ratios=DEFAULT_PUSH_RATIOS) -> FeederMap:
    """The map of ``feeder`` from one reference run per push (about 30 ms each; of pushes that
    leave the part stuck, the band's two ends are kept). Raises
    ParameterError when a run does not settle or the mean velocity does not increase with the
    push (a feeder whose motion has no single periodic state there)."""
    ratios = np.asarray(push_ratios, dtype=float)
    if ratios.ndim != 1 or ratios.size < 2 or not np.all(np.diff(ratios) > 0) or \
            not np.all(np.abs(ratios) < 1):
        raise ParameterError("push_ratios must be at least 2 increasing values in (-1, 1): "
                             "pushes over mu g")
    if not np.any(ratios == 0):
        raise ParameterError("push_ratios must include 0: the conveying velocity")
    mu_g = feeder.friction_coefficient * feeder.gravity_m_per_s2
    velocities = []
    for ratio in ratios:
        motion = convey(feeder, push_m_per_s2=ratio * mu_g)
        if not motion.converged:
            raise ParameterError(f"feeder map: the reference did not settle at push {ratio:+.3f} "
                                 f"mu g in {motion.periods} periods (Gamma "
                                 f"{feeder.throw_number:.3g}); no periodic state to average")
        velocities.append(motion.mean_velocity_m_per_s)
    velocities = np.asarray(velocities)
    steps = np.diff(velocities)
    # A part stuck through every period (pushes within the static band, below the stick limit)
    # has V = 0 exactly: a vertical step of the map.
    stuck = (steps == 0) & (velocities[:-1] == 0)
    if not np.all((steps > 0) | stuck):
        k = int(np.argmin(np.where(stuck, np.inf, steps)))
        raise ParameterError(
            f"feeder map: the mean velocity does not increase with the push between "
            f"{ratios[k]:+.3f} and {ratios[k + 1]:+.3f} mu g ({velocities[k]:.6g} then "
            f"{velocities[k + 1]:.6g} m/s) for Gamma {feeder.throw_number:.3g}; the map needs one "
            "periodic state per push")
    # of a stuck band, its two ends
    inner = np.zeros(len(velocities), bool)
    inner[1:-1] = (velocities[1:-1] == 0) & (velocities[:-2] == 0) & (velocities[2:] == 0)
    ratios, velocities = ratios[~inner], velocities[~inner]
    return FeederMap(feeder, ratios, velocities, -ratios * feeder.friction_coefficient)


__all__ = ["FeederMap", "build_map", "DEFAULT_PUSH_RATIOS"]
