#!/usr/bin/env python3
"""Benchmark of how the friction element's cost scales (issue 11, item 2). Not a test: it
prints, measured side by side in one run (one thread: ``mujoco.rollout`` with one MjData, timed
by the calling thread's CPU time):

A. The element's share of the step in a robot-size scene: the plate-push SCARA scene
   (mjcf_models/robots/plate_push_resolved.xml at dt = 10 us, plate_push_averaged.xml at
   dt = 1 ms) as is, and two baselines made through MjSpec: the element removed (its plugin
   instance, the two actuators that use it and the state sensor that reads them; the part then
   slides on MuJoCo's frictionless contact) and the element replaced by joint damping on the
   part (mu m g at the push speed). Removed, the part runs ahead of the pusher and the scene
   has fewer contacts and constraint rows (MuJoCo 4.0: 4-5 contacts and 4-8 rows a step
   instead of 6 and 12), which the share would wrongly count as the element's; damped, the
   contacts are the same, so the goal (share <= 2 %) is judged against that baseline. All
   start from the same point of the push (after a settled approach, as in
   scripts/bench_averaged.py) and run >= 1e4 steps of the push per measurement, in
   interleaved rounds. Share = 1 - baseline / as is.
B. Cost against the number of elements: one model holding N independent copies of the paper's
   rig (mjcf_models/rig/, Dahl, v_a = 3 mm/s, each with its own slider, drive spring, vibrating
   table, friction element and state sensor), N = 1 ... 100, at the rig's recommended timestep,
   and the same N-rig model with every friction element (and its state sensor) removed: the
   bare cost. The copies are made with MjSpec.attach (prefix rig<i>_ each), not from generated
   MJCF text. attach prefixes the plugin instances' names but not the names inside their
   config (the state sensor's ``actuator``, the dynamometer's ``tendon``): those are prefixed
   before attaching. Every rig starts in the single rig's settled state (its steady vibrating
   slide) and must reproduce the single, unattached rig's sensor values after the first run.
   Per N: best of 5 (--quick: 3) interleaved runs of >= 0.2 s (rollouts of the same 1000
   steps), each next to the bare model's run, and a least-squares fit t(N) = a + b N with its
   largest relative deviation (small when the cost grows linearly); b with elements minus
   b bare is one element's cost.

MuJoCo warnings after any run stop the script with an error.

    .venv/bin/python scripts/bench_scaling.py [--quick] [--json FILE]
"""
from __future__ import annotations

import os

# Before numpy loads: idle OpenBLAS threads spin on the second core and disturb the timings.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from vibrofriction import sim
import vibrofriction
from vibrofriction.rigs import rig as rig_module
from vibrofriction.robots import scenes
from vibrofriction.params import RigParameters, default_friction

# The same CPU timer and machine description as the per-step benchmark (run from scripts/).
from bench_plugin import _cpu_seconds, machine

# Plugins that are a friction element, and the state sensors that read one.
ELEMENT_PLUGINS = ("vibrofriction.friction", "vibrofriction.planar", "vibrofriction.averaged")
STATE_SENSOR_PLUGINS = ("vibrofriction.friction_sensor", "vibrofriction.planar_sensor")
# Config keys of the vibrofriction plugins whose values name other model elements.
NAME_CONFIG_KEYS = ("actuator", "tendon", "normal_sensor", "contact_geom1", "contact_geom2")

FULL_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
SHARE_GOAL_PCT = 2.0
SCENES = ("plate_push_resolved", "plate_push_averaged")  # each at its own timestep
WITH, REMOVED, DAMPED = "as is", "element removed", "element replaced by damping"
SCENE_VARIANTS = (REMOVED, WITH, DAMPED)  # run order: as is next to each baseline
SCENE_MIN_STEPS = 10_000
RIG_VA_M_PER_S = 3e-3
RIG_LAW = "dahl"
COPIES = (1, 2, 5, 10, 20, 50, 100)
QUICK_COPIES = (1, 10, 30)
COPIES_MIN_RUN_S = 0.2
COPIES_WINDOW_STEPS = 1000  # ~20 vibration periods, the same window for every N
COPY_PREFIX = "rig"
LINEAR_TOLERANCE_PCT = 10.0  # above the run-to-run noise of a best-of-runs time


def _check_warnings(data: mujoco.MjData, what: str) -> None:
    warnings = {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(data.warning)
                if w.number}
    if warnings:
        raise RuntimeError(f"MuJoCo warnings in {what}: {warnings}")


