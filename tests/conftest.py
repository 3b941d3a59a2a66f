"""Shared fixtures: the paper's rig parameters and helpers to run MuJoCo models of the rig.

Tests import the installed package (run scripts/dev_install.sh after changing plugin/).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import mujoco
import numpy as np
import pytest
from mujoco import rollout as mj_rollout

import vibrofriction
from vibrofriction.params import PAPER_NORMAL_FORCE_N, RigParameters
from vibrofriction.sim import initial_state, sensor_columns

# Friction bound of the paper rig: mu = 0.2 (params.py) times F_N = 55.2 N (paper, section 4).
PAPER_FRICTION_BOUND_N = 0.2 * PAPER_NORMAL_FORCE_N
# Whole identifications beyond one per feature (the other laws of a round trip, the tone, every
# hidden effect) run with VIBROFRICTION_FULL_MATRIX=1: the default suite stays near 10 minutes
# on 2 cores.
FULL_MATRIX = os.environ.get("VIBROFRICTION_FULL_MATRIX") == "1"
full_matrix_only = pytest.mark.skipif(
    not FULL_MATRIX, reason="one of the full matrix of identifications: run it with "
                            "VIBROFRICTION_FULL_MATRIX=1")
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclass(frozen=True)
class Rollout:
    """States after each step and sensors before each step (row i at t_i = i dt)."""

    model: mujoco.MjModel
    initial_state: np.ndarray
    state: np.ndarray  # (nstep, nstate): after step i
    sensordata: np.ndarray  # (nstep, nsensordata): computed in step i, i.e. at t_i

    def sensor(self, name: str) -> np.ndarray:
        return sensor_columns(self.model, self.sensordata, name)

    @property
    def states_before(self) -> np.ndarray:
        """State at t_i for each row (the initial state, then the states after steps 0..n-2)."""
        return np.vstack([self.initial_state[None], self.state[:-1]])

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(self.sensordata.shape[0]) * self.model.opt.timestep


def run_rollout(model: mujoco.MjModel, nstep: int, state0: np.ndarray | None = None) -> Rollout:
    data = mujoco.MjData(model)
    state0 = initial_state(model, data) if state0 is None else state0
    state, sensordata = mj_rollout.rollout(model, data, state0[None], nstep=nstep)
    return Rollout(model=model, initial_state=state0, state=state[0], sensordata=sensordata[0])


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture(scope="session", autouse=True)
def _plugin_loaded() -> None:
    vibrofriction.load()


@pytest.fixture(autouse=True)
def _no_callback_left_behind():
    """A test that installs mjcb_act_dyn must remove it (it is global to the process)."""
    yield
    assert mujoco.get_mjcb_act_dyn() is None, "mjcb_act_dyn left installed"


@pytest.fixture
def paper_rig():
    """RigParameters at the paper's values with the given v_a (m/s)."""
    def make(vibration_velocity_amplitude_m_per_s: float = 0.0, **changes) -> RigParameters:
        return RigParameters(
            vibration_velocity_amplitude_m_per_s=vibration_velocity_amplitude_m_per_s,
            **changes).validate()
    return make


def skip_unless_builtin(name: str):
    """Skip a test of MuJoCo's built-in variant ``name`` where the installed MuJoCo lacks it
    (MuJoCo 4.0 added joint springyield and the passive LuGre dcmotor)."""
    from vibrofriction.study.builtin import unavailable_variants
    missing = unavailable_variants().get(name)
    return pytest.mark.skipif(missing is not None,
                              reason=f"MuJoCo {mujoco.__version__} lacks {missing}")


def carriage_scene_xml(friction, *, mass_kg: float, timestep_s: float, measured: str,
                       actdim: int = 1, normal_N: float = 1.0) -> str:
    """A user's machine scene: a carriage on a guide with this friction (a FrictionParameters,
    written through the vocabulary), pushed by a measured force, ``measured``
    ("position_m" or "velocity_m_per_s") its output; the record's mapping in <custom>."""
    from vibrofriction.vocabulary import config_values, element_keys
    config = "".join(f'<config key="{k}" value="{v}"/>' for k, v in
                     config_values(friction, element_keys("friction")).items())
    sensor = {"position_m": "jointpos", "velocity_m_per_s": "jointvel"}[measured]
    return f"""
<mujoco model="carriage">
  <option timestep="{timestep_s!r}" integrator="Euler"/>
  <extension><plugin plugin="vibrofriction.friction"><instance name="guide_friction">
    <config key="law" value="{friction.law}"/><config key="normal" value="{normal_N}"/>{config}
  </instance></plugin></extension>
  <custom>
    <text name="vibrofriction:joint" data="slide"/>
    <text name="vibrofriction:body" data="carriage"/>
    <text name="vibrofriction:input:drive_force_N" data="push"/>
    <text name="vibrofriction:output:{measured}" data="measured"/>
  </custom>
  <worldbody><body name="carriage"><joint name="slide" type="slide" axis="1 0 0"/>
    <inertial pos="0 0 0" mass="{mass_kg}" diaginertia="1 1 1"/></body></worldbody>
  <actuator>
    <motor name="push" joint="slide"/>
    <plugin name="friction" joint="slide" instance="guide_friction" actdim="{actdim}"/>
  </actuator>
  <sensor><{sensor} name="measured" joint="slide"/></sensor>
</mujoco>"""
