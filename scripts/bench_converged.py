#!/usr/bin/env python3
"""What users pay for a converged master curve (issue 11). Not a test: it prints, measured side
by side in one run on this machine:

1. **A converged four-law master curve** (30 values of kappa_v, log-spaced): the CPU time of the
   plugin's runs to steady state (``vibrofriction.rigs.steady``, single thread, each law's static
   run included; building each case's model from its MJCF is part of it, and its share is
   printed) at the coarsest timestep -- the rule's (``rig.recommended_timestep``), halved as
   often as needed -- at which every point is within 1 % of the converged curve (the plugin at
   a quarter of the rule's timestep).
2. **MuJoCo's best built-in configuration reaching the same accuracy**, for the laws it has:
   joint ``frictionloss`` with solreffriction 2e-6 (Coulomb) and the ``dcmotor`` LuGre element.
   Each point runs as long as the plugin's run of that point did and is averaged over the same
   window; the timestep is refined (the rule's, halved up to 4 times) until every point is
   within 1 % of the plugin law's converged curve; the cost is that curve's CPU time.
3. **The scipy reference** (``vibrofriction.oracle.reference``, LSODA) on a subset of the points,
   over the same windows: CPU time per point against the plugin's on the same points.
4. **Sweep throughput**: ``sweep.sweep`` (Dahl) with 1 and 2 rollout threads and on a local Dask
   cluster of two single-thread workers, against the number of points.

CPU time is the process's (``time.process_time``): every run here steps in the calling thread.

    .venv/bin/python scripts/bench_converged.py [--quick] [--json FILE]
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
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from vibrofriction.oracle import reference
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import LAWS, RigParameters
from vibrofriction.rigs.steady import SteadyRun, hann_mean, run_until_steady
from vibrofriction.study.builtin import VARIANTS, build_variant_spec, variant_friction
from vibrofriction.study.config import StudyConfig
from vibrofriction.rigs.sweep import sweep

ACCURACY = 0.01
BUILTIN = {"coulomb": "frictionloss-tight", "lugre": "dcmotor-lugre"}
MAX_REFINEMENTS = 4  # the built-in's timestep: the rule's / 2^j, j <= 4
TRUTH_REFINEMENT = 2  # the converged values: the plugin at a quarter of its timestep


def kappa_grid(quick: bool) -> np.ndarray:
    return np.geomspace(0.5, 50.0, 8 if quick else 30)


def curve_cases(law: str, kappas: np.ndarray, config: StudyConfig) -> list[tuple]:
    base = config.rig
    cases = []
    for kappa in [0.0, *kappas]:  # the static run first
        rig = replace(base, vibration_velocity_amplitude_m_per_s=kappa
                      * base.drive_velocity_m_per_s)
        cases.append((rig, variant_friction(VARIANTS[f"plugin-{_plugin_name(law)}"], rig,
                                            config)))
    return cases


def _plugin_name(law: str) -> str:
    return "dupont-jenkins" if law == "dupont" else law


def plugin_curve(law: str, kappas: np.ndarray, config: StudyConfig, *, refine: int = 0
                 ) -> tuple[list[SteadyRun], float]:
    """The curve's runs to steady state on one thread, and their CPU time."""
    cases = curve_cases(law, kappas, config)
    dts = [rig_module.recommended_timestep(r) / 2 ** refine for r, _ in cases]
    start = time.process_time()
    runs = run_until_steady(cases, timesteps=dts, nthread=1)
    return runs, time.process_time() - start


def builtin_point(variant: str, run: SteadyRun, config: StudyConfig, timestep_s: float
                  ) -> tuple[float, float]:
    """(mean drive force over the plugin run's window, CPU seconds) of a built-in variant."""
    model = build_variant_spec(variant, run.rig, config, timestep_s).compile()
    data = mujoco.MjData(model)
    state = rig_module.initial_state(model, data)
    nstep = int(math.ceil(run.summary.window_end_s / timestep_s)) + 2
    start = time.process_time()
    _, sensordata = mj_rollout.rollout(model, data, state[None], nstep=nstep)
    cpu = time.process_time() - start
    if any(w.number for w in data.warning):
        raise RuntimeError(f"MuJoCo warnings in {variant}")
    drive = rig_module.sensor_columns(model, sensordata[0], "drive_force")
    t = np.arange(nstep) * timestep_s
    return hann_mean(t, drive, run.summary.window_start_s, run.summary.window_end_s), cpu


