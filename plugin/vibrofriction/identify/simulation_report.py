"""report.json, report.md and a figure for an identification by simulation (the rig replay).

report.json has the keys of the inverse path's report (``law``, ``baseline``, ``candidates``,
``selected_effects``, ``final``, ``residual_peaks_Hz``) plus ``method``, ``channels`` (every
measured channel's error) and ``settings``; ``rmse_N``/``relerr_pct`` are of the measured force
(friction force when measured, else drive force).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..params import RigParameters
from ..provenance import json_text
from .identifiability import simulation_diagnostics
from . import residual_diagnostics
from .model import (MAP_EFFECTS, effect_fields, own_map_effects, own_parameter_names,
                    simulation_effects)
from .report import error_table_lines, write_folder
from .series import listing as series_listing, simulation_series, write_series
from .simulation import MIN_SLIPS, SimFit, SimIdentification

_UNITS = {"position_m": "m", "velocity_m_per_s": "m/s", "acceleration_m_per_s2": "m/s^2",
          "drive_force_N": "N", "friction_force_N": "N"}


def parameters(result: SimIdentification, fit: SimFit) -> dict[str, float | None]:
    """Every value of the fitted scene: friction attributes, the rig's values and a machine
    scene's fitted named values."""
    rig, friction = _case(result, fit)
    out: dict[str, Any] = friction.law_values()
    out.update({"mass_kg": rig.mass_kg, "drive_damping_N_s_per_m": rig.drive_damping_N_s_per_m,
                "normal_force_N": rig.normal_force_N})
    if rig.drive_backlash_m > 0:
        # the centre as simulate takes it: relative to the start (the replay's own coordinates
        # place the drive end where the record's samples put it)
        centre = result.train.backlash_centre_from_start_m(rig.drive_backlash_m)
        out.update({"drive_backlash_m": rig.drive_backlash_m,
                    "drive_backlash_centre_m": centre})
    out.update({n: fit.values[n] for n in fit.model.scene})
    if "gms_spread" in fit.values:  # the coordinate the elements' lists were fitted in
        out["gms_spread"] = fit.values["gms_spread"]
    out.update({n: fit.values[n] for n in own_parameter_names(fit.model.effects)})
    return {k: _finite(v) for k, v in out.items()}


def _case(result: SimIdentification, fit: SimFit) -> tuple[RigParameters, Any]:
    replay = result.train
    friction = fit.model.friction_parameters(fit.values,
                                             replay.rig.vibration_frequency_Hz or None)
    mass = fit.values.get("mass_kg", replay.rig.mass_kg)
    rig = replay.fitted_rig(fit.values, mass)
    return rig, friction


def report_json(result: SimIdentification) -> dict[str, Any]:
    """report.json of the simulation path (schema: docs/interfaces.md)."""
    def block(fit: SimFit) -> dict[str, Any]:
        return {"parameters": parameters(result, fit), "train": fit.train.as_dict(False),
                "validation": [m.as_dict(True) for m in fit.validation],
                "channels": {c: {"rmse": m.rmse_N, "relerr_pct": _finite(m.relerr_pct)}
                             for c, m in fit.channels.items()}}

    candidates = []
    for effect in simulation_effects():
        c = result.candidates.get(effect)
        if c is None:
            continue
        candidates.append({"effect": effect, "parameters": parameters(result, c.fit),
                           "train": c.fit.train.as_dict(False),
                           "validation": [m.as_dict(True) for m in c.fit.validation],
                           "criterion": _finite(c.delta_bic) if c.fitted else None,
                           "screen_criterion": _finite(c.screen_delta_bic),
                           "held_out_evidence": _finite(c.held_out_evidence),
                           "fitted": c.fitted, "justified": c.justified,
                           "reason": c.reason})
    return {
        "law": result.law,
        "method": "simulation",
        "measured_force": result.primary,
        "baseline": block(result.baseline),
        "candidates": candidates,
        "selected_effects": list(result.selected),
        "final": {**block(result.final),
                  "standard_errors": {k: _finite(v) if v is not None else None
                                      for k, v in result.standard_errors.items()},
                  # identifiability of each value, presliding, residual outliers
                  **simulation_diagnostics(result).as_json()},
        "residual_peaks_Hz": list(result.residual_peaks_Hz),
        "skipped": dict(result.skipped),
        # what the final residual follows and the verdict, per measured channel (the
        # measured force's at the top level; residual_diagnostics.py)
        "diagnostics": residual_diagnostics.simulation_json(
            residual_diagnostics.for_simulation(result)),
        "settings": {**result.settings, "simulations": result.simulations,
                     "seconds": round(result.seconds, 3),
                     # F_N was the record's normal_force_N column, step by step (the
                     # parameters' normal_force_N and the set line hold its median)
                     "normal_force_from_record": bool(getattr(
                         result.train, "normal_force_from_record", False))},
        "set": set_line(result),
        "initial_state": initial_state(result),
        **({"closed_loop": {"model": result.train.scene.name,
                            "first_sample": 50, **result.closed_loop}}
           if result.closed_loop is not None else {}),
        # the final model's measured, predicted and residual channels of every record
        "series": series_listing(result.train.name, [v.name for v in result.validation]),
    }