def remove_friction_elements(spec: mujoco.MjSpec) -> int:
    """Delete every friction element from ``spec``: its plugin instance, the actuators that
    use it and the state sensors that read them. Returns the number of instances deleted."""
    names = {p.name for p in spec.plugins if p.plugin_name in ELEMENT_PLUGINS}
    for actuator in list(spec.actuators):
        if actuator.plugin.active and actuator.plugin.name in names:
            spec.delete(actuator)
    for sensor in list(spec.sensors):
        # Only plugin_name: reading sensor.plugin.config crashes MuJoCo 4.0's bindings for a
        # sensor that points to a named instance.
        if (sensor.type == mujoco.mjtSensor.mjSENS_PLUGIN
                and sensor.plugin.plugin_name in STATE_SENSOR_PLUGINS):
            spec.delete(sensor)
    # MuJoCo deletes an instance (and a sensor's own one) with the last element that uses it:
    # look again rather than delete a held instance twice, which corrupts memory.
    for instance in [p for p in spec.plugins if p.name in names]:
        spec.delete(instance)
    return len(names)


@dataclass
class Workload:
    """One timed run: ``nroll`` rollouts of ``nstep`` steps, each from ``state``."""

    label: str
    model: mujoco.MjModel
    state: np.ndarray                  # (nstate,) full physics state
    nstep: int
    control: np.ndarray | None = None  # (nstep, nu); None: zero ctrl
    nroll: int = field(default=0, init=False)
    last_sensordata: np.ndarray | None = field(default=None, init=False)  # first rollout's

    def __post_init__(self) -> None:
        self.data = mujoco.MjData(self.model)
        self.set_nroll(1)

    def set_nroll(self, nroll: int) -> None:
        """Make the inputs and outputs of nroll rollouts outside the timing: np.full writes
        the outputs, so the rollout does not pay their first-touch page faults."""
        self.nroll = nroll
        self._states = np.repeat(self.state[None], nroll, axis=0)
        self._control = (None if self.control is None
                         else np.repeat(self.control[None], nroll, axis=0))
        nstate = mujoco.mj_stateSize(self.model, FULL_STATE)
        self._state_out = np.full((nroll, self.nstep, nstate), np.nan)
        self._sensordata_out = np.full((nroll, self.nstep, self.model.nsensordata), np.nan)

    def seconds_per_step(self) -> float:
        seconds = _cpu_seconds(lambda: mj_rollout.rollout(
            self.model, self.data, self._states, self._control, nstep=self.nstep,
            state=self._state_out, sensordata=self._sensordata_out))
        _check_warnings(self.data, self.label)
        self.last_sensordata = self._sensordata_out[0, -1].copy()
        return seconds / (self.nroll * self.nstep)

    def calibrate(self, min_steps: int, min_seconds: float) -> None:
        """Set nroll for >= min_steps steps and >= min_seconds a run (this run warms up)."""
        self.set_nroll(1)
        per_rollout_s = self.seconds_per_step() * self.nstep
        self.set_nroll(max(math.ceil(min_steps / self.nstep),
                           math.ceil(min_seconds / per_rollout_s)))


def _interleaved(workloads: list[Workload], rounds: int) -> list[list[float]]:
    """Seconds per step of each workload in each round, after an uncounted warm-up round; the
    order alternates round by round so that a drift of the machine's load hits all alike."""
    times: list[list[float]] = [[] for _ in workloads]
    for r in range(rounds + 1):
        order = list(enumerate(workloads))
        for i, work in (order if r % 2 == 0 else order[::-1]):
            seconds = work.seconds_per_step()
            if r:
                times[i].append(seconds)
    return times


# ---- A: the element's share of a robot scene's step ----------------------------------------------

def _scene_spec(name: str, variant: str) -> mujoco.MjSpec:
    spec = mujoco.MjSpec.from_file(str(scenes.scene_path(name)))
    if variant == WITH:
        return spec
    if remove_friction_elements(spec) == 0:
        raise RuntimeError(f"{name} has no friction element to remove")
    if variant == DAMPED:
        # Drag mu m g at the push speed: the part stays against the pusher as with the
        # element, so the contacts, and the constraint solver's work, are the same.
        plan = scenes.PushPlan()
        damping = (scenes.PLATE_PART_FRICTION.friction_coefficient * scenes.PART_MASS_KG
                   * scenes.GRAVITY_M_PER_S2 / plan.speed_m_per_s)
        for joint in ("part_x", "part_y"):
            spec.joint(joint).damping = [damping, 0.0, 0.0]
    return spec