def builtin_curve(law: str, runs: list[SteadyRun], truth: list[float], config: StudyConfig
                  ) -> dict:
    """The coarsest uniform refinement of the plugin's timesteps at which the built-in curve
    is within ACCURACY of ``truth`` at every point, and its CPU time."""
    variant = BUILTIN[law]
    for j in range(MAX_REFINEMENTS + 1):
        cpu, worst = 0.0, 0.0
        for run, target in zip(runs, truth):
            dt = rig_module.recommended_timestep(run.rig) / 2 ** j
            mean, seconds = builtin_point(variant, run, config, dt)
            cpu += seconds
            worst = max(worst, abs(mean / target - 1))
        if worst <= ACCURACY:
            return {"variant": variant, "refinement": j, "cpu_s": cpu, "worst_error": worst,
                    "reached": True}
    return {"variant": variant, "refinement": MAX_REFINEMENTS, "cpu_s": cpu,
            "worst_error": worst, "reached": False}


def reference_points(law: str, runs: list[SteadyRun], every: int) -> dict:
    """CPU time of the scipy reference over the windows of every ``every``-th vibrating point,
    and the plugin's for the same points (its runs' share, from a single-point rerun)."""
    chosen = runs[1::every]
    ref_cpu = plugin_cpu = 0.0
    worst = 0.0
    for run in chosen:
        start = time.process_time()
        ref = reference.simulate_reference(run.rig, run.friction, run.summary.window_end_s
                                           + 1e-4, sample_dt_s=2e-6)
        ref_cpu += time.process_time() - start
        ref_mean = hann_mean(ref.time_s, ref.drive_force_N, run.summary.window_start_s,
                             run.summary.window_end_s)
        worst = max(worst, abs(run.mean_drive_force_N / ref_mean - 1))
        start = time.process_time()
        run_until_steady([(run.rig, run.friction)], timesteps=[run.timestep_s], nthread=1)
        plugin_cpu += time.process_time() - start
    return {"points": len(chosen), "reference_cpu_s": ref_cpu, "plugin_cpu_s": plugin_cpu,
            "ratio": ref_cpu / plugin_cpu, "worst_plugin_vs_reference": worst}


def master_curves(quick: bool, log) -> dict:
    config = StudyConfig()
    kappas = kappa_grid(quick)
    out: dict = {"kappas": kappas.tolist(), "laws": {}}
    for law in LAWS:
        # The truth: the plugin at a quarter of its rule's timestep. The plugin's curve is
        # the coarsest refinement within ACCURACY of it (the rule itself for most laws).
        truth_runs, _ = plugin_curve(law, kappas, config, refine=TRUTH_REFINEMENT)
        truth = [r.mean_drive_force_N for r in truth_runs]
        for refine in range(TRUTH_REFINEMENT + 1):
            runs, cpu = plugin_curve(law, kappas, config, refine=refine)
            changes = [abs(a.mean_drive_force_N / b - 1) for a, b in zip(runs, truth)]
            if max(changes) <= ACCURACY:
                break
        change = max(changes)
        worst_kappa = runs[int(np.argmax(changes))].rig.kappa
        start = time.process_time()
        for r, f in curve_cases(law, kappas, config):
            rig_module.build_model(r, f, rig_module.recommended_timestep(r))
        build = time.process_time() - start
        entry = {"plugin_cpu_s": cpu, "model_build_cpu_s": build, "refinement": refine,
                 "error_vs_truth": change, "worst_kappa": worst_kappa,
                 "converged": sum(r.convergence.converged for r in runs), "runs": len(runs),
                 "simulated_s": sum(r.convergence.simulated_s for r in runs)}
        log(f"{law}: plugin {cpu:.2f} s CPU for {len(runs)} runs at dt/{2 ** refine} "
            f"({build:.2f} s building models), at most {change:.2%} from the truth "
            f"(kappa {worst_kappa:.3g})")
        if law in BUILTIN:
            entry["builtin"] = builtin_curve(law, runs, truth, config)
            entry["builtin"]["ratio"] = entry["builtin"]["cpu_s"] / cpu
            log(f"{law}: built-in {entry['builtin']}")
        entry["reference"] = reference_points(law, runs, 8 if quick else 6)
        log(f"{law}: reference {entry['reference']}")
        out["laws"][law] = entry
    return out


