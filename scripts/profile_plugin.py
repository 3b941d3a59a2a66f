#!/usr/bin/env python3
"""Instructions per step of the rig with each friction law, split by library (valgrind callgrind).

Timings on a shared machine move by a per cent from run to run; instruction counts do not. This
script counts, for the bare rig (friction element removed) and for the rig with each law, the
instructions one ``mj_step`` executes, and splits the extra over the bare rig into what runs in
MuJoCo (libmujoco: its per-instance plugin dispatch, the extra actuator and activation), in the
vibrofriction library (the law) and in the math library (exp, sin). Each count is the
difference of two runs (5000 and 1000 steps), so start-up work cancels. Not a test; needs
valgrind on PATH. About half a minute per model.

--robot-scenes counts instead the plate-push robot scenes whose step scripts/bench_scaling.py
times (plate_push_resolved at dt = 10 us, plate_push_averaged at 1 ms), over the same push
window from the same state, in three variants: as is, the element's state sensor removed, and
bench_scaling's baseline (the element replaced by damping on the part: the same contacts).
Each count is the difference of two runs, one rollout of the window and enough rollouts of it
in one call to count >= 20 000 steps. It prints the element's share of the step (1 - baseline /
variant, as bench_scaling) with and without its sensor, what the plugins' callbacks (compute,
advance) cost with the functions they call (the rest of the element's extra is MuJoCo's own),
and what some MuJoCo functions cost with their callees: mj_rnePostConstraint, which MuJoCo runs
for any plugin sensor of the acceleration stage. It stops if the plugin library is rebuilt
during the run. About a quarter of an hour.

    .venv/bin/python scripts/profile_plugin.py [--laws dahl,lugre] [--json FILE]
    .venv/bin/python scripts/profile_plugin.py --robot-scenes [--json FILE]
"""
from __future__ import annotations

import argparse
import collections
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SHORT_STEPS, LONG_STEPS = 1000, 5000
LAWS = ("coulomb", "dahl", "dupont", "lugre")
BARE = "bare"
# MuJoCo's own cost of an activation (a built-in zero-gain integrator actuator, no plugin) and
# of one more plugin instance (the element's optional state sensor).
INTEGRATOR = "integrator"
DAHL_WITH_SENSOR = "dahl+sensor"
# libc (malloc, memcpy) also serves Python's start-up, which varies a little between runs: only
# the math library is a column of its own.
LIBRARIES = {"libmujoco": "MuJoCo", "libvibrofriction_plugin": "vibrofriction",
             "libm.so": "math library"}
COLUMNS = ("MuJoCo", "vibrofriction", "math library")
# --robot-scenes: the variants besides bench_scaling's "as is" and damped baseline.
SENSOR_REMOVED = "state sensor removed"
# MuJoCo functions counted with their callees (per step): the post-constraint RNE that plugin
# sensors of the acceleration stage trigger, the actuation stage (the actuator plugin's
# dispatch and compute) and the constraint stage (which the baseline must keep the same).
FUNCTIONS = ("mj_rnePostConstraint", "mj_fwdActuation", "mj_fwdConstraint")
# The vibrofriction plugins' callbacks (compute, advance, ...) that MuJoCo calls, with the
# MuJoCo, C and math library functions they call: the rest of a plugin's cost is MuJoCo's own.
CALLBACKS = "plugin callbacks"
SCENE_COUNTED_STEPS = 20_000  # start-up varies by ~1e6 instructions between runs


def _scene_model(scene: str, variant: str):
    """A plate-push robot scene as compiled by scripts/bench_scaling.py, or (SENSOR_REMOVED) as
    is without the plugin sensors that read a friction element's state."""
    import bench_scaling  # scripts/ is sys.path[0]: this script's directory
    import mujoco

    if variant != SENSOR_REMOVED:
        return bench_scaling._scene_spec(scene, variant).compile()
    spec = bench_scaling._scene_spec(scene, bench_scaling.WITH)
    sensors = [sensor for sensor in spec.sensors
               if sensor.type == mujoco.mjtSensor.mjSENS_PLUGIN
               and sensor.plugin.plugin_name in bench_scaling.STATE_SENSOR_PLUGINS]
    if not sensors:
        raise RuntimeError(f"{scene} has no friction state sensor to remove")
    for sensor in sensors:
        spec.delete(sensor)  # and with it the sensor's own plugin instance
    return spec.compile()


