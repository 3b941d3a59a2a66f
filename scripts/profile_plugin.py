#!/usr/bin/env python3
"""Instructions per step of the rig with each friction law, split by library (valgrind callgrind).

Timings on a shared machine move by a per cent from run to run; instruction counts do not. This
script counts, for the bare rig (friction element removed) and for the rig with each law, the
instructions one ``mj_step`` executes, and splits the extra over the bare rig into what runs in
MuJoCo (libmujoco: its per-instance plugin dispatch, the extra actuator and activation), in the
vibrofriction library (the law) and in the math library (exp, sin). Each count is the
difference of two runs (5000 and 1000 steps), so start-up work cancels. Not a test; needs
valgrind on PATH. About half a minute per model.

    .venv/bin/python scripts/profile_plugin.py [--laws dahl,lugre] [--json FILE]
"""
from __future__ import annotations

import argparse
import collections
import json
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


def _child(model: str, nstep: int) -> None:
    """Steps the model nstep times in one rollout call (runs under valgrind)."""
    import mujoco
    from mujoco import rollout

    from vibrofriction import rig as rig_module
    from vibrofriction.params import RigParameters, default_friction
    from vibrofriction.python_law import bare_rig_spec

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
    rollout.rollout(compiled, data, rig_module.initial_state(compiled, data)[None], nstep=nstep)


def _instructions_by_library(model: str, nstep: int, workdir: Path) -> collections.Counter:
    out = workdir / f"callgrind.{model}.{nstep}"
    env = dict(os.environ, PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1")
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                    sys.executable, __file__, "--child", model, str(nstep)],
                   check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    report = subprocess.run(["callgrind_annotate", "--threshold=100", str(out)], check=True,
                            capture_output=True, text=True).stdout
    counts: collections.Counter = collections.Counter()
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", default=",".join(LAWS),
                        help="comma-separated laws (default: all four)")
    parser.add_argument("--json", type=Path, help="also write the counts as JSON")
    parser.add_argument("--child", nargs=2, metavar=("MODEL", "NSTEP"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        _child(args.child[0], int(args.child[1]))
        return 0
    laws = [law.strip() for law in args.laws.split(",") if law.strip()]
    unknown = sorted(set(laws) - set(LAWS))
    if unknown:
        parser.error(f"unknown law(s) {', '.join(unknown)}; use some of {', '.join(LAWS)}")
    missing = [tool for tool in ("valgrind", "callgrind_annotate") if shutil.which(tool) is None]
    if missing:
        print(f"profile_plugin.py needs {' and '.join(missing)} on PATH (e.g. apt install "
              "valgrind); bench_plugin.py measures time without it", file=sys.stderr)
        return 2
    rows: dict[str, dict[str, float]] = {}
    models = [BARE, INTEGRATOR, *laws, DAHL_WITH_SENSOR]
    with tempfile.TemporaryDirectory(prefix="vibrofriction-callgrind-") as tmp:
        for index, model in enumerate(models, start=1):
            print(f"[{index}/{len(models)}] callgrind: {model}", file=sys.stderr, flush=True)
            rows[model] = _per_step(model, Path(tmp))
    bare = rows[BARE]
    columns = ("MuJoCo", "vibrofriction", "math library")
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
