"""Fit the friction element's attributes with MuJoCo's own toolbox, mujoco.sysid.

`vibrofriction identify` is made for friction records: it chooses starts, selects effects, and
handles noise, stick-slip and sensor lag. mujoco.sysid (``pip install "mujoco[sysid]"``) is
MuJoCo's general fitter of an MjSpec to recorded sensors. It fits the plugin's attributes as
well, given two things this example shows:

- The plugin's attributes are strings in the spec's plugin config: a parameter's modifier
  writes ``config["mu"]``. Give it a unit near 1 (the stiffness in N/um, not N/m): the
  optimizer's steps are judged in the parameters' own units.
- mujoco.sysid divides each compared channel by its norm, and a plugin sensor may have a
  channel that stays zero (NaN, then). Compare only what was measured: the measured series
  keeps the model's full sensor layout, with NaN where nothing was measured, and
  ``enabled_observations`` names the measured sensors. (A series holding only the measured
  columns is compared against the wrong predicted columns in mujoco 4.0.0.)

The record here is the Dahl rig simulated with known values (use a lab record instead);
mu and the contact stiffness start 30 % off and come back.

    python examples/fit_with_mujoco_sysid.py
"""
from dataclasses import replace

import numpy as np

import mujoco
from mujoco import rollout

from vibrofriction.rigs import rig
from vibrofriction.params import FrictionParameters, RigParameters

try:
    from mujoco import sysid
    sysid.optimize  # noqa: B018  (mujoco.sysid imports empty without its extra)
except (ImportError, AttributeError):
    raise SystemExit('mujoco.sysid is not installed: pip install "mujoco[sysid]"') from None

MEASURED = ["slider_position", "drive_force"]  # what the lab's sensors give


def friction_attribute(key: str, unit: float = 1.0):
    """A mujoco.sysid modifier writing one attribute of the friction element's config."""
    def modify(spec: mujoco.MjSpec, parameter: sysid.Parameter) -> None:
        plugin = next(p for p in spec.plugins if p.name == "friction")
        config = dict(plugin.config)
        config[key] = repr(float(parameter.value[0]) * unit)
        plugin.config = config
    return modify


def record(setup: RigParameters, truth: FrictionParameters, duration_s: float):
    """Initial state, controls and the measured sensors of a simulated run."""
    timestep_s = rig.recommended_timestep(setup)
    model = rig.build_model(setup, truth, timestep_s)
    data = mujoco.MjData(model)
    steps = round(duration_s / timestep_s)
    initial_state = sysid.create_initial_state(model, data.qpos, data.qvel, data.act)
    controls = np.zeros((steps, model.nu))  # the rig is driven by its motion plugins
    state, sensordata = rollout.rollout(model, data, initial_state, controls[:-1])
    state, sensordata = state[0], sensordata[0]
    measured = np.full_like(sensordata, np.nan)
    for name in MEASURED:
        columns = slice(model.sensor(name).adr[0], model.sensor(name).adr[0] + model.sensor(name).dim[0])
        measured[:, columns] = sensordata[:, columns]
    return (initial_state, sysid.TimeSeries(np.arange(steps) * timestep_s, controls),
            sysid.TimeSeries.from_names(state[:, 0], measured, model))


def main() -> None:
    setup = RigParameters(vibration_velocity_amplitude_m_per_s=1.5e-3)
    truth = FrictionParameters(law="dahl", friction_coefficient=0.17,
                               contact_stiffness_N_per_m=60e6, alpha=1.5)
    initial_state, controls, sensors = record(setup, truth, duration_s=0.03)

    parameters = sysid.ParameterDict()
    parameters.add(sysid.Parameter("mu", nominal=0.2, min_value=0.05, max_value=0.5,
                                   modifier=friction_attribute("mu")))
    parameters.add(sysid.Parameter("stiffness_N_per_um", nominal=80.0, min_value=10.0,
                                   max_value=300.0, modifier=friction_attribute("stiffness", 1e6)))
    parameters["mu"].value[:] = 0.22                   # 30 % off
    parameters["stiffness_N_per_um"].value[:] = 78.0   # 30 % off

    start = replace(truth, friction_coefficient=0.22, contact_stiffness_N_per_m=78e6)
    scene = rig.build_spec(setup, start, rig.recommended_timestep(setup))
    sequences = sysid.ModelSequences("dahl rig", scene, "record", initial_state, controls,
                                     sensors)
    residual = sysid.build_residual_fn(
        models_sequences=[sequences],
        enabled_observations=[(name, sysid.SignalType.MjSensor) for name in MEASURED])
    fitted, _ = sysid.optimize(initial_params=parameters, residual_fn=residual,
                               optimizer="mujoco", verbose=False)
    print(f"mujoco.sysid: mu {fitted['mu'].value[0]:.4f} (true 0.17), contact stiffness "
          f"{fitted['stiffness_N_per_um'].value[0]:.2f} N/um (true 60)")


if __name__ == "__main__":
    main()