def _scene_child(window: Path, nroll: int) -> None:
    """Runs a saved push window nroll times in one rollout call (under valgrind)."""
    import mujoco
    import numpy as np
    from mujoco import rollout

    import vibrofriction

    vibrofriction.load()
    saved = np.load(window)
    model = _scene_model(str(saved["scene"]), str(saved["variant"]))
    data = mujoco.MjData(model)
    control = saved["control"]
    rollout.rollout(model, data, np.repeat(saved["state"][None], nroll, axis=0),
                    np.repeat(control[None], nroll, axis=0), nstep=control.shape[0])


def _child(model: str, nstep: int) -> None:
    """Steps the model nstep times in one rollout call (runs under valgrind); a saved push
    window (.npz) instead runs nstep times."""
    if model.endswith(".npz"):
        _scene_child(Path(model), nstep)
        return
    import mujoco
    from mujoco import rollout

    from vibrofriction import sim
    from vibrofriction.rigs import rig as rig_module
    from vibrofriction.params import RigParameters, default_friction
    from vibrofriction.rigs.python_law import bare_rig_spec

    rig = RigParameters(vibration_velocity_amplitude_m_per_s=3e-3)
    if model == BARE:
        compiled = bare_rig_spec(rig, timestep_s=1e-5).compile()
    elif model == INTEGRATOR:
        spec = bare_rig_spec(rig, timestep_s=1e-5)
        actuator = spec.add_actuator(name="zero_gain_integrator", target="slider_on_table",
                                     trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
        actuator.gainprm[0] = 0.0
        compiled = spec.compile()
    elif model == DAHL_WITH_SENSOR:
        compiled = rig_module.build_spec(rig, default_friction("dahl", rig), 1e-5).compile()
    else:
        spec = rig_module.build_spec(rig, default_friction(model, rig), 1e-5)
        spec.delete(spec.sensor("friction_state"))  # the element alone, as bench_plugin.py
        compiled = spec.compile()
    data = mujoco.MjData(compiled)
    rollout.rollout(compiled, data, sim.initial_state(compiled, data)[None], nstep=nstep)


def _instructions_by_library(model: str, nstep: int, workdir: Path,
                             with_functions: bool = False) -> collections.Counter:
    """Instructions of one run by library; with_functions: also FUNCTIONS and CALLBACKS, each
    with its callees."""
    out = workdir / f"callgrind.{Path(model).stem}.{nstep}"
    env = dict(os.environ, PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1")
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                    sys.executable, __file__, "--child", model, str(nstep)],
                   check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    report = subprocess.run(["callgrind_annotate", "--threshold=100", str(out)], check=True,
                            capture_output=True, text=True).stdout
    counts: collections.Counter = collections.Counter()
    if with_functions:
        inclusive = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100",
                                    str(out)], check=True, capture_output=True, text=True).stdout
        for line in inclusive.splitlines():
            match = re.match(r"\s*([\d,]+) \([ \d.]+%\)\s+[^:]*:(.*) \[(.*)\]\s*$", line)
            if not match:
                continue
            count, name, library = int(match.group(1).replace(",", "")), *match.group(2, 3)
            if "libmujoco" in library and name in FUNCTIONS:
                counts[name] += count
            # The entry points MuJoCo calls: plugin_util.h's SetPluginCallbacks lambdas (they
            # do not call one another, so their inclusive counts add up).
            elif ("libvibrofriction_plugin" in library
                  and name.startswith("vibrofriction::SetPluginCallbacks<") and "::_FUN(" in name):
                counts[CALLBACKS] += count
    for line in report.splitlines():
        match = re.match(r"\s*([\d,]+) \([ \d.]+%\)\s+(.*)", line)
        if not match:
            continue
        count = int(match.group(1).replace(",", ""))
        name = match.group(2)
        if "PROGRAM TOTALS" in name:
            counts["total"] = count
            continue
        library = next((label for key, label in LIBRARIES.items() if key in name), "other")
        counts[library] += count
    return counts


def _per_step(model: str, workdir: Path) -> dict[str, float]:
    short = _instructions_by_library(model, SHORT_STEPS, workdir)
    long = _instructions_by_library(model, LONG_STEPS, workdir)
    return {key: (long[key] - short[key]) / (LONG_STEPS - SHORT_STEPS)
            for key in set(short) | set(long)}


# ---- --robot-scenes --------------------------------------------------------------------------

