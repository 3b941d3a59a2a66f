"""``vibrofriction identify DATA [--validate DATA]... [--law LAW] [--out DIR]``.

Fits the friction law (the plugin's C++ code) to a measured record, traces the residual to the
effects of the vocabulary, selects those the data justify and writes report.json
(docs/interfaces.md), report.md, the final model's series of every record
(series_<dataset>.csv) and figures to DIR. Progress goes to stderr.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
from pathlib import Path

from .common import (UsageError, check_output_folder, check_replaceable_folder, check_writable,
                     parse_overrides, write_json)
from ..data.datasets import Dataset, all_or_nothing, read_dataset
from ..identify import MIN_IMPROVEMENT, identify
from ..identify.model import IDENTIFIABLE_LAWS, RIG_EFFECTS, inverse_effects
from ..identify.own_effects import load_effects_file, unregister
from ..identify.report import report_json, rig_replay, write_report

HELP = ("fit a friction law to a measured record (dataset format), trace the residual to "
        "missing effects (viscous, stribeck, asymmetry, position_ripple, "
        "normal_force_modulation (also at 2, 3, 4 f: normal_force_modulation_2f, ...), "
        "drive_damping, sensor_lag, force_offset, and the free-form "
        "position_map, velocity_map, time_map; by simulation also backlash; on the inverse "
        "path also contact_play; your own with --effects-from), select those the "
        "data justify, and write report.json, report.md, each record's measured, predicted "
        "and residual series and figures")

# Sidecar keys --set may supply or override (docs/dataset-format.md).
_METADATA_KEYS = ("mass_kg", "normal_force_N", "drive_stiffness_N_per_m",
                  "drive_velocity_m_per_s", "vibration_frequency_Hz")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the identify command's options to its argparse parser."""
    parser.add_argument("data", type=Path, metavar="DATA",
                        help="training record: NAME.csv or NAME.csv.gz with its NAME.json")
    parser.add_argument("--validate", type=Path, action="append", default=[], metavar="DATA",
                        help="held-out record (repeatable); errors reported, and an effect "
                             "must also lower the held-out error to be selected")
    parser.add_argument("--law", default="lugre", choices=IDENTIFIABLE_LAWS,
                        help="friction law (default lugre: the law with every effect of the "
                             "vocabulary, Stribeck included)")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="output folder (default: identify_<NAME> in the current folder); "
                             "an existing DIR must be empty or an earlier report (it holds "
                             "report.json) and is replaced as a whole: files in it that this "
                             "run does not write are deleted")
    parser.add_argument("--with", dest="declared", default="", metavar="EFFECT,...",
                        help="effects known in advance, fitted in the baseline (e.g. "
                             "viscous,force_offset for the EMPS benchmark's IDIM-LS model)")
    parser.add_argument("--lowpass", type=float, default=None, metavar="HZ",
                        help="inverse path: zero-phase 4th-order Butterworth at HZ on the "
                             "measured force and, in parallel, on the model's predicted force "
                             "(the fit and every error are of the filtered signals); a record "
                             "without velocity_m_per_s also has its position filtered before "
                             "it is differentiated (IDIM practice); a measured velocity or "
                             "acceleration is used unfiltered; off by default")
    parser.add_argument("--min-improvement", type=float, default=MIN_IMPROVEMENT,
                        metavar="FRACTION",
                        help=f"least relative drop of the training RMSE for an effect to be "
                             f"selected (default {MIN_IMPROVEMENT:g})")
    parser.add_argument("--substeps", type=int, default=None, metavar="N",
                        help="simulation path: MuJoCo steps per sample interval (a vibrating "
                             "sensor record: about N, as N + 0.382 per vibration period, so "
                             "that the step grid slides along the vibration; default: the "
                             "record's simulation_timestep_s, else halved until the "
                             "prediction converges); inverse path: law substeps per sample "
                             "interval (default 4; midpoint rule)")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="NAME=VALUE",
                        help="supply or override a sidecar value of DATA (and of every "
                             f"--validate record): {', '.join(_METADATA_KEYS)}")
    parser.add_argument("--model", default=None, metavar="MODEL",
                        help="the model the records are replayed in (overrides the sidecars' "
                             "'model'): a bundled machine (emps) or an MJCF scene whose "
                             "<custom> texts map the record onto it (see docs/identification.md, "
                             "'Your own scene'); 'rig' for the vibrating rig")
    parser.add_argument("--method", choices=("auto", "simulation", "inverse"), default="auto",
                        help="simulation: fit the MuJoCo rig scene with the plugin, driven by "
                             "the record's inputs, to every measured channel (output error; "
                             "needs a rig record: drive_stiffness_N_per_m and "
                             "drive_velocity_m_per_s in the sidecar; or a sidecar 'model', "
                             "e.g. emps: that machine in closed loop). inverse: the law driven "
                             "by the measured, differentiated motion (fast; for records with "
                             "no simulator model). auto (default): simulation where the "
                             "record is a rig record or names its model, else inverse; the "
                             "report says which ran and why")
    parser.add_argument("--timestep", type=float, default=1e-6, metavar="S",
                        help="inverse path: timestep of the MuJoCo rig replay of the final "
                             "model (records of a spring-driven rig only; default 1e-6); the "
                             "simulation path chooses its own (see --substeps)")
    parser.add_argument("--effects-from", dest="effects_from", type=Path, action="append",
                        default=[], metavar="FILE.py",
                        help="a Python file that registers effects of one's own "
                             "(vibrofriction.identify.own_effects.register_effect): they are "
                             "candidates and --with names like the vocabulary's "
                             "(docs/identification.md, examples/own_effect.py); repeatable")
    parser.add_argument("--no-figures", action="store_true",
                        help="skip the PNG figures (each record's series_<dataset>.csv is "
                             "still written)")
    parser.add_argument("--json", dest="json_path", type=Path, default=None, metavar="FILE",
                        help="also write report.json to FILE (outside DIR); DIR and FILE are "
                             "written together or, on any error, neither")