def initial_state(result: SimIdentification) -> dict[str, Any]:
    """The replayed body's velocity at the first sample: measured, estimated by smoothing, or
    fitted with the parameters (a nuisance of the training record, not part of the scene)."""
    replay = result.train
    if "initial_velocity_m_per_s" in result.final.values:
        error = result.standard_errors.get("initial_velocity_m_per_s")
        return {"velocity_m_per_s": _finite(result.final.values["initial_velocity_m_per_s"]),
                "velocity_from": "fitted",
                "velocity_standard_error": _finite(error) if error is not None else None}
    # (a machine replay starts from a smoothing estimate of its measured position)
    return {"velocity_m_per_s": _finite(replay.initial_velocity_m_per_s),
            "velocity_from": "smoothing estimate"}


def _initial_velocity_text(result: SimIdentification) -> str:
    state = initial_state(result)
    return f"{state['velocity_m_per_s']:.4g} m/s ({state['velocity_from']})"


# The benchmark's own closed-loop figures (EMPS description, section 3.5: IDIM-LS estimates
# simulated in its Simulink model), shown beside ours.
PUBLISHED_CLOSED_LOOP = {
    "emps": {"estimation run (DATA_EMPS)": {"force_relerr_pct": 5.848,
                                           "position_relerr_pct": 0.013752,
                                           "velocity_relerr_pct": 0.22911},
             "validation run (DATA_EMPS_PULSES)": {"force_relerr_pct": 8.9409,
                                                   "position_relerr_pct": 0.0080248,
                                                   "velocity_relerr_pct": 0.47888}},
}


def _is_machine(result: SimIdentification) -> bool:
    return hasattr(result.train, "scene")


def fitted_scene_xml(result: SimIdentification) -> str:
    """The machine scene with the final model's values, as MJCF."""
    rig, friction = _case(result, result.final)
    named = {n: result.final.values[n] for n in result.final.model.scene}
    return result.train.spec(rig, friction, probes=False, scene_values=named).to_xml()


def set_line(result: SimIdentification) -> str:
    """The ``--set`` options that run the final model in ``vibrofriction simulate`` (the rig;
    a machine's fitted model is its scene, ``fitted_model.xml``)."""
    if _is_machine(result):
        return ""
    p = parameters(result, result.final)
    names = ["friction_coefficient", "normal_force_N", "mass_kg"] + \
        [n for n in result.final.values if n in p and n not in ("friction_coefficient",
                                                                 "mass_kg")
         and n not in own_parameter_names(result.final.model.effects)]
    if "normal_force_modulation" in result.final.values:
        names.append("normal_force_modulation_frequency_Hz")
    if "drive_backlash_m" in result.final.values:
        names.append("drive_backlash_centre_m")
    if result.train.lagged_sensor == "dynamometer":
        # the lag is the rig dynamometer's (its sensor's time_constant), not the element's
        names = [n for n in names if n != "sensor_lag_s"]
    for effect in MAP_EFFECTS:  # a map: its knots and factors, as lists
        if effect in (*result.final.model.effects, *own_map_effects(result.final.model.effects)):
            names += [n for n in p if n.startswith(f"{effect}_")]
    parts = [f"--law {result.law}"]
    for n in dict.fromkeys(names):
        value = p.get(n)
        if isinstance(value, (list, tuple)):
            parts.append(f"--set {n}={','.join(f'{x:.9g}' for x in value)}")
        elif value is not None:
            parts.append(f"--set {n}={value:.9g}")
    return " ".join(parts)


