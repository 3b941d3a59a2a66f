"""report.json (docs/interfaces.md, exactly), report.md and the figures, written atomically."""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..data.datasets import stage_folder
from ..params import RigParameters
from ..provenance import json_text
from .identifiability import inverse_diagnostics
from . import residual_diagnostics
from .fit import FitResult
from .model import (MAP_EFFECTS, effect_fields, inverse_effects, own_map_effects,
                    own_parameter_names)
from .selection import Identification
from .series import inverse_series, listing as series_listing, write_series

REPORT_FILES = ("report.json", "report.md", "fit.png", "residual_vs_regressor.png",
                "spectrum.png", "diagnostics.png")


# ------------------------------------------------------------------------------------ json

def parameters(result: Identification, fit: FitResult) -> dict[str, float]:
    """Every parameter of the fitted model in the vocabulary (FrictionParameters fields, and
    the rig's mass_kg, drive_damping_N_s_per_m and the normal_force_N used)."""
    record = result.train
    friction = fit.model.friction_parameters(fit.values, record.vibration_frequency_Hz)
    out = friction.law_values()
    mass = fit.values.get("mass_kg", record.mass_kg)
    if mass is not None:
        out["mass_kg"] = float(mass)
    out["drive_damping_N_s_per_m"] = float(fit.values.get("drive_damping_N_s_per_m", 0.0))
    out["normal_force_N"] = float(np.median(record.normal_force_N))
    if "gms_spread" in fit.values:  # the coordinate the elements' lists were fitted in
        out["gms_spread"] = float(fit.values["gms_spread"])
    out.update({n: fit.values[n] for n in own_parameter_names(fit.model.effects)})
    return {k: _finite(v) for k, v in out.items()}


def report_json(result: Identification) -> dict[str, Any]:
    """report.json of the inverse path (schema: docs/interfaces.md)."""
    def block(fit: FitResult) -> dict[str, Any]:
        return {"parameters": parameters(result, fit), "train": fit.train.as_dict(False),
                "validation": [m.as_dict(True) for m in fit.validation]}

    candidates = []
    for effect in inverse_effects():
        c = result.candidates.get(effect)
        if c is None:
            continue
        candidates.append({"effect": effect, "parameters": parameters(result, c.fit),
                           "train": c.fit.train.as_dict(False),
                           "validation": [m.as_dict(True) for m in c.fit.validation],
                           "criterion": _finite(c.delta_bic),
                           "held_out_evidence": _finite(c.held_out_evidence)})
    return {
        "law": result.law,
        "method": result.settings.get("method", "inverse"),
        "method_reason": result.settings.get("method_reason"),
        "baseline": block(result.baseline),
        "candidates": candidates,
        "selected_effects": list(result.selected),
        # (+ identifiability of each value, presliding, residual outliers: identifiability.py)
        "final": {**block(result.final), **inverse_diagnostics(result).as_json()},
        "residual_peaks_Hz": [round(f, 6) for f in result.final_analysis.spectrum.peaks_Hz]
        if result.final_analysis.spectrum else [],
        # a damped oscillation after the reversals that the final model leaves (null: none)
        "ringing_after_reversals": result.final_analysis.ringing.as_dict()
        if result.final_analysis.ringing else None,
        # what the final residual follows, and the verdict against its noise floor
        # (residual_diagnostics.py)
        "diagnostics": residual_diagnostics.for_identification(result).as_dict(),
        # the final model's measured, predicted and residual force of every record (series.py)
        "series": series_listing(result.train.name, [v.name for v in result.validation]),
    }


def _finite(value: float | tuple[float, ...]) -> float | list | None:
    if isinstance(value, (tuple, list)):  # a map's knots or factors
        return [_finite(x) for x in value]
    value = float(value)
    return value if math.isfinite(value) else None


# -------------------------------------------------------------------------------- markdown

def report_markdown(result: Identification, rig_replay: dict | None = None) -> str:
    """The report.md of an identification: one section writer after another."""
    lines: list[str] = []
    lines += _header_lines(result)
    diagnosis = residual_diagnostics.for_identification(result)
    lines += ["", residual_diagnostics.verdict_sentence(diagnosis)]
    informed = inverse_diagnostics(result)  # (each record's prediction: computed once)
    lines += _error_lines(result, informed)
    lines += _selected_lines(result)
    lines += _rounds_lines(result)
    lines += _parameter_lines(result, informed)
    lines += _residual_lines(result)
    lines += residual_diagnostics.markdown_lines([diagnosis])
    lines += _mujoco_lines(result, rig_replay)
    lines += _closing_lines()
    return "\n".join(lines)


