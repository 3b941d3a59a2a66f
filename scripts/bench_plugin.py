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

import os

# Before numpy loads: idle OpenBLAS threads spin on the second core and disturb the timings.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import contextlib
import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from vibrofriction import sim
import vibrofriction
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import LAWS, RigParameters, default_friction
from vibrofriction.rigs.python_law import (ContactParameters, act_dyn_callback, bare_rig_spec,
                                           dahl_zdot, python_law_spec)
from vibrofriction.oracle.reference import simulate_reference
from vibrofriction.summary import summarize

TIMESTEP_S = 1e-5
VA_M_PER_S = 3e-3
CONVERGED_TIMESTEP_S = 1e-6
TIMESTEPS_S = (1e-6, 2e-6, 5e-6, 1e-5, 2e-5, 5e-5, 1e-4)
QUICK_TIMESTEPS_S = (1e-6, 1e-5, 1e-4)
AMPLITUDES_M_PER_S = (0.75e-3, 3e-3)
FRICTIONLOSS_SOLREF = (2e-6, 1.0)
BARE = "bare rig (friction element removed)"
BUILTIN_STATE = "built-in integrator actuator on the bare rig (one act, zero force)"


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
    """Steps/s of each model and its cost per step over the bare rig.

    Rounds of pairs: in each round every model runs right next to a run of the bare rig (in
    alternating order), and its cost in that round is its time over that bare run's time; the
    table gives the median over rounds with the interquartile range (a shared machine drifts,
    but little within a pair). Steps/s are from each model's best run.
    """
    nstep = 5000 if quick else 20000
    rounds = 5 if quick else 25
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=VA_M_PER_S)
    models: dict[str, tuple[mujoco.MjModel, Callable[[], contextlib.AbstractContextManager]]] = {
        BARE: (bare_rig_spec(rig, timestep_s=TIMESTEP_S).compile(), _no_callback)}
    for law in LAWS:
        # The element alone: its state sensor is an optional plugin of its own.
        element = rig_module.build_spec(rig, default_friction(law, rig), TIMESTEP_S)
        element.delete(element.sensor("friction_state"))
        models[f"native plugin, {law}"] = (element.compile(), _no_callback)
    for law in LAWS:
        models[f"native plugin, {law}, with its state sensor"] = (
            rig_module.build_model(rig, default_friction(law, rig), TIMESTEP_S), _no_callback)
    # What MuJoCo itself charges for an actuator with one activation state (no friction).
    models[BUILTIN_STATE] = (_bare_with_integrator_actuator(rig), _no_callback)
    dahl = default_friction("dahl", rig)
    contact = ContactParameters(dahl, rig.normal_force_N)
    models["Python callback (mjcb_act_dyn), dahl"] = (
        python_law_spec(rig, dahl, timestep_s=TIMESTEP_S).compile(),
        lambda: act_dyn_callback(dahl_zdot, contact))
    runs = {name: (model, mujoco.MjData(model), sim.initial_state(model)[None])
            for name, (model, _) in models.items()}

    def run(name: str) -> float:
        model, data, state = runs[name]
        with models[name][1]():
            return _cpu_seconds(lambda: mj_rollout.rollout(model, data, state, nstep=nstep))

    seconds: dict[str, list[float]] = {name: [] for name in models}
    ratios: dict[str, list[float]] = {name: [] for name in models if name != BARE}
    for round_index in range(rounds + 1):  # round 0 warms up and is not counted
        for pair_index, name in enumerate(ratios):
            if (round_index + pair_index) % 2:
                bare_s, model_s = run(BARE), run(name)
            else:
                model_s, bare_s = run(name), run(BARE)
            if round_index:
                seconds[BARE].append(bare_s)
                seconds[name].append(model_s)
                ratios[name].append(model_s / bare_s)
    rows = {name: nstep / min(times) for name, times in seconds.items()}
    overhead: dict[str, list[float]] = {BARE: [0.0, 0.0, 0.0]}
    for name, values in ratios.items():
        ratio_pct = 100 * (np.array(values) - 1)
        overhead[name] = [float(np.percentile(ratio_pct, q)) for q in (50, 25, 75)]
    simulated_s = 0.01 if quick else 0.03
    reference_s = min(_cpu_seconds(lambda: simulate_reference(rig, dahl, simulated_s,
                                                              sample_dt_s=TIMESTEP_S))
                      for _ in range(1 if quick else 3))
    reference = "scipy reference (solve_ivp LSODA, rtol 1e-8), dahl"
    rows[reference] = simulated_s / reference_s / TIMESTEP_S
    ratio = 100 * (rows[BARE] / rows[reference] - 1)
    overhead[reference] = [ratio, ratio, ratio]
    return {"timestep_s": TIMESTEP_S, "nstep": nstep, "rounds": rounds,
            "steps_per_s": rows,
            "overhead_over_bare_pct": {name: value[0] for name, value in overhead.items()},
            "overhead_over_bare_quartiles_pct": {name: value[1:]
                                                 for name, value in overhead.items()}}


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
                                       sim.initial_state(model)[None], nstep=nstep)
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
             f"one thread, CPU time, {s['rounds']} interleaved rounds of {s['nstep']} steps)",
             "",
             "| model | steps/s (best round) | cost per step vs bare rig: median (quartiles) "
             "of the rounds |", "|---|---:|---:|"]
    for name, value in s["steps_per_s"].items():
        overhead = s["overhead_over_bare_pct"][name]
        low, high = s["overhead_over_bare_quartiles_pct"][name]
        if name == BARE:
            cost = "-"
        elif low == high:  # timed separately (scipy)
            cost = f"{overhead:+.0f} %"
        else:
            cost = f"{overhead:+.1f} % ({low:+.1f} to {high:+.1f})"
        lines.append(f"| {name} | {value:,.0f} | {cost} |")
    if "accuracy" not in result:
        return "\n".join(lines)
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
    parser.add_argument("--speed-only", action="store_true",
                        help="skip the timestep-accuracy part (a few minutes)")
    args = parser.parse_args(argv)
    vibrofriction.load()
    print("speed ...", file=sys.stderr, flush=True)
    result = {"machine": machine(), "quick": args.quick, "speed": speed(args.quick)}
    if not args.speed_only:
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