def _baseline_start_line(result: SimIdentification) -> str:
    """Where the baseline fit started, and why a stick-slip record was also replayed as
    segments."""
    phases = result.settings.get("stick_phases", 0)
    line = f"- baseline: started from {result.settings.get('baseline_start')}"
    if phases >= MIN_SLIPS and "sensor_lag" not in result.declared:
        line += (f". The record shows {phases} stick phases after a slip, so it was also "
                 f"replayed as {phases + 1} segments started there (a whole-record fit of "
                 "stick-slip stays near its start): segmented fits, then multiple shooting "
                 "with the segments' start states fitted, gave the whole-record fit more "
                 "starts")
    return line + "."


def report_markdown(result: SimIdentification) -> str:
    """report.md of an identification by simulation: how the record was replayed, the error
    before and after, the selection, the final model, the residual's diagnostics and how to
    run what was fitted."""
    r = result
    diagnosis = residual_diagnostics.for_simulation(r)
    informed = simulation_diagnostics(r)
    lines = _method_lines(r, diagnosis) + _error_lines(r)
    lines += informed.outlier_lines(_UNITS)
    if r.closed_loop is not None:
        lines += _closed_loop_section(r)
    lines += _selection_lines(r)
    lines += _final_model_lines(r, informed)
    lines += _closing_lines(r, diagnosis)
    return "\n".join(lines)


def _method_lines(r: SimIdentification, diagnosis) -> list[str]:
    """The title, the method, the record and its settings, and the verdict on the model."""
    replay = r.train
    return [f"# Identification by simulation: {replay.name}", "",
            f"- law: **{r.law}**" + (f" + declared {', '.join(r.declared)}" if r.declared
                                     else ""),
            (f"- method: output error{', in closed loop' if replay.scene.controller else ''}. "
             f"The scene ({replay.scene.path.name}: {replay.scene.description}) runs in "
             "MuJoCo with the friction plugin" + (
                 " and the machine's own controller, driven by the record's reference"
                 if replay.scene.controller else ", driven by the record's inputs") +
             "; its sensors predict what the record measured." if _is_machine(r) else
             "- method: output error. The rig scene (mjcf_models/rig) runs in MuJoCo with the "
             "friction plugin, driven by the record's support motion and the drive end's "
             "motion; its sensors predict what the record measured.") +
            " Nothing measured is differentiated to form the prediction.",
            _baseline_start_line(r),
            f"- MuJoCo timestep {replay.timestep_s:.4g} s ({replay.steps_per_sample:.4g} "
            "step(s) a sample" +
            (", on a grid sliding along the vibration" if replay.sliding else "") +
            f"); {r.simulations} simulations in {r.seconds:.1f} s",
            f"- record: `{replay.name}`, {replay.n} samples; measured outputs: " +
            ", ".join(f"{c} (white-noise sd {replay.noise[c]:.3g}, sd in the fit "
                      f"{r.settings['noise_sd'][c]:.3g} {_UNITS[c]})"
                      for c in replay.channels),
            "- held-out records: " + (", ".join(f"`{v.name}`" for v in r.validation) or
                                      "none"),
            "- normal force: " + (
                f"the record's normal_force_N column, step by step (median "
                f"{replay.rig.normal_force_N:.6g} N, which the simulate line below holds "
                "constant)" if getattr(replay, "normal_force_from_record", False) else
                f"{replay.rig.normal_force_N:.6g} N" if replay.normal_force_known else
                                  "not given: F_N = 1 N, so friction_coefficient is the "
                                  "friction level in N"),
            "- mass: " + ("identified" if r.settings.get("fit_mass") else
                          f"{replay.rig.mass_kg:g} kg (sidecar)"),
            "- initial velocity: " + _initial_velocity_text(r),
            "", residual_diagnostics.verdict_sentence(diagnosis[r.primary])]


def _error_lines(r: SimIdentification) -> list[str]:
    """Each channel's error, and each held-out record's, before and after the selection."""
    replay = r.train
    lines = error_table_lines(
        [f"{c} relerr" for c in replay.channels] + [f"held-out `{v.name}`" for v in r.validation],
        {label: [f"{fit.channels[c].relerr_pct:.4g} %" for c in replay.channels] +
         [f"{m.relerr_pct:.4g} %" for m in fit.validation]
         for label, fit in (("baseline", r.baseline), ("final", r.final))})
    lines += ["", "relerr = 100 ||y - y_sim|| / ||y|| of each measured channel; held-out "
              f"columns are of {r.primary}.", ""]
    return lines