def _scene_workload(name: str, variant: str) -> Workload:
    """The push phase of a plate-push scene (as scripts/bench_averaged.py, _scene_cost)."""
    model = _scene_spec(name, variant).compile()
    dt = model.opt.timestep
    plan = scenes.PushPlan()
    start_s = plan.push_start_s + 0.2  # the part is being pushed from here on
    k0 = int(round(start_s / dt))
    window = min(SCENE_MIN_STEPS, int(plan.push_end_s / dt) - k0)  # steps, within the push
    ctrl = scenes.push_controls(model, plan, k0 + window, 1.0)
    x, y, quill = plan.pusher(0.0)
    q1, q2 = scenes.scara_ik(x, y)
    state0 = scenes.initial_state(model, ctrl[0], {"shoulder": q1, "elbow": q2, "quill": quill})
    lead = scenes.run_scene(model, ctrl[:k0], state0)
    label = f"{name}, {variant}"
    if lead.warnings:
        raise RuntimeError(f"MuJoCo warnings in {label}: {lead.warnings}")
    return Workload(label, model, lead.state[-1], window, control=ctrl[k0:])


def scene_share(name: str, rounds: int) -> dict:
    """Time per step of each variant, and the element's share of the step against each
    baseline: the median over rounds of 1 - baseline / as is, the two run next to each other
    (the machine's speed drifts by tens of % over seconds, little within a pair)."""
    workloads = {variant: _scene_workload(name, variant) for variant in SCENE_VARIANTS}
    as_is = workloads[WITH]
    as_is.calibrate(SCENE_MIN_STEPS, 0.1)
    for work in workloads.values():
        work.set_nroll(as_is.nroll)  # the same work in each
    times = dict(zip(workloads, _interleaved(list(workloads.values()), rounds)))
    with_s = np.array(times[WITH])
    out = {"scene": name, "timestep_s": as_is.model.opt.timestep,
           "steps_per_run": as_is.nroll * as_is.nstep, "rounds": rounds,
           "goal_pct": SHARE_GOAL_PCT, "us_per_step": {}, "share_pct": {},
           "share_quartiles_pct": {}, "share_of_best_times_pct": {}}
    for variant in (WITH, REMOVED, DAMPED):
        seconds = np.array(times[variant])
        out["us_per_step"][variant] = 1e6 * seconds.min()
        if variant != WITH:
            share = 100 * (1 - seconds / with_s)
            out["share_pct"][variant] = float(np.median(share))
            out["share_quartiles_pct"][variant] = np.percentile(share, [25, 75]).tolist()
            out["share_of_best_times_pct"][variant] = 100 * (1 - seconds.min() / with_s.min())
    return out


# ---- B: cost against the number of elements ------------------------------------------------------

def _prefix_name_configs(spec: mujoco.MjSpec, prefix: str) -> None:
    """Prefix the element names inside plugin configs, which attach leaves as they are."""
    for plugin in spec.plugins:
        config = dict(plugin.config)
        if any(key in config for key in NAME_CONFIG_KEYS):
            plugin.config = {key: prefix + value if key in NAME_CONFIG_KEYS else value
                             for key, value in config.items()}


def _rig_spec(rig: RigParameters, timestep_s: float, with_element: bool) -> mujoco.MjSpec:
    spec = rig_module.build_spec(rig, default_friction(RIG_LAW, rig), timestep_s)
    if not with_element:
        remove_friction_elements(spec)
    return spec


def rig_copies(n: int, rig: RigParameters, timestep_s: float,
               with_element: bool) -> mujoco.MjModel:
    """One model with n independent rigs, attached with the prefixes rig0_, rig1_, ..."""
    parent = mujoco.MjSpec()
    parent.modelname = f"{n} rigs"
    for i in range(n):
        child = _rig_spec(rig, timestep_s, with_element)
        if i == 0:  # attach keeps the parent's options: take the rig's
            parent.option.timestep = child.option.timestep
            parent.option.integrator = child.option.integrator
        prefix = f"{COPY_PREFIX}{i}_"
        _prefix_name_configs(child, prefix)
        # Side by side in y (for a viewer; the rigs' geoms do not collide).
        frame = parent.worldbody.add_frame(pos=[0.0, 0.1 * i, 0.0])
        parent.attach(child, prefix=prefix, frame=frame)
    return parent.compile()


def _settled_state(model: mujoco.MjModel, nstep: int, label: str) -> np.ndarray:
    """Full physics state after nstep steps from rest."""
    data = mujoco.MjData(model)
    state, _ = mj_rollout.rollout(model, data, sim.initial_state(model)[None],
                                  nstep=nstep)
    _check_warnings(data, label)
    return state[0, -1]


