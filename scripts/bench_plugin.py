#!/usr/bin/env python3
"""Benchmark of the vibrofriction plugin on the paper's rig (Gutowski & Leus 2012: m 0.5 kg,
k_t 80 N/um, v_d 0.5 mm/s, f 4 kHz, here v_a = 3 mm/s). Not a test: it prints, side by side:

1. Speed at dt = 1e-5 s, single thread, best of several repeats of ``mujoco.rollout``:
   steps/s of the bare rig (the same model with the friction element deleted via MjSpec), with
   the native plugin (each law), with the Python-callback law (mjcb_act_dyn), and the scipy
   reference (simulated seconds per wall second, as steps/s at dt = 1e-5 s); the plugin's
   overhead over the bare step.
2. Accuracy: the mean drive force's relative error against a converged run (dt = 1e-6 s) as a
   function of the timestep, for each law and for MuJoCo's built-in joint ``frictionloss``
   (mu F_N, solreffriction "2e-6 1") in place of the friction element.

    .venv/bin/python scripts/bench_plugin.py [--quick] [--json FILE]
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

import vibrofriction
from vibrofriction import rig as rig_module
from vibrofriction.params import LAWS, RigParameters, default_friction
from vibrofriction.python_law import (ContactParameters, act_dyn_callback, bare_rig_spec,
                                      dahl_zdot, python_law_spec)
from vibrofriction.reference import simulate_reference
from vibrofriction.summary import summarize

TIMESTEP_S = 1e-5
VA_M_PER_S = 3e-3
CONVERGED_TIMESTEP_S = 1e-6
TIMESTEPS_S = (1e-6, 2e-6, 5e-6, 1e-5, 2e-5, 5e-5, 1e-4)
QUICK_TIMESTEPS_S = (1e-6, 1e-5, 1e-4)
AMPLITUDES_M_PER_S = (0.75e-3, 3e-3)
FRICTIONLOSS_SOLREF = (2e-6, 1.0)
BARE = "bare rig (friction element removed)"
WITHOUT_SENSOR = "native plugin, dahl, without its state sensor"
BUILTIN_STATE = "built-in integrator actuator on the bare rig (one act, zero force)"


def _initial_state(model: mujoco.MjModel) -> np.ndarray:
    data = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return state


def _cpu_seconds(work: Callable[[], object]) -> float:
    """CPU time of this thread: rollout with nthread 0 steps in the calling thread, so other
    processes on a shared machine do not inflate it (wall time would)."""
    start = time.thread_time()
    work()
    return time.thread_time() - start


@contextlib.contextmanager
def _no_callback() -> Iterator[None]:
    yield


def speed(quick: bool) -> dict:
    """Steps/s of each model: interleaved rounds (every model once per round), best round."""
    nstep = 5000 if quick else 20000
    rounds = 5 if quick else 15
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA_M_PER_S)
    models: dict[str, tuple[mujoco.MjModel, Callable[[], contextlib.AbstractContextManager]]] = {
        BARE: (bare_rig_spec(rig, timestep_s=TIMESTEP_S).compile(), _no_callback)}
    for law in LAWS:
        models[f"native plugin, {law}"] = (
            rig_module.build_model(rig, default_friction(law, rig), TIMESTEP_S), _no_callback)
    # The element without its (optional) state sensor.
    no_sensor = rig_module.build_spec(rig, default_friction("dahl", rig), TIMESTEP_S)
    no_sensor.delete(no_sensor.sensor("friction_state"))
    models[WITHOUT_SENSOR] = (no_sensor.compile(), _no_callback)
    # What MuJoCo itself charges for an actuator with one activation state (no friction).
    models[BUILTIN_STATE] = (_bare_with_integrator_actuator(rig), _no_callback)
    dahl = default_friction("dahl", rig)
    contact = ContactParameters(dahl, rig.normal_force_N)
    models["Python callback (mjcb_act_dyn), dahl"] = (
        python_law_spec(rig, dahl, timestep_s=TIMESTEP_S).compile(),
        lambda: act_dyn_callback(dahl_zdot, contact))
    best = {name: math.inf for name in models}
    runs = {name: (model, mujoco.MjData(model), _initial_state(model)[None])
            for name, (model, _) in models.items()}
    for round_index in range(rounds + 1):  # round 0 warms up and is not counted
        for name, (model, data, state) in runs.items():
            with models[name][1]():
                seconds = _cpu_seconds(
                    lambda: mj_rollout.rollout(model, data, state, nstep=nstep))
            if round_index:
                best[name] = min(best[name], seconds)
    rows = {name: nstep / seconds for name, seconds in best.items()}
    simulated_s = 0.01 if quick else 0.03
    reference_s = min(_cpu_seconds(lambda: simulate_reference(rig, dahl, simulated_s,
                                                              sample_dt_s=TIMESTEP_S))
                      for _ in range(1 if quick else 3))
    rows["scipy reference (solve_ivp LSODA, rtol 1e-8), dahl"] = \
        simulated_s / reference_s / TIMESTEP_S
    bare = rows[BARE]
    return {"timestep_s": TIMESTEP_S, "nstep": nstep, "rounds": rounds,
            "steps_per_s": rows,
            "overhead_over_bare_pct": {name: 100 * (bare / value - 1)
                                       for name, value in rows.items()}}


def _bare_with_integrator_actuator(rig: RigParameters) -> mujoco.MjModel:
    """The bare rig plus a zero-gain built-in integrator actuator on the slider joint."""
    spec = bare_rig_spec(rig, timestep_s=TIMESTEP_S)
    actuator = spec.add_actuator()
    actuator.name = "zero_gain_integrator"
    actuator.target = "slider_on_table"
    actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
    actuator.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
    actuator.gainprm[0] = 0.0
    return spec.compile()


def _frictionloss_model(rig: RigParameters, timestep_s: float) -> mujoco.MjModel:
    spec = bare_rig_spec(rig, timestep_s=timestep_s)
    joint = spec.joint("slider_on_table")
    joint.frictionloss = 0.2 * rig.normal_force_N  # mu F_N, mu = 0.2 (params.py)
    joint.solref_friction = list(FRICTIONLOSS_SOLREF)  # MJCF solreffriction
    return spec.compile()


def _frictionloss_mean(rig: RigParameters, timestep_s: float, duration_s: float,
                       settle_s: float) -> float:
    model = _frictionloss_model(rig, timestep_s)
    nstep = int(round(duration_s / timestep_s))
    _, sensordata = mj_rollout.rollout(model, mujoco.MjData(model),
                                       _initial_state(model)[None], nstep=nstep)
    drive = sensordata[0][:, model.sensor_adr[model.sensor("drive_force").id]]
    t = np.arange(nstep) * timestep_s
    return summarize(t, drive, drive, 1 / rig.vibration_frequency_Hz, settle_s).mean_drive_force_N


def accuracy(quick: bool) -> dict:
    timesteps = QUICK_TIMESTEPS_S if quick else TIMESTEPS_S
    amplitudes = AMPLITUDES_M_PER_S[1:] if quick else AMPLITUDES_M_PER_S
    out: dict = {"timesteps_s": list(timesteps), "converged_timestep_s": CONVERGED_TIMESTEP_S,
                 "amplitudes_m_per_s": list(amplitudes), "mean_drive_force_N": {},
                 "relative_error_pct": {}}
    base = RigParameters()
    duration, settle = rig_module.default_times(base, default_friction("dahl", base))
    for va in amplitudes:
        rig = replace(base, vibration_velocity_amplitude_m_per_s=va)
        for law in LAWS:
            friction = default_friction(law, rig)
            means = {}
            for dt in timesteps:
                run = rig_module.simulate(rig, friction, duration_s=duration, timestep_s=dt,
                                          settle_time_s=settle)
                means[dt] = run.summary().mean_drive_force_N
            _record(out, f"{law}", va, means)
        means = {dt: _frictionloss_mean(rig, dt, duration, settle) for dt in timesteps}
        _record(out, "MuJoCo frictionloss, solreffriction 2e-6 1", va, means)
    return out


def _record(out: dict, name: str, va: float, means: dict[float, float]) -> None:
    key = f"{name} @ v_a {va * 1e3:g} mm/s"
    converged = means[CONVERGED_TIMESTEP_S]
    out["mean_drive_force_N"][key] = {repr(dt): m for dt, m in means.items()}
    out["relative_error_pct"][key] = {repr(dt): 100 * (m / converged - 1)
                                      for dt, m in means.items()}


def markdown(result: dict) -> str:
    s = result["speed"]
    lines = [f"### Speed (paper rig, v_a {VA_M_PER_S * 1e3:g} mm/s, dt {s['timestep_s']:g} s, "
             f"one thread, CPU time, best of {s['rounds']} rounds of {s['nstep']} steps)", "",
             "| model | steps/s | cost per step vs bare rig |", "|---|---:|---:|"]
    for name, value in s["steps_per_s"].items():
        overhead = s["overhead_over_bare_pct"][name]
        cost = "-" if name == BARE else f"{overhead:+.1f} %"
        lines.append(f"| {name} | {value:,.0f} | {cost} |")
    a = result["accuracy"]
    timesteps = a["timesteps_s"][1:]
    lines += ["", "### Mean drive force: relative error (%) against dt = 1e-6 s", "",
              "| model | " + " | ".join(f"dt {dt:g} s" for dt in timesteps) + " |",
              "|---|" + "---:|" * len(timesteps)]
    for key, errors in a["relative_error_pct"].items():
        converged = a["mean_drive_force_N"][key][repr(a["converged_timestep_s"])]
        cells = [f"{errors[repr(dt)]:+.2f}" for dt in timesteps]
        lines.append(f"| {key} (F = {converged:.3f} N) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def machine() -> dict:
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        cores = os.cpu_count()
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info
                       if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {"cpu": cpu, "cores": cores, "python": platform.python_version(),
            "mujoco": mujoco.__version__, "vibrofriction": vibrofriction.__version__}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="fewer repeats, shorter runs, three timesteps, v_a 3 mm/s only")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE",
                        help="also write the numbers as JSON")
    args = parser.parse_args(argv)
    vibrofriction.load()
    print("speed ...", file=sys.stderr, flush=True)
    result = {"machine": machine(), "quick": args.quick, "speed": speed(args.quick)}
    print("accuracy ...", file=sys.stderr, flush=True)
    result["accuracy"] = accuracy(args.quick)
    m = result["machine"]
    print(f"machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, "
          f"MuJoCo {m['mujoco']}\n")
    print(markdown(result))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