def _selection_lines(r: SimIdentification) -> list[str]:
    """The effects selected, and every candidate of every round with its verdict."""
    lines: list[str] = []
    lines += ["## Selected effects", ""]
    if not r.selected:
        lines.append("None: no candidate passed the criterion; the baseline is the final "
                     "model.")
    for effect in r.selected:
        c = r.candidates[effect]
        values = ", ".join(f"{n} = {c.fit.values[n]:.6g}" for n in effect_fields(effect)
                           if n in c.fit.values)
        lines.append(f"- **{effect}** (round {c.round}): {c.reason}. {values}.")
    lines += ["", "## Candidates", "",
              "dBIC = n_eff ln((RSS_E + F)/(RSS_M + F)) + (k_E - k_M) ln n_eff on the "
              "noise-weighted residual of all channels; F is the simulator's own error (the "
              "baseline at this timestep against half of it), so discretization error selects "
              "nothing. Justified when dBIC < "
              f"{r.settings['bic_threshold']:g}, the weighted RMSE falls by at least "
              f"{100 * r.settings['min_improvement']:g} %, held-out error falls, and a "
              "periodic effect beats an additive tone. Each round first screens every "
              "candidate linearized at the round's model (the residual projected on the "
              "model's and the effect's sensitivities); the best ones with a linearized dBIC "
              "below 0 are fitted in full.", "",
              "| round | effect | linearized dBIC | dBIC | weighted RMSE change | verdict |",
              "|---|---|---|---|---|---|"]
    for round_ in r.rounds:
        for c in round_:
            fitted = f"{c.delta_bic:.1f} | {-100 * c.train_drop:+.2f} %" if c.fitted else \
                "– | –"
            lines.append(f"| {c.round} | {c.effect} | {c.screen_delta_bic:.1f} | {fitted} | "
                         f"{'justified' if c.justified else 'no: ' + c.reason} |")
    for effect, why in r.dropped.items():
        lines.append(f"| – | {effect} | – | – | – | {why} |")
    for effect, why in r.skipped.items():
        lines.append(f"| – | {effect} | – | – | – | not a candidate: {why} |")
    return lines


def _final_model_lines(r: SimIdentification, informed) -> list[str]:
    """The final model's parameters, their standard errors and whether the record informs
    them."""
    lines: list[str] = []
    lines += ["", "## Final model", "",
              "| parameter | value | standard error (fitted values) | informed |",
              "|---|---|---|---|"]
    for name, value in parameters(r, r.final).items():
        if value is not None:
            error = r.standard_errors.get(name)
            if error is None:
                cell = "not identifiable here" if name in r.standard_errors else ""
            else:
                cell = f"{error:.2g}" + (f" ({100 * error / abs(value):.2g} %)" if value
                                         else "")
                if name in r.final.at_bound:
                    cell += "; at its bound"
            shown = " ".join(f"{x:.6g}" for x in value) if isinstance(value, (list, tuple)) else \
                f"{value:.9g}"  # (a list: the gms elements', a map's)
            lines.append(f"| `{name}`{informed.unit_note(name)} | {shown} | {cell} | "
                         f"{informed.flag(name)} |")
    lines += ["", "Standard errors: Gauss-Newton, s^2 (J^T J)^-1 at the optimum with the "
              "residual variance scaled by the sample count over the effective one; they "
              "describe the record's noise, not a model that is wrong.",
              *informed.parameter_notes()]
    return lines