def run(args: argparse.Namespace) -> int:
    """Run the identify command on parsed arguments; return the exit status."""
    own: list[str] = []
    try:
        for path in args.effects_from:
            own += load_effects_file(path)
        return _run(args)
    finally:  # (registered for this run: an in-process caller's next run starts without them)
        for name in own:
            unregister(name)


def _run(args: argparse.Namespace) -> int:
    started = time.monotonic()
    declared = [e.strip() for e in args.declared.split(",") if e.strip()]
    # (each path then checks the effects it traces: the maps are the inverse path's, backlash
    # the simulation path's)
    known = inverse_effects() + RIG_EFFECTS  # (own effects: this run's and any registered)
    unknown = [e for e in declared if e not in known]
    if unknown:
        raise UsageError(f"--with: unknown effect(s) {', '.join(unknown)}; use: "
                         f"{', '.join(known)} (or register your own: --effects-from)")
    if not 0 <= args.min_improvement < 1:
        raise UsageError(f"--min-improvement {args.min_improvement} must lie in [0, 1)")
    if args.substeps is not None and not 1 <= args.substeps <= 64:
        raise UsageError(f"--substeps {args.substeps} must lie in 1..64")
    if not (math.isfinite(args.timestep) and args.timestep > 0):
        raise UsageError(f"--timestep {args.timestep} must be a positive number of seconds")
    overrides: dict = _metadata_overrides(args.overrides)
    if args.model is not None:
        # a file named on the command line is relative to the current folder
        overrides["model"] = str(Path(args.model).resolve()) if \
            args.model.endswith(".xml") else args.model
    train = _with_metadata(read_dataset(args.data), overrides)
    held = [_with_metadata(read_dataset(path), overrides) for path in args.validate]
    out = args.out or Path(f"identify_{train.name}")
    _check_out(out, args)

    def progress(message: str) -> None:
        print(f"[{time.monotonic() - started:6.1f} s] {message}", file=sys.stderr, flush=True)

    method, reason = _method(args.method, train, model_option=args.model is not None)
    if method == "simulation":
        return _run_simulation(args, train, held, out, declared, reason, progress)
    result = identify(train, held, law=args.law, declared=declared, substeps=args.substeps,
                      lowpass_Hz=args.lowpass, min_improvement=args.min_improvement,
                      progress=progress)
    result.settings.update(method="inverse", method_reason=reason)
    replay = None
    if train.metadata.drive_stiffness_N_per_m:
        progress("replaying baseline and final model in the MuJoCo rig")
        replay = rig_replay(result, train.metadata, timestep_s=args.timestep)
    if not args.no_figures:
        progress("writing report and figures")
    with all_or_nothing():  # DIR and --json FILE: both or neither
        write_report(result, out, figures=not args.no_figures, rig_replay_result=replay)
        if args.json_path is not None:
            write_json(args.json_path, report_json(result))
    b, f = result.baseline.train, result.final.train
    print(f"{train.name}: baseline relerr {b.relerr_pct:.3g} % -> final {f.relerr_pct:.3g} % "
          f"(selected: {', '.join(result.selected) or 'nothing'}); report in {out}")
    return 0