def throughput(quick: bool, log) -> dict:
    rig = RigParameters()
    from vibrofriction.params import default_friction
    friction = default_friction("dahl", rig)
    sizes = (2, 4) if quick else (4, 8, 16)
    rows = []
    cluster = client = None
    try:
        from dask.distributed import Client, LocalCluster
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    except ImportError:
        log("dask.distributed is not installed: no Dask column (pip install '.[dask]')")
    try:
        for n in sizes:
            amplitudes = list(np.geomspace(0.75e-3, 10e-3, n))
            row = {"points": n}
            for label, kwargs in (("threads_1", {"nthread": 1}), ("threads_2", {"nthread": 2}),
                                  ("dask_2_workers", {"scheduler": client})):
                if label.startswith("dask") and client is None:
                    continue
                start = time.perf_counter()
                sweep(rig, friction, amplitudes, progress=False, **kwargs)
                row[label] = time.perf_counter() - start
            rows.append(row)
            log(f"sweep {row}")
    finally:
        if client is not None:
            client.close()
            cluster.close()
    return {"rows": rows}


def markdown(result: dict) -> str:
    m = result["master"]
    lines = [f"Master curve: {len(m['kappas'])} values of kappa_v from {m['kappas'][0]:g} to "
             f"{m['kappas'][-1]:g} plus the static run, single thread, CPU seconds.", "",
             "| law | plugin (of it building models) | its largest error (at kappa_v) | "
             f"built-in reaching {ACCURACY:.0%} | built-in / plugin | scipy / plugin per point "
             "(points) |",
             "|---|---|---|---|---|---|"]
    for law, e in m["laws"].items():
        b = e.get("builtin")
        built = "-" if b is None else (
            f"{b['variant']}: {b['cpu_s']:.2f} s at dt/{2 ** b['refinement']}"
            + ("" if b["reached"] else f" (not reached: {b['worst_error']:.1%})"))
        ratio = "-" if b is None else f"{b['ratio']:.2g}"
        r = e["reference"]
        lines.append(f"| {law} | {e['plugin_cpu_s']:.2f} s ({e['model_build_cpu_s']:.2f} s) at "
                     f"dt/{2 ** e['refinement']} | "
                     f"{e['error_vs_truth']:.2%} ({e['worst_kappa']:.3g}) | "
                     f"{built} | {ratio} | {r['ratio']:.0f} ({r['points']}) |")
    t = result["throughput"]["rows"]
    lines += ["", "Sweep throughput (Dahl, wall seconds, each point run to steady state):", "",
              "| points | 1 thread | 2 threads | Dask, 2 workers |", "|---|---|---|---|"]
    for row in t:
        dask = f"{row['dask_2_workers']:.2f}" if "dask_2_workers" in row else "-"
        lines.append(f"| {row['points']} | {row['threads_1']:.2f} | {row['threads_2']:.2f} | "
                     f"{dask} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="8 points, smaller sweeps")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE")
    args = parser.parse_args(argv)

    def log(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    start = time.perf_counter()
    result = {"master": master_curves(args.quick, log), "throughput": throughput(args.quick, log),
              "cpu_count": rig_module._cpu_count(), "mujoco": mujoco.__version__}
    result["wall_s"] = time.perf_counter() - start
    print(markdown(result))
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
