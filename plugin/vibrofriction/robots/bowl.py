"""Bowl feeders at robot timesteps: parts climbing a helical track.

A vibratory bowl feeder's track is a helix around the bowl's axis: the bowl twists about its axis
and heaves along it, so every point of the track moves along a throw line inclined at beta to the
track, and a part on it climbs the spiral. At robot timesteps the bowl is simulated still and each
part carries ``vibrofriction.contact_feeder`` with ``helix_pitch``: the element conveys along the
helix's tangent at the part's contact point (pointing up the spiral), so the conveying direction
follows the part around the bowl, and applies the feeder map there.

Along the local track the part is a block on a track inclined at the helix angle
alpha = atan(pitch / (2 pi r)): gravity presses it with g cos(alpha) and pulls it back with
g sin(alpha). The exact reference for it is therefore the linear feeder's
(`vibrofriction.oracle.feeder_reference`) with gravity g cos(alpha) (Gamma is the local throw
number, A w^2 sin(beta) / (g cos alpha)) and a push -g sin(alpha) along the track; the map is made
for that feeder (``bowl_map``), with that push among its points, so the climbing speed is one of
the map's points. The throw follows the position along the spiral as far as the track's radius
is constant (the usual cylindrical bowl): a track whose radius changes has a throw that changes
with it, and needs one map per radius band.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import sim
from ..oracle.feeder_reference import Feeder, convey
from .feeder_map import DEFAULT_PUSH_RATIOS, FeederMap, build_map

GRAVITY_M_PER_S2 = 9.81


@dataclass(frozen=True)
class Bowl:
    """A cylindrical bowl's helical track and its vibration, seen along the track."""

    radius_m: float = 0.1              # the track's centreline radius
    pitch_m: float = 0.02              # rise per turn (counter-clockwise, seen from above)
    throw_number: float = 1.2          # local Gamma, with gravity's part normal to the track
    throw_angle_rad: float = math.radians(25.0)  # throw line over the track
    frequency_Hz: float = 50.0
    friction_coefficient: float = 0.4
    turns: float = 2.0
    segments_per_turn: int = 36        # flat boxes along the helix
    track_width_m: float = 0.03
    track_thickness_m: float = 0.004

    @property
    def helix_angle_rad(self) -> float:
        """alpha: the track's inclination along the spiral."""
        return math.atan2(abs(self.pitch_m), 2 * math.pi * self.radius_m)

    @property
    def local_feeder(self) -> Feeder:
        """The linear feeder a part sees along the track: gravity g cos(alpha) normal to it."""
        gravity = GRAVITY_M_PER_S2 * math.cos(self.helix_angle_rad)
        return Feeder.from_throw_number(self.throw_number, self.throw_angle_rad,
                                        self.frequency_Hz, self.friction_coefficient, gravity)

    @property
    def climbing_push_m_per_s2(self) -> float:
        """Gravity along the track, per unit mass (negative: down the spiral)."""
        return -GRAVITY_M_PER_S2 * math.sin(self.helix_angle_rad)

    def reference_speed_m_per_s(self) -> float:
        """The exact climbing speed along the track (the reference with gravity's pull)."""
        return convey(self.local_feeder,
                      push_m_per_s2=self.climbing_push_m_per_s2).mean_velocity_m_per_s

    def point(self, phi_rad: float) -> np.ndarray:
        """The helix's centreline at angle phi (the track's top surface)."""
        return np.array([self.radius_m * math.cos(phi_rad), self.radius_m * math.sin(phi_rad),
                         self.pitch_m * phi_rad / (2 * math.pi)])

    def tangent(self, phi_rad: float) -> np.ndarray:
        """The upward unit tangent at angle phi (the conveying direction)."""
        run, rise = 2 * math.pi * self.radius_m, self.pitch_m
        up = 1.0 if rise > 0 else -1.0
        t = up * np.array([-run * math.sin(phi_rad), run * math.cos(phi_rad), rise])
        return t / np.linalg.norm(t)

    def track_geoms(self, prefix: str = "track") -> str:
        """The track as flat boxes tangent to the helix at their centres, top surface on it."""
        count = int(round(self.turns * self.segments_per_turn))
        step = 2 * math.pi / self.segments_per_turn
        half_length = self.radius_m * math.tan(step / 2) / math.cos(self.helix_angle_rad)
        return "\n      ".join(self.segment_geom(f"{prefix}{k}", (k + 0.5) * step,
                                                half_length + 5e-4) for k in range(count))

    def frame(self, phi_rad: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The track's frame at phi: the upward tangent, across (towards the axis for a
        counter-clockwise spiral), and the track's normal (up)."""
        x = self.tangent(phi_rad)
        inward = -np.array([math.cos(phi_rad), math.sin(phi_rad), 0.0])
        y = inward if self.pitch_m > 0 else -inward
        return x, y, np.cross(x, y)

    def segment_geom(self, name: str, phi_rad: float, half_length_m: float) -> str:
        """A flat box tangent to the helix at phi, its top surface through the helix."""
        x, y, z = self.frame(phi_rad)
        centre = self.point(phi_rad) - z * self.track_thickness_m / 2
        axes = " ".join(f"{v:.12g}" for v in (*x, *y))
        pos = " ".join(f"{v:.12g}" for v in centre)
        return (f'<geom name="{name}" type="box" size="{half_length_m:.12g} '
                f'{self.track_width_m / 2:.12g} {self.track_thickness_m / 2:.12g}" pos="{pos}" '
                f'xyaxes="{axes}" condim="1" rgba="0.62 0.64 0.7 1"/>')