def _closing_lines(r: SimIdentification, diagnosis) -> list[str]:
    """The residual's diagnostics, its peaks, where the series are, and how to run the
    fitted model."""
    replay = r.train
    lines: list[str] = []
    lines += [""] + residual_diagnostics.markdown_lines(list(diagnosis.values()))
    lines += ["", "Residual peaks (Hz, " + r.primary + "): " +
              (", ".join(f"{f:.6g}" for f in r.residual_peaks_Hz) or "none"), "",
              "The final model's series, the training record's and each held-out record's: "
              "`series_<dataset>.csv` (report.json `series`; time_s and each fitted channel "
              "measured, predicted and residual = measured - predicted) and, with figures, "
              "`series_<dataset>.png` (the whole record and a window of a few vibration "
              "periods, or 5 % of the record, where the residual is largest).", "",
              *(["The fitted scene is `fitted_model.xml` (load it with "
                 "`mujoco.MjModel.from_xml_path` after `vibrofriction.load()`).", ""]
                if _is_machine(r) else
                ["Run the fitted rig:", "", f"    vibrofriction simulate {set_line(r)}", ""])]
    if replay.lagged_sensor == "dynamometer" and "sensor_lag_s" in r.final.values:
        lines += [f"The fitted sensor lag ({r.final.values['sensor_lag_s']:.6g} s) is the "
                  "dynamometer's: the `time_constant` of the rig's `dynamometer` "
                  "(`vibrofriction.lagged_tendon`) sensor, not a friction attribute.", ""]
    return lines


def _closed_loop_section(r: SimIdentification) -> list[str]:
    """The closed-loop errors as the machine's benchmark defines them, beside its own."""
    name = r.train.scene.name
    keys = ("force_relerr_pct", "position_relerr_pct", "velocity_relerr_pct")
    lines = ["## Closed-loop simulation errors (the benchmark's definition)", "",
             "relerr = 100 ||y - y_sim|| / ||y|| from the 50th sample, of the total drive "
             "force, the position and the velocity (the measured velocity a central "
             "difference of the position, for this table only).", "",
             "| model | record | force | position | velocity |", "|---|---|---|---|---|"]
    for label in ("baseline", "final"):
        for record, errors in r.closed_loop[label].items():
            cells = [f"{errors[k]:.4g} %" if k in errors else "–" for k in keys]
            lines.append(f"| {label} ({r.law}) | {record} | " + " | ".join(cells) + " |")
    published = PUBLISHED_CLOSED_LOOP.get(name, {}) if r.train.scene.bundled else {}
    for record, errors in published.items():
        lines.append(f"| published IDIM-LS, its own simulation | {record} | " +
                     " | ".join(f"{errors[k]:.4g} %" for k in keys) + " |")
    return lines + [""]


def write_report(result: SimIdentification, out_dir, *, figures: bool = True) -> Path:
    """Write report.json, report.md, the series (and figures; a machine's fitted scene) to
    ``out_dir``, all or nothing; returns the folder."""
    def write(tmp: Path) -> None:
        (tmp / "report.json").write_text(json_text(report_json(result)))
        (tmp / "report.md").write_text(report_markdown(result))
        if _is_machine(result):
            (tmp / "fitted_model.xml").write_text(fitted_scene_xml(result))
        write_series(simulation_series(result), tmp, figures=figures,
                     title=f"{result.law} + " + (", ".join(result.selected) or "nothing"))
        if figures:
            _figure(result, tmp / "fit.png")
            residual_diagnostics.write_figure(
                list(residual_diagnostics.for_simulation(result).values()),
                tmp / "diagnostics.png")

    return write_folder(out_dir, write)


def _figure(result: SimIdentification, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    replay = result.train
    channel = result.primary
    t = replay.time_s
    measured = replay.measured[channel]
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    axes[0].plot(t, measured, lw=0.6, color="0.4", label="measured")
    axes[0].plot(t, result.baseline.predicted[channel], lw=0.8, label="baseline (simulated)")
    axes[0].plot(t, result.final.predicted[channel], lw=0.8, ls="--",
                 label="final (simulated)")
    axes[0].set_ylabel(f"{channel}")
    axes[0].legend(loc="best", fontsize=8)
    axes[1].plot(t, result.baseline.predicted[channel] - measured, lw=0.5, label="baseline")
    axes[1].plot(t, result.final.predicted[channel] - measured, lw=0.5, label="final")
    axes[1].set_ylabel("simulated - measured")
    axes[1].set_xlabel("time_s")
    axes[1].legend(loc="best", fontsize=8)
    fig.suptitle(f"{replay.name}: {result.law}, selected: "
                 f"{', '.join(result.selected) or 'nothing'}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return float(value) if isinstance(value, (int, float, np.floating)) and \
        not isinstance(value, bool) else value


__all__ = ["PUBLISHED_CLOSED_LOOP", "fitted_scene_xml", "report_json", "report_markdown", "write_report", "parameters", "set_line"]
