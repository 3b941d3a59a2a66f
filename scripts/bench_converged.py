#!/usr/bin/env python3
"""What users pay for a converged master curve (issues 11, 36). Not a test: it prints, measured
side by side in one run on this machine:

1. **A converged four-law master curve** (30 values of kappa_v, log-spaced, and the static run)
   at 1 %, per law family, by three routes (``study.builtin.converged_curve_costs``; CPU time,
   single thread, building each case's model included): the product's fastest route
   (``--method auto``: each point's periodic orbit, ``vibrofriction.rigs.periodic``, the
   transient where none is found), the plugin's transient runs to steady state
   (``rigs.steady``), and MuJoCo's best built-in element for the law (frictionloss or contact
   with a 2e-6 s time constant for Coulomb, the dcmotor LuGre, joint springyield for the
   Jenkins element), each point run from rest as long as the plugin's transient of that point
   and averaged over the same window. Each route runs at the coarsest refinement of the rule's
   timestep (``rig.recommended_timestep`` / 2^j) at which every point is within 1 % of the
   converged curve: the plugin at a quarter of the rule's timestep, run to steady state by the
   transient (independent of the periodic solver).
3. **The scipy reference** (``--scipy``) (``vibrofriction.oracle.reference``, LSODA) on a subset of the points,
   over the same windows: CPU time per point against the plugin's on the same points.
4. **Sweep throughput**: ``sweep.sweep`` (Dahl, the default method) with 1 and 2 rollout
   threads and on a local Dask cluster of two single-thread workers, against the number of
   points.

CPU time is the process's (``time.process_time``): every run here steps in the calling thread.

    .venv/bin/python scripts/bench_converged.py [--quick] [--scipy] [--json FILE]
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

from vibrofriction import sim
from vibrofriction.oracle import reference
from vibrofriction.rigs import rig as rig_module
from vibrofriction.params import LAWS, RigParameters
from vibrofriction.rigs.steady import SteadyRun, hann_mean, run_until_steady
from vibrofriction.study.builtin import (VARIANTS, build_variant_spec, converged_costs_table,
                                         converged_curve_costs, variant_friction)
from vibrofriction.study.config import StudyConfig
from vibrofriction.rigs.sweep import sweep

ACCURACY = 0.01


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


def master_curves(quick: bool, log, scipy: bool = False) -> dict:
    config = StudyConfig()
    kappas = kappa_grid(quick)
    out = converged_curve_costs(config, kappas, log=log)
    if scipy:
        for law in LAWS:
            runs, _ = plugin_curve(law, kappas, config)
            out["laws"][law]["reference"] = reference_points(law, runs, 8 if quick else 6)
            log(f"{law}: reference {out['laws'][law]['reference']}")
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
             f"{m['kappas'][-1]:g} plus the static run, single thread, CPU seconds to every "
             f"point within {ACCURACY:.0%} of the converged curve.", "",
             converged_costs_table(m)]
    refs = {law: e["reference"] for law, e in m["laws"].items() if "reference" in e}
    if refs:
        lines += ["", "| law | scipy / plugin transient per point (points) |", "|---|---|"]
        lines += [f"| {law} | {r['ratio']:.0f} ({r['points']}) |" for law, r in refs.items()]
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
    parser.add_argument("--scipy", action="store_true",
                        help="also time the scipy reference on a subset of the points")
    parser.add_argument("--no-throughput", dest="throughput", action="store_false",
                        help="skip the sweep throughput")
    parser.add_argument("--json", type=Path, default=None, metavar="FILE")
    args = parser.parse_args(argv)

    def log(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    start = time.perf_counter()
    result = {"master": master_curves(args.quick, log, args.scipy),
              "throughput": throughput(args.quick, log) if args.throughput else {"rows": []},
              "cpu_count": sim.cpu_count(), "mujoco": mujoco.__version__}
    result["wall_s"] = time.perf_counter() - start
    print(markdown(result))
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