def bowl_map(bowl: Bowl) -> FeederMap:
    """The feeder map of the bowl's local track, its pushes the default ones and the climbing
    push (gravity along the track): the part's climbing speed is a point of the map."""
    feeder = bowl.local_feeder
    climb = bowl.climbing_push_m_per_s2 / (feeder.friction_coefficient * feeder.gravity_m_per_s2)
    ratios = np.union1d(DEFAULT_PUSH_RATIOS, [round(climb, 12)])
    return build_map(feeder, push_ratios=ratios)


PART_HALF_M = 0.008
PART_MASS_KG = 0.02


def bowl_scene_xml(bowl: Bowl, feeder_map: FeederMap, *, parts_at_rad=(0.3,),
                   timestep_s: float = 1e-3, title: str = "vibrofriction bowl feeder",
                   track: str | None = None, part_offsets_m=None) -> str:
    """MJCF of the still bowl with its helical track (or the geoms `track`) and free parts
    (16 mm cubes, 20 g) at the given angles along the spiral, each with
    vibrofriction.contact_feeder (helix_pitch); `part_offsets_m`: each part's shift from there
    (m, world), e.g. along the track."""
    instances, bodies = [], []
    offsets = part_offsets_m if part_offsets_m is not None else [(0.0, 0.0, 0.0)] * len(
        parts_at_rad)
    for i, phi in enumerate(parts_at_rad):
        config = feeder_map.contact_config("bowl", torsion_radius_m=0.765 * PART_HALF_M)
        config.pop("axis")
        config["helix_pitch"] = repr(float(bowl.pitch_m))
        # (text, not MjSpec: the scene is written to a file with its comments; the keys are
        # checked against the table all the same)
        instances.append(sim.instance_xml("contact_feeder", f"part{i}_friction", config))
        x, y, z = bowl.frame(phi)
        centre = bowl.point(phi) + z * (PART_HALF_M + 1e-5) + np.asarray(offsets[i], float)
        pos = " ".join(f"{v:.12g}" for v in centre)
        axes = " ".join(f"{v:.12g}" for v in (*x, *y))
        bodies.append(
            f'<body name="part{i}" pos="{pos}" xyaxes="{axes}"><freejoint name="part{i}"/>'
            f'<geom name="part{i}" type="box" size="{PART_HALF_M} {PART_HALF_M} {PART_HALF_M}" '
            f'mass="{PART_MASS_KG}" condim="1" rgba="0.2 0.5 0.85 1"/>'
            f'<plugin instance="part{i}_friction"/></body>')
    top = abs(bowl.point(2 * math.pi * bowl.turns)[2])
    return f"""<mujoco model="{title}">
  <option timestep="{timestep_s!r}" integrator="implicitfast"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <extension>
    <plugin plugin="vibrofriction.contact_feeder">
      {"".join(instances)}
    </plugin>
  </extension>
  <worldbody>
    <light pos="0 -0.3 0.6" dir="0 0.5 -1" diffuse="0.8 0.8 0.8"/>
    <camera name="overview" pos="0.17 -0.2 {top + 0.16:.4g}" xyaxes="0.77 0.64 0 -0.37 0.45 0.81"/>
    <!-- still: the map holds the vibration (local Gamma {bowl.throw_number:g}, throw
         {math.degrees(bowl.throw_angle_rad):g} deg, {bowl.frequency_Hz:g} Hz, mu
         {bowl.friction_coefficient:g}) -->
    <body name="bowl">
      <geom name="column" type="cylinder" size="{bowl.radius_m - bowl.track_width_m / 2:.4g} {top / 2 + 0.01:.4g}"
            pos="0 0 {top / 2 - 0.01:.4g}" rgba="0.45 0.45 0.5 1" contype="0" conaffinity="0"/>
      {track if track is not None else bowl.track_geoms()}
    </body>
    {"".join(bodies)}
  </worldbody>
</mujoco>
"""


def helix_angle_of(bowl: Bowl, position: np.ndarray) -> float:
    """The unwrapped angle phi of a point about the bowl's axis, from its height (the spiral's
    turn) and its azimuth."""
    azimuth = math.atan2(position[1], position[0])
    turn = (position[2] * 2 * math.pi / bowl.pitch_m - azimuth) / (2 * math.pi)
    return azimuth + 2 * math.pi * round(turn)


__all__ = ["Bowl", "bowl_map", "bowl_scene_xml", "helix_angle_of", "PART_HALF_M",
           "PART_MASS_KG"]