def _header_lines(r: Identification) -> list[str]:
    """The record, the law and what was measured."""
    record = r.train
    lines = [f"# Identification: {record.name}", ""]
    lines += [
        f"- law: **{r.law}**; baseline = law" +
        (f" + declared {', '.join(r.declared)}" if r.declared else ""),
        f"- training record: `{record.name}`, {record.n} samples over "
        f"{record.time_s[-1] - record.time_s[0]:.4g} s; measured: {record.target} force"
        + ("; mass identified" if r.settings.get("fit_mass") else
           (f"; mass {record.mass_kg:g} kg (sidecar)" if record.mass_kg else "")),
        "- held-out records: " + (", ".join(f"`{v.name}`" for v in r.validation) or "none"),
        "- normal force: " + (f"{np.median(record.normal_force_N):.6g} N" if
                              record.normal_force_known else
                              "not given: F_N = 1 N, so friction_coefficient is the friction "
                              "level in N"),
        "- support: " + (f"vibrating at {record.vibration_frequency_Hz:g} Hz (measured support "
                         "velocity drives the law)" if record.vibrating else "fixed"),
    ]
    if r.settings.get("lowpass_Hz"):
        lines.append(f"- parallel zero-phase low-pass at {r.settings['lowpass_Hz']:g} Hz on the "
                     "measured force and on the model output (a position without a measured "
                     "velocity is filtered before it is differentiated; a measured velocity or "
                     "acceleration is used unfiltered); errors are of the filtered signals")
    return lines