def _save_push_windows(scene: str, workdir: Path) -> tuple[dict[str, Path], int]:
    """Saves each variant's push window (the model's name, start state, controls) as
    scripts/bench_scaling.py times it; returns the files and the window's steps."""
    import bench_scaling
    import mujoco
    import numpy as np
    from mujoco import rollout

    import vibrofriction

    vibrofriction.load()
    as_is = bench_scaling._scene_workload(scene, bench_scaling.WITH)
    damped = bench_scaling._scene_workload(scene, bench_scaling.DAMPED)
    # The state sensor does not act on the physics: without it the scene runs the same states
    # from the same start (checked here over the whole window, as are MuJoCo's warnings).
    sensorless = _scene_model(scene, SENSOR_REMOVED)
    runs = ((bench_scaling.WITH, as_is.model, as_is), (SENSOR_REMOVED, sensorless, as_is),
            (bench_scaling.DAMPED, damped.model, damped))
    states = {}
    for variant, model, work in runs:
        data = mujoco.MjData(model)
        states[variant], _ = rollout.rollout(model, data, work.state[None], work.control[None],
                                             nstep=work.nstep)
        bench_scaling._check_warnings(data, f"{scene}, {variant}")
    if not np.array_equal(states[bench_scaling.WITH], states[SENSOR_REMOVED]):
        raise RuntimeError(f"{scene}: removing the state sensor changes the trajectory")
    windows = {}
    for variant, _, work in runs:
        windows[variant] = workdir / f"{scene}.{len(windows)}.npz"
        np.savez(windows[variant], scene=scene, variant=variant, state=work.state,
                 control=work.control)
    return windows, as_is.nstep


def _robot_scenes(workdir: Path) -> dict:
    import bench_scaling

    from vibrofriction.laws import library_path

    def library_stamp() -> tuple[int, int]:
        status = library_path().stat()
        return status.st_mtime_ns, status.st_size

    library = library_stamp()
    variants = (bench_scaling.WITH, SENSOR_REMOVED, bench_scaling.DAMPED)
    scenes = {}
    for scene in bench_scaling.SCENES:
        windows, window_steps = _save_push_windows(scene, workdir)
        nroll = 1 + math.ceil(SCENE_COUNTED_STEPS / window_steps)
        counted = (nroll - 1) * window_steps
        rows = {}
        for variant in variants:
            print(f"[{len(scenes) * len(variants) + len(rows) + 1}/"
                  f"{len(bench_scaling.SCENES) * len(variants)}] callgrind: {scene}, {variant}",
                  file=sys.stderr, flush=True)
            short = _instructions_by_library(str(windows[variant]), 1, workdir, True)
            long = _instructions_by_library(str(windows[variant]), nroll, workdir, True)
            rows[variant] = {key: (long[key] - short[key]) / counted
                             for key in set(short) | set(long)}
        scenes[scene] = {"window_steps": window_steps, "counted_steps": counted, "rows": rows}
    if library_stamp() != library:
        raise RuntimeError(f"{library_path()} was rebuilt during the run: the counts mix two "
                           "builds; run again")
    return scenes