def _tiled_state(single: mujoco.MjModel, state: np.ndarray, model: mujoco.MjModel,
                 n: int) -> np.ndarray:
    """State of the n-rig model with every rig in the single rig's ``state``."""
    one, many = mujoco.MjData(single), mujoco.MjData(model)
    mujoco.mj_setState(single, one, state, FULL_STATE)
    many.time = one.time
    # attach appends each rig's joints and actuators in the rig's own order.
    many.qpos[:] = np.tile(one.qpos, n)
    many.qvel[:] = np.tile(one.qvel, n)
    many.act[:] = np.tile(one.act, n)
    # Plugin instances come in another order (a sensor's own instance first): match by name.
    for j in range(model.nplugin):
        size = model.plugin_statenum[j]
        if size == 0:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, j).split("_", 1)[1]
        k = mujoco.mj_name2id(single, mujoco.mjtObj.mjOBJ_PLUGIN, name)
        a, b = model.plugin_stateadr[j], single.plugin_stateadr[k]
        many.plugin_state[a:a + size] = one.plugin_state[b:b + size]
    out = np.empty(mujoco.mj_stateSize(model, FULL_STATE))
    mujoco.mj_getState(model, many, out, FULL_STATE)
    return out


def copies_scaling(copies: tuple[int, ...], rounds: int) -> dict:
    rig = RigParameters(vibration_velocity_amplitude_m_per_s=RIG_VA_M_PER_S)
    dt = rig_module.recommended_timestep(rig)
    # Time the rigs' steady vibrating slide, not their start from rest.
    settle_s = rig_module.default_times(rig, default_friction(RIG_LAW, rig))[1]
    workloads: dict[tuple[int, bool], Workload] = {}
    for with_element in (True, False):
        kind = "with elements" if with_element else "bare"
        single = _rig_spec(rig, dt, with_element).compile()  # not attached: the reference
        settled = _settled_state(single, int(round(settle_s / dt)), f"single rig, {kind}")
        reference = Workload(f"single rig, {kind}", single, settled, COPIES_WINDOW_STEPS)
        reference.seconds_per_step()
        for n in copies:
            label = f"{n} rigs, {kind}"
            model = rig_copies(n, rig, dt, with_element)
            work = Workload(label, model, _tiled_state(single, settled, model, n),
                            COPIES_WINDOW_STEPS)
            work.calibrate(0, COPIES_MIN_RUN_S)
            # Every rig must run as the single one: same sensor values, in rig order.
            if not np.allclose(work.last_sensordata.reshape(n, -1), reference.last_sensordata,
                               rtol=1e-9, atol=1e-12):
                raise RuntimeError(f"{label}: the rigs do not reproduce the single rig")
            workloads[n, with_element] = work
    # Each N with elements next to its bare model, so that the pair sees the same machine.
    keys = [(n, with_element) for n in copies for with_element in (True, False)]
    times = {key: np.array(t)
             for key, t in zip(keys, _interleaved([workloads[key] for key in keys], rounds))}
    best = {key: t.min() for key, t in times.items()}
    out: dict = {"law": RIG_LAW, "va_m_per_s": RIG_VA_M_PER_S, "timestep_s": dt,
                 "settle_s": settle_s, "rounds": rounds, "copies": list(copies),
                 "rows": [], "fit": {}}
    n_copies = np.array(copies, dtype=float)
    for with_element, key in ((True, "with"), (False, "bare")):
        t = np.array([best[n, with_element] for n in copies])
        b, a = np.polyfit(n_copies, t, 1)
        deviation = np.abs(t - (a + b * n_copies)) / t
        out["fit"][key] = {"a_us": 1e6 * a, "b_ns": 1e9 * b,
                           "max_deviation_pct": 100 * float(deviation.max())}
    for n in copies:
        with_s, bare_s = best[n, True], best[n, False]
        out["rows"].append({
            "n": n, "steps_per_run": workloads[n, True].nroll * COPIES_WINDOW_STEPS,
            "with_us_per_step": 1e6 * with_s, "bare_us_per_step": 1e6 * bare_s,
            "with_ns_per_step_per_rig": 1e9 * with_s / n,
            "element_ns_per_step_per_element": 1e9 * (with_s - bare_s) / n,
            "element_ns_median_of_pairs": 1e9 * float(np.median(times[n, True]
                                                                - times[n, False])) / n})
    fit = out["fit"]
    out["element_ns"] = fit["with"]["b_ns"] - fit["bare"]["b_ns"]
    out["element_over_bare_rig_pct"] = 100 * out["element_ns"] / fit["bare"]["b_ns"]
    return out