def error_table_lines(columns: list[str], rows: dict[str, list[str]]) -> list[str]:
    """The report's "Error before and after" section heading and table (both paths): a row a
    model (baseline, final), a column a measured channel or held-out record."""
    lines = ["", "## Error before and after", "",
             "| model | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
    lines += [f"| {label} | " + " | ".join(cells) + " |" for label, cells in rows.items()]
    return lines


def _error_lines(r: Identification, informed) -> list[str]:
    """The error table, baseline and final, training and held out."""
    record = r.train
    lines: list[str] = []
    lines += error_table_lines(
        ["training"] + [f"held-out `{v.name}`" for v in r.validation],
        {label: [_metric_cell(fit.train)] + [_metric_cell(m) for m in fit.validation]
         for label, fit in (("baseline", r.baseline), ("final", r.final))})
    lines += ["", "Cells: RMSE (relative error 100 ||y - y_hat|| / ||y||) of the measured "
              f"{record.target} force.", ""]
    lines += informed.outlier_lines({f"{record.target}_force_N": "N"})
    return lines


def _selected_lines(r: Identification) -> list[str]:
    """Each selected effect, why, its values and its ties."""
    lines: list[str] = []
    lines += ["## Selected effects and why", ""]
    if not r.selected:
        lines.append("None: no candidate effect passed the criterion (below). The baseline "
                     "is the final model.")
    for effect in r.selected:
        c = r.candidates[effect]
        exposing = r.exposing.get(effect, "")
        binned = r.baseline_analysis.binned.get(exposing)
        exposed = (f" The baseline residual against {binned.regressor} shows it "
                   f"(bin means carry {100 * binned.explained:.1f} % of the residual "
                   "variance; figure residual_vs_regressor.png).") if binned else ""
        values = ", ".join(f"{name} = {_pm(c.fit, name)}" for name in
                           _effect_names(effect, c.fit))
        ties = [o.effect for o in r.rounds[c.round - 1]
                if o.effect != effect and o.justified and abs(o.delta_bic - c.delta_bic) < 2.0]
        tied = (f" Indistinguishable on this record from {', '.join(ties)} (dBIC within 2): "
                "the data cannot tell them apart; the one with the lower dBIC is kept.") if ties else ""
        lines.append(f"- **{effect}** (round {c.round}): {c.reason}"
                     + (f"; held-out RMSE {100 * (math.exp(c.validation_log_ratio) - 1):+.1f} %"
                        if c.validation_log_ratio is not None else "")
                     + f". {values}.{exposed}{tied}")
    return lines


def _rounds_lines(r: Identification) -> list[str]:
    """Every candidate of every round with its dBIC and verdict."""
    lines: list[str] = []
    lines += ["", "## Candidates, round by round", "",
              "dBIC = n_eff ln(RSS_E/RSS_M) + (k_E - k_M) ln(n_eff) against the model of that "
              "round (negative favours the effect); justified when dBIC < "
              f"{r.settings['bic_threshold']:g}, the training RMSE falls by at least "
              f"{100 * r.settings['min_improvement']:g} %, held-out RMSE falls (when there are "
              "held-out records) and, for periodic effects, the effect beats an additive tone.",
              ""]
    for index, evaluated in enumerate(r.rounds, start=1):
        lines += [f"Round {index}:", "",
                  "| effect | dBIC | training RMSE (N) | change | held-out change | verdict |",
                  "|---|---|---|---|---|---|"]
        for c in sorted(evaluated, key=lambda c: c.delta_bic):
            held = ("" if c.validation_log_ratio is None else
                    f"{100 * (math.exp(c.validation_log_ratio) - 1):+.2f} %")
            verdict = ("**selected**" if c.justified and r.selected[index - 1:index] == [c.effect]
                       else ("justified" if c.justified else c.reason))
            lines.append(f"| {c.effect} | {c.delta_bic:.1f} | {c.fit.train.rmse_N:.5g} | "
                         f"{-100 * c.train_drop:+.2f} % | {held} | {verdict} |")
        lines.append("")
    if r.skipped:
        lines += ["Not candidates here:", ""]
        lines += [f"- {effect}: {why}" for effect, why in r.skipped.items()]
        lines.append("")
    return lines


def _parameter_lines(r: Identification, informed) -> list[str]:
    """The parameters of the baseline and final models."""
    lines: list[str] = []
    lines += ["## Final parameters", "",
              "1-sigma from the Jacobian at the optimum, s^2 (J^T J)^-1 with s^2 = RSS/(n - k), "
              "inflated by n/n_eff for the residual's autocorrelation "
              f"(n = {r.final.n}, n_eff = {r.final.n_eff:.0f}).", "",
              "| parameter | baseline | final | informed (final) |", "|---|---|---|---|"]
    names = list(dict.fromkeys([*r.baseline.values, *r.final.values]))
    for name in names:
        before = _pm(r.baseline, name) if name in r.baseline.values else ""
        after = _pm(r.final, name) if name in r.final.values else ""
        lines.append(f"| {informed.label(name)} | {before} | {after} | "
                     f"{informed.flag(name)} |")
    return lines + informed.parameter_notes()


def _residual_lines(r: Identification) -> list[str]:
    """What is left in the residual: shares, peaks, ringing."""
    lines: list[str] = []
    lines += ["", "## Residual", ""]
    for label, analysis in (("baseline", r.baseline_analysis), ("final", r.final_analysis)):
        shares = ", ".join(f"{b.regressor} {100 * b.explained:.1f} %"
                           for b in analysis.binned.values())
        peaks = analysis.spectrum.peaks_Hz if analysis.spectrum else []
        lines.append(f"- {label}: share of the residual variance carried by bin means: {shares}; "
                     f"autocorrelation time {analysis.tau_samples:.1f} samples "
                     f"(n_eff = {analysis.n_eff:.0f}); spectral peaks > 10x the noise floor: "
                     + (", ".join(f"{f:.5g} Hz" for f in peaks) if peaks else "none"))
    final_peaks = r.final_analysis.spectrum.peaks_Hz if r.final_analysis.spectrum else []
    lines += ["", "Unexplained residual: " + (
        "peaks at " + ", ".join(f"{f:.5g} Hz" for f in final_peaks) +
        " stand above the noise floor and no effect of the vocabulary explains them "
        "(`residual_peaks_Hz`)." if final_peaks else "no spectral peak stands above the noise "
        "floor."), ""]
    ringing = r.final_analysis.ringing
    if ringing:
        lines += [f"Ringing after the reversals (`ringing_after_reversals`): the residual, "
                  f"averaged over {ringing.reversals} reversals and signed by the new direction, "
                  f"is a damped oscillation at {ringing.frequency_Hz:.4g} Hz with damping ratio "
                  f"{ringing.damping_ratio:.3g} and {ringing.amplitude_N:.3g} N at the reversal "
                  f"({100 * ringing.explained:.0f} % of that averaged residual): a resonance "
                  "the friction model lacks -- a compliance in series with the contact, or "
                  "backlash whose impacts excite it. A play in the contact itself (the force "
                  "near 0 for a stretch after each reversal) is the candidate `contact_play`"
                  + (" (selected above)" if "contact_play" in r.selected else
                     " (declared)" if "contact_play" in r.declared else
                     " (" + r.skipped["contact_play"] + ")" if "contact_play" in r.skipped
                     else " (tried above)") +
                  "; a play in a rig's drive, before its dynamometer, is the simulation path's "
                  "`backlash` candidate; the impacts' resonance (a mass behind the play) is "
                  "not in the vocabulary.", ""]
    return lines


def _mujoco_lines(r: Identification, rig_replay: dict | None) -> list[str]:
    """The final model as a simulate command, and its replay in the rig."""
    lines: list[str] = []
    lines += ["## The final model in MuJoCo", "",
              "Every fitted value is a field of FrictionParameters / RigParameters, i.e. a config "
              "attribute of the `vibrofriction.friction` plugin (docs/simulation.md, "
              "Parameters):", "",
              "    vibrofriction simulate --law " + r.law + " " +
              " ".join(f"--set {k}={_set_text(v)}" for k, v in _set_values(r).items()), ""]
    if rig_replay:
        lines += [f"Replayed in the MuJoCo rig (timestep {rig_replay['timestep_s']:g} s, from "
                  "rest, sidecar rig values): relative error of the "
                  f"{rig_replay['signal']} against the record: baseline "
                  f"{rig_replay['baseline_relerr_pct']:.3g} %, final "
                  f"{rig_replay['final_relerr_pct']:.3g} %.", ""]
    return lines


def _closing_lines() -> list[str]:
    """The figures and the method."""
    lines: list[str] = []
    lines += ["## Figures", "",
              "- `fit.png`: measured vs model, baseline and final",
              "- `residual_vs_regressor.png`: baseline and final residual against the regressor "
              "that exposed each selected effect",
              "- `spectrum.png`: residual spectra (Welch) with the noise floor and peaks",
              "- `diagnostics.png`: the share of the final residual's variance each regressor "
              "carries (red: significant)",
              "- `series_<dataset>.png`, the training record's and each held-out record's: "
              "the final model's prediction and residual, the whole record and a window of a "
              "few vibration periods (or 5 % of the record) where the residual is largest", "",
              "The series themselves are `series_<dataset>.csv` (report.json `series`): "
              "time_s and the measured, predicted and residual (measured - predicted) force, "
              "written with --no-figures too.", ""]
    lines += ["## Method", "",
              "Inverse model: the law (the plugin's C++ code via laws.run_law) is driven by the "
              "measured relative velocity (body minus support) along the record; the predicted "
              "measured force is the friction (friction records) or m a + friction - h_d (v_d - "
              "xdot) (drive-force records). scipy least_squares (trf) fits all parameters of a "
              "model at once; each candidate effect is refitted with everything else.", ""]
    return lines


def _metric_cell(m) -> str:
    return f"{m.rmse_N:.4g} N ({m.relerr_pct:.3g} %)"


def _pm(fit: FitResult, name: str) -> str:
    value = fit.values[name]
    sigma = fit.uncertainties.get(name)
    bound = " (at the bound of its range)" if name in fit.at_bound else ""
    if sigma is None or not math.isfinite(sigma):
        return f"{value:.6g}{bound}"
    return f"{value:.6g} ± {sigma:.2g}{bound}"


def _effect_names(effect: str, fit: FitResult) -> list[str]:
    return [n for n in effect_fields(effect) if n in fit.values]


def _set_values(r: Identification) -> dict[str, float]:
    out = {}
    own = own_parameter_names(r.final.model.effects)  # (run as their level map's lists)
    for name, value in parameters(r, r.final).items():
        if name in own:
            continue
        if name in r.final.values or name in ("normal_force_N",) or \
                name == "normal_force_modulation_frequency_Hz" and \
                "normal_force_modulation" in r.final.values:
            if value is not None:
                out[name] = value
    if r.train.mass_kg is not None or "mass_kg" in r.final.values:
        out["mass_kg"] = parameters(r, r.final)["mass_kg"]
    fitted = parameters(r, r.final)
    for effect in MAP_EFFECTS:  # a map: its knots and factors, as lists
        if effect in (*r.final.model.effects, *own_map_effects(r.final.model.effects)):
            prefix = effect.split("_")[0]
            out.update({k: v for k, v in fitted.items() if k.startswith(f"{prefix}_map_")})
    return out


def _set_text(value) -> str:
    """A --set value: a number, or a list as comma-separated numbers."""
    if isinstance(value, (list, tuple)):
        return ",".join(f"{x:.6g}" for x in value)
    return f"{value:.6g}"


# ------------------------------------------------------------------------------ rig replay

def rig_replay(result: Identification, dataset_metadata, timestep_s: float = 1e-6
               ) -> dict | None:
    """Run the MuJoCo rig with the baseline and the final parameters, compare with the record.

    Only for records of a spring-driven rig (sidecar: mass_kg, drive_stiffness_N_per_m,
    drive_velocity_m_per_s, normal_force_N) that start from rest at t = 0. The support is
    u0 sin(2 pi f t) with the measured velocity amplitude, as the rig's motion plugin makes it.
    """
    from ..rigs import rig as rig_module

    record = result.train
    meta = dataset_metadata
    if not (meta.drive_stiffness_N_per_m and meta.drive_velocity_m_per_s and
            record.normal_force_known and (meta.mass_kg or "mass_kg" in result.final.values)
            and abs(record.time_s[0]) < 1e-12):
        return None
    amplitude = 0.0
    if record.vibrating:
        amplitude = float(np.sqrt(2 * np.mean(
            (record.body_velocity_m_per_s - record.relative_velocity_m_per_s) ** 2)))
    duration = float(record.time_s[-1])
    out = {"timestep_s": timestep_s}
    for label, fit in (("baseline", result.baseline), ("final", result.final)):
        p = parameters(result, fit)
        rig = RigParameters(mass_kg=p["mass_kg"],
                            drive_stiffness_N_per_m=meta.drive_stiffness_N_per_m,
                            drive_damping_N_s_per_m=p["drive_damping_N_s_per_m"],
                            drive_velocity_m_per_s=meta.drive_velocity_m_per_s,
                            vibration_frequency_Hz=record.vibration_frequency_Hz or 0.0,
                            vibration_velocity_amplitude_m_per_s=amplitude,
                            normal_force_N=p["normal_force_N"])
        friction = fit.model.friction_parameters(fit.values, record.vibration_frequency_Hz)
        run = rig_module.simulate(rig, friction, duration_s=duration + timestep_s,
                                  timestep_s=timestep_s)
        if record.target == "friction":
            signal, measured = run.friction_force_N, record.target_N
            out["signal"] = "friction force"
        else:
            signal, measured = run.slider_velocity_m_per_s, record.body_velocity_m_per_s
            out["signal"] = "slider velocity"
        simulated = np.interp(record.time_s, run.time_s, signal)
        # Compared after the first 1 % of the record: at t = 0 the plugin and a record differ
        # by convention (force and lagged sensor start at 0 in the plugin), not by physics.
        keep = record.time_s >= record.time_s[0] + 0.01 * (record.time_s[-1] - record.time_s[0])
        out[f"{label}_relerr_pct"] = float(100 * np.linalg.norm((simulated - measured)[keep]) /
                                           np.linalg.norm(measured[keep]))
    return out


# ----------------------------------------------------------------------------------- write

def write_report(result: Identification, out_dir: str | os.PathLike, *,
                 figures: bool = True, rig_replay_result: dict | None = None) -> Path:
    """Write everything into a temporary folder next to ``out_dir``, then move it in place.

    A failure while writing leaves ``out_dir`` as it was (no half-written report).
    """
    def write(tmp: Path) -> None:
        (tmp / "report.json").write_text(json_text(report_json(result)))
        (tmp / "report.md").write_text(report_markdown(result, rig_replay_result))
        write_series(inverse_series(result), tmp, figures=figures,
                     title=f"{result.law} + " + (", ".join(result.selected) or "nothing"))
        if figures:
            from .figures import write_figures
            write_figures(result, tmp)
            residual_diagnostics.write_figure([residual_diagnostics.for_identification(result)],
                                              tmp / "diagnostics.png")

    return write_folder(out_dir, write)


def write_folder(out_dir: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Run ``write(tmp)`` on a new folder beside ``out_dir``, then swap it in: an existing
    ``out_dir`` is replaced as a whole (renamed aside, the new one renamed in, the old one
    deleted; restored on any failure), so no stale file of an earlier report stays. Inside
    ``datasets.all_or_nothing()`` the swap happens with the block's other outputs."""
    stage_folder(out_dir, write)
    return Path(out_dir)


__all__ = ["report_json", "report_markdown", "write_report", "write_folder", "parameters", "rig_replay",
           "REPORT_FILES"]