def _print_robot_scenes(scenes: dict) -> None:
    import bench_scaling

    def extra(row: dict, base: dict, key: str = "total") -> float:
        return row.get(key, 0.0) - base.get(key, 0.0)

    with_, damped = bench_scaling.WITH, bench_scaling.DAMPED
    inclusive = (CALLBACKS, *FUNCTIONS)
    for scene, result in scenes.items():
        rows = result["rows"]
        base = rows[damped]
        print(f"\n{scene}: instructions per step over bench_scaling.py's push window "
              f"({result['window_steps']} steps, {result['counted_steps']} counted); baseline: "
              f"{damped}")
        print(f"{'variant':28s} {'total':>8s} {'share':>6s} " +
              " ".join(f"{c:>13s}" for c in COLUMNS) + " " +
              " ".join(f"{f:>20s}" for f in inclusive))
        for variant, row in rows.items():
            if variant == damped:
                share, sign = f"{'-':>6s}", ""
            else:
                share, sign = f"{100 * (1 - base['total'] / row['total']):5.1f}%", "+"
            print(f"{variant:28s} {row['total']:8.0f} {share} " +
                  " ".join(f"{row.get(c, 0.0) - (base.get(c, 0.0) if sign else 0.0):{sign}13.0f}"
                           for c in COLUMNS) + " " +
                  " ".join(f"{row.get(f, 0.0):20.0f}" for f in inclusive))
        sensorless = rows[SENSOR_REMOVED]
        element, callbacks = extra(sensorless, base), extra(sensorless, base, CALLBACKS)
        own_code = extra(sensorless, base, "vibrofriction")
        sensor = extra(rows[with_], sensorless)
        print(f"- element with its state sensor: {extra(rows[with_], base):+.0f} instructions a "
              f"step, {100 * (1 - base['total'] / rows[with_]['total']):.1f} % of the step")
        print(f"- element alone: {element:+.0f}, {100 * element / sensorless['total']:.1f} % of "
              f"its step: its callbacks {callbacks:+.0f} (vibrofriction {own_code:+.0f}, the "
              f"rest in the MuJoCo, C and math library functions they call), MuJoCo's own "
              f"{element - callbacks:+.0f} (two actuators with activations, the plugin dispatch)")
        print(f"- its state sensor: {sensor:+.0f}: mj_rnePostConstraint "
              f"{extra(rows[with_], sensorless, FUNCTIONS[0]):+.0f}, the sensor's callbacks "
              f"{extra(rows[with_], sensorless, CALLBACKS):+.0f}")
    print(f"(share: 1 - baseline / variant, as bench_scaling.py; library columns: extra over the "
          f"baseline, whose own counts they show; {', '.join(inclusive)}: with callees)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", default=None,
                        help="comma-separated laws (default: all four)")
    parser.add_argument("--robot-scenes", action="store_true",
                        help="count the plate-push robot scenes (as is, state sensor removed, "
                             "element replaced by damping) instead of the rig")
    parser.add_argument("--json", type=Path, help="also write the counts as JSON")
    parser.add_argument("--child", nargs=2, metavar=("MODEL", "NSTEP"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        _child(args.child[0], int(args.child[1]))
        return 0
    if args.robot_scenes and args.laws is not None:
        parser.error("--laws is for the rig; --robot-scenes counts the scenes' own element")
    laws = [law.strip() for law in (args.laws or ",".join(LAWS)).split(",") if law.strip()]
    unknown = sorted(set(laws) - set(LAWS))
    if unknown:
        parser.error(f"unknown law(s) {', '.join(unknown)}; use some of {', '.join(LAWS)}")
    missing = [tool for tool in ("valgrind", "callgrind_annotate") if shutil.which(tool) is None]
    if missing:
        print(f"profile_plugin.py needs {' and '.join(missing)} on PATH (e.g. apt install "
              "valgrind); bench_plugin.py measures time without it", file=sys.stderr)
        return 2
    if args.robot_scenes:
        with tempfile.TemporaryDirectory(prefix="vibrofriction-callgrind-") as tmp:
            scenes = _robot_scenes(Path(tmp))
        _print_robot_scenes(scenes)
        if args.json:
            args.json.write_text(json.dumps({"robot_scenes": scenes}, indent=2) + "\n")
        return 0
    rows: dict[str, dict[str, float]] = {}
    models = [BARE, INTEGRATOR, *laws, DAHL_WITH_SENSOR]
    with tempfile.TemporaryDirectory(prefix="vibrofriction-callgrind-") as tmp:
        for index, model in enumerate(models, start=1):
            print(f"[{index}/{len(models)}] callgrind: {model}", file=sys.stderr, flush=True)
            rows[model] = _per_step(model, Path(tmp))
    bare = rows[BARE]
    columns = COLUMNS
    print(f"\nInstructions per step (rig at v_a = 3 mm/s, dt = 1e-5 s, element without its "
          f"sensor); bare rig: {bare['total']:.0f}")
    print(f"{'model':12s} {'total':>8s} {'over bare':>10s} " +
          " ".join(f"{c:>14s}" for c in columns))
    for model in models[1:]:
        row = rows[model]
        extra = {c: row.get(c, 0.0) - bare.get(c, 0.0) for c in columns}
        print(f"{model:12s} {row['total']:8.0f} {100 * (row['total'] / bare['total'] - 1):+9.1f}% " +
              " ".join(f"{extra[c]:+14.0f}" for c in columns))
    print("(columns: extra instructions per step over the bare rig, by library; integrator: a "
          "built-in zero-gain integrator actuator instead of the element; dahl+sensor: the "
          "element with its state sensor plugin)")
    if args.json:
        args.json.write_text(json.dumps({"instructions_per_step": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