# ---- Report --------------------------------------------------------------------------------------

def markdown(result: dict) -> str:
    lines = ["### A. The friction element's share of the step, plate-push robot scene",
             "",
             "One thread, CPU time. Share = 1 - baseline / as is: median (quartiles) over the "
             "interleaved rounds, each baseline run next to the scene as is; and from the best "
             "times.",
             "",
             "| scene | dt | steps a run | model | us/step (best) | element's share: median "
             "(quartiles) | from best times |",
             "|---|---:|---:|---|---:|---:|---:|"]
    for s in result["scenes"]:
        for variant, us in s["us_per_step"].items():
            cells = "- | - |"
            if variant in s["share_pct"]:
                low, high = s["share_quartiles_pct"][variant]
                cells = (f"{s['share_pct'][variant]:.1f} % ({low:.1f} to {high:.1f}) | "
                         f"{s['share_of_best_times_pct'][variant]:.1f} % |")
            lines.append(f"| {s['scene']} | {s['timestep_s'] * 1e3:g} ms | "
                         f"{s['steps_per_run']:,} | {variant} | {us:.2f} | {cells}")
    lines.append("")
    for s in result["scenes"]:
        share = s["share_pct"][DAMPED]
        verdict = "met" if share <= s["goal_pct"] else "missed"
        lines.append(f"- {s['scene']}: share {share:.1f} % against the damped part (same "
                     f"contacts, {s['rounds']} rounds), goal <= {s['goal_pct']:g} %: {verdict}")
    c = result["copies"]
    lines += ["",
              f"### B. Cost against the number of friction elements (N rigs in one model, "
              f"{c['law']}, v_a {c['va_m_per_s'] * 1e3:g} mm/s, dt {c['timestep_s'] * 1e6:.3f} us, "
              f"best of {c['rounds']} interleaved runs of >= {COPIES_MIN_RUN_S:g} s)",
              "",
              "| N | with elements (us/step) | bare (us/step) | with, per rig (ns/step) | "
              "(with - bare) / N, best times (ns/step) | same, median of the pairs |",
              "|---:|---:|---:|---:|---:|---:|"]
    for row in c["rows"]:
        lines.append(f"| {row['n']} | {row['with_us_per_step']:.2f} | "
                     f"{row['bare_us_per_step']:.2f} | {row['with_ns_per_step_per_rig']:.0f} | "
                     f"{row['element_ns_per_step_per_element']:.0f} | "
                     f"{row['element_ns_median_of_pairs']:.0f} |")
    lines.append("")
    for key, text in (("with", "with elements"), ("bare", "bare")):
        f = c["fit"][key]
        lines.append(f"- fit t(N) = a + b N, {text}: a = {f['a_us']:.2f} us, "
                     f"b = {f['b_ns']:.0f} ns per rig; largest deviation from the fit "
                     f"{f['max_deviation_pct']:.1f} % ("
                     + ("linear" if f["max_deviation_pct"] <= LINEAR_TOLERANCE_PCT
                        else "not linear") + f" at a {LINEAR_TOLERANCE_PCT:g} % tolerance)")
    lines.append(f"- one friction element (b with - b bare): {c['element_ns']:.0f} ns per step, "
                 f"{c['element_over_bare_rig_pct']:.0f} % of a bare rig's "
                 f"{c['fit']['bare']['b_ns']:.0f} ns")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"A: 5 rounds (else 21); B: N = {QUICK_COPIES}, best of 3 "
                             f"(else N = {COPIES}, best of 5)")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE",
                        help="also write the numbers as JSON")
    args = parser.parse_args(argv)
    vibrofriction.load()
    start = time.perf_counter()
    result: dict = {"machine": machine(), "quick": args.quick, "scenes": []}
    for name in SCENES:
        print(f"A: {name} ...", file=sys.stderr, flush=True)
        result["scenes"].append(scene_share(name, 5 if args.quick else 21))
    print("B: N rigs ...", file=sys.stderr, flush=True)
    result["copies"] = (copies_scaling(QUICK_COPIES, 3) if args.quick
                        else copies_scaling(COPIES, 5))
    m = result["machine"]
    print(f"machine: {m['cpu']}, Python {m['python']}, MuJoCo {m['mujoco']}, "
          f"vibrofriction {m['vibrofriction']}; {time.perf_counter() - start:.0f} s\n")
    print(markdown(result))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