def _check_out(out: Path, args: argparse.Namespace) -> None:
    """DIR replaces what is there as a whole: refuse a folder that is not an earlier report, one
    that holds the current folder or an input record, and a --json FILE inside it."""
    check_output_folder(out, "--out")
    check_writable(out, "--out")
    folder = Path(os.path.abspath(out))
    check_replaceable_folder(out, "--out", "report.json")
    inside = [Path(os.path.abspath(p)) for p in (args.data, *args.validate)]
    for path, what in zip(inside, ["DATA", *["--validate DATA"] * len(args.validate)]):
        if path == folder or folder in path.parents:
            raise UsageError(f"--out {out} holds {what} ({path}) and would be replaced as a "
                             "whole; name another folder")


def _method(requested: str, train: Dataset, model_option: bool = False) -> tuple[str, str]:
    """Which identification path runs, and why (``model_option``: --model named the model)."""
    meta = train.metadata
    rig_record = bool(meta.drive_stiffness_N_per_m and meta.drive_velocity_m_per_s)
    if requested == "inverse":
        return "inverse", "asked for with --method inverse"
    if requested == "simulation":
        return "simulation", "asked for with --method simulation"
    if meta.model not in (None, "rig"):
        named = "--model names" if model_option else "the sidecar names"
        return "simulation", (f"{named} the model ({meta.model!r}): that MuJoCo scene, in "
                              "closed loop, is fitted to what the record measured")
    if rig_record:
        return "simulation", ("a rig record (drive spring and drive velocity in the sidecar): "
                              "the MuJoCo rig scene is fitted to what the record measured")
    return "inverse", ("no simulator model for this record (no drive_stiffness_N_per_m and "
                       "drive_velocity_m_per_s in the sidecar): the law is fitted along the "
                       "measured motion")


def _run_simulation(args, train, held, out, declared, reason, progress) -> int:
    from ..identify.simulation import identify_by_simulation
    from ..identify import simulation_report

    if args.lowpass is not None:
        raise UsageError("--lowpass applies to --method inverse only: the simulation path "
                         "weights each channel by its estimated noise instead")
    result = identify_by_simulation(train, held, law=args.law, declared=declared,
                                    substeps=args.substeps,
                                    min_improvement=args.min_improvement, progress=progress)
    result.settings["method_reason"] = reason
    if not args.no_figures:
        progress("writing report and figures")
    payload = simulation_report.report_json(result)
    with all_or_nothing():  # DIR and --json FILE: both or neither
        simulation_report.write_report(result, out, figures=not args.no_figures)
        if args.json_path is not None:
            write_json(args.json_path, payload)
    b, f = result.baseline.train, result.final.train
    print(f"{train.name}: identified by simulation ({reason}); {result.primary} relerr "
          f"baseline {b.relerr_pct:.3g} % -> final {f.relerr_pct:.3g} % (selected: "
          f"{', '.join(result.selected) or 'nothing'}); report in {out}")
    return 0


def _metadata_overrides(pairs) -> dict[str, float]:
    out = {}
    for name, raw in parse_overrides(pairs).items():
        if name not in _METADATA_KEYS:
            raise UsageError(f"--set {name}: identify accepts only the sidecar values "
                             f"{', '.join(_METADATA_KEYS)}")
        try:
            value = float(raw)
        except ValueError:
            raise UsageError(f"--set {name}={raw!r} is not a number") from None
        if not math.isfinite(value):
            raise UsageError(f"--set {name}={raw!r} must be finite")
        out[name] = value
    return out


def _with_metadata(dataset: Dataset, overrides: dict[str, float]) -> Dataset:
    if not overrides:
        return dataset
    metadata = dataclasses.replace(dataset.metadata, **overrides)
    return Dataset(name=dataset.name, columns=dataset.columns, metadata=metadata,
                   source_path=dataset.source_path)
