"""The paper's computational figures (Gutowski & Leus 2012, Figs. 7-14) and master curves.

Each ``fig_*`` function computes its runs, writes ``<name>.png`` and ``<name>.csv`` into the
output folder, and returns the numbers the claims summary needs. Computation and plotting are
separate (``compute_*`` / ``plot_*``) so that tests can check numbers without drawing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..params import LAWS, RigParameters
from ..rigs.sweep import joint_convergence
from . import overlays
from .config import (EXPERIMENT_FIG13, EXPERIMENT_FIG14, MM_PER_S, N_PER_UM,
                     PROFILE_COULOMB_VIBRATION_VELOCITY_M_PER_S,
                     PROFILE_VIBRATION_VELOCITIES_M_PER_S,
                     STIFFNESS_PROFILE_VIBRATION_VELOCITY_M_PER_S,
                     TRACE_VIBRATION_VELOCITIES_M_PER_S, ExperimentConfig, StudyConfig)
from .output import LAW_COLORS, LAW_LABELS, new_figure, save_figure, write_csv
from .runner import Case, Progress, Trace, run_points, run_traces, static_points

UM = 1e-6


# ----------------------------------------------------------------------------- master curves
@dataclass(frozen=True)
class MasterPoint:
    """One point of a master curve F_d-v/F_d-s = f(kappa_v)."""

    law: str
    kappa: float
    vibration_velocity_amplitude_m_per_s: float
    vibration_frequency_Hz: float
    drive_velocity_m_per_s: float
    normal_force_N: float
    contact_stiffness_N_per_m: float
    timestep_s: float
    mean_drive_force_N: float
    static_drive_force_N: float
    friction_min_N: float
    friction_max_N: float
    sign_change: bool
    kinematic_ratio: float
    converged: bool  # the run and its static run reached steady state (orbit or transient)
    estimated_remaining_error: float  # relative, of mean_drive_force_N
    window_start_s: float  # the averaging window of mean_drive_force_N
    window_end_s: float

    @property
    def ratio(self) -> float:
        return self.mean_drive_force_N / self.static_drive_force_N

    def row(self) -> dict[str, object]:
        return {
            "law": self.law, "kappa": self.kappa,
            "vibration_velocity_amplitude_m_per_s": self.vibration_velocity_amplitude_m_per_s,
            "vibration_frequency_Hz": self.vibration_frequency_Hz,
            "drive_velocity_m_per_s": self.drive_velocity_m_per_s,
            "normal_force_N": self.normal_force_N,
            "contact_stiffness_N_per_m": self.contact_stiffness_N_per_m,
            "timestep_s": self.timestep_s,
            "mean_drive_force_N": self.mean_drive_force_N,
            "static_drive_force_N": self.static_drive_force_N,
            "ratio": self.ratio,
            "friction_min_N": self.friction_min_N, "friction_max_N": self.friction_max_N,
            "sign_change": self.sign_change, "kinematic_ratio": self.kinematic_ratio,
            "converged": self.converged,
            "estimated_remaining_error": self.estimated_remaining_error,
            "window_start_s": self.window_start_s, "window_end_s": self.window_end_s,
        }


def compute_master(config: StudyConfig, base: RigParameters, laws: Sequence[str],
                   kappas: Sequence[float], *, contact_stiffness_N_per_m: float | None = None,
                   kinematic: bool = True, progress: Progress | None = None
                   ) -> list[MasterPoint]:
    """Master curves of ``laws`` over ``kappas`` (v_a = kappa v_d) around ``base``."""
    cases: list[Case] = []
    for law in laws:
        for kappa in kappas:
            r = replace(base, vibration_velocity_amplitude_m_per_s=kappa
                        * base.drive_velocity_m_per_s).validate()
            cases.append((r, config.friction_for(law, r, contact_stiffness_N_per_m)))
    points = run_points(cases, config, progress=progress)
    statics = static_points(cases, config)
    kin: dict[str, np.ndarray] = {}
    if kinematic:
        for law in laws:
            friction = config.friction_for(law, base, contact_stiffness_N_per_m)
            kin[law] = overlays.kinematic_ratios(
                friction, base, kappas, periods=config.kinematic_periods,
                samples_per_period=config.kinematic_samples_per_period)
    out = []
    for k, ((r, f), p, fds) in enumerate(zip(cases, points, statics)):
        law = f.law
        kappa = kappas[k % len(kappas)]
        converged, remaining = joint_convergence(p, fds)
        out.append(MasterPoint(
            law=law, kappa=float(kappa),
            vibration_velocity_amplitude_m_per_s=r.vibration_velocity_amplitude_m_per_s,
            vibration_frequency_Hz=r.vibration_frequency_Hz,
            drive_velocity_m_per_s=r.drive_velocity_m_per_s, normal_force_N=r.normal_force_N,
            contact_stiffness_N_per_m=f.contact_stiffness_N_per_m, timestep_s=p.timestep_s,
            mean_drive_force_N=p.summary.mean_drive_force_N,
            static_drive_force_N=fds.mean_drive_force_N,
            friction_min_N=p.summary.friction_min_N, friction_max_N=p.summary.friction_max_N,
            sign_change=p.summary.sign_change,
            kinematic_ratio=float(kin[law][k % len(kappas)]) if law in kin else math.nan,
            converged=converged, estimated_remaining_error=remaining,
            window_start_s=p.summary.window_start_s, window_end_s=p.summary.window_end_s))
    return out


def curve(points: Sequence[MasterPoint], law: str, *, stiffness: float | None = None
          ) -> list[MasterPoint]:
    """The points of one law (and stiffness), sorted by kappa."""
    sel = [p for p in points if p.law == law
           and (stiffness is None or math.isclose(p.contact_stiffness_N_per_m, stiffness))]
    return sorted(sel, key=lambda p: p.kappa)


def _master_axes(ax, title: str) -> None:
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.axvline(1.0, color="0.8", lw=0.8)
    ax.axhline(1 / 20, color="0.6", lw=0.8, ls=":")
    ax.text(0.99, 1 / 20 * 1.08, "20-fold reduction", fontsize=7, color="0.4", ha="right",
            transform=ax.get_yaxis_transform())
    ax.set_xlabel(r"$\kappa_v = v_a / v_d$")
    ax.set_ylabel(r"$F_{d\text{-}v} / F_{d\text{-}s}$")
    ax.set_ylim(3e-3, 1.4)
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)


def plot_master(points: Sequence[MasterPoint], laws: Sequence[str], path: Path, *,
                title: str, alpha: float = 1.0) -> Path:
    """Master curves with kinematic limits (dashed) and the closed forms when available."""
    fig = new_figure(6.4, 4.2)
    ax = fig.subplots()
    kappas = np.array(sorted({p.kappa for p in points}))
    for law in laws:
        c = curve(points, law)
        ks = [p.kappa for p in c]
        emphasis = dict(lw=2.4, zorder=5) if law == "dahl" else dict(lw=1.2, zorder=4)
        ax.plot(ks, [p.ratio for p in c], "o-", ms=3, color=LAW_COLORS[law],
                label=f"{LAW_LABELS[law]} (rig)", **emphasis)
        kin = [p.kinematic_ratio for p in c]
        if not all(math.isnan(v) for v in kin):
            ax.plot(ks, kin, "--", lw=0.9, color=LAW_COLORS[law],
                    label=f"{LAW_LABELS[law]} kinematic limit")
        sc = [p for p in c if p.sign_change]
        if sc:
            ax.plot([p.kappa for p in sc], [p.ratio for p in sc], "x", color=LAW_COLORS[law],
                    ms=5, lw=0.8)
    dense = np.geomspace(max(kappas.min(), 0.2), kappas.max(), 200)
    arc = overlays.arcsin_ratios(dense)
    if arc is not None:
        ax.plot(dense, arc, "k-", lw=0.8, label=r"arcsin law $\frac{2}{\pi}\arcsin(1/\kappa_v)$")
    dahl0 = overlays.dahl_vanishing_amplitude_ratios(dense, alpha)
    if dahl0 is not None and "dahl" in laws:
        ax.plot(dense, dahl0, ":", color=LAW_COLORS["dahl"], lw=1.2,
                label=r"Dahl, $u_0 \to 0$")
    ax.plot([], [], "kx", ms=5, label="x: F_F changes sign")
    _master_axes(ax, title)
    ax.legend(fontsize=6.5, ncol=2, loc="lower left")
    return save_figure(fig, path)


def fig_master_curves(config: StudyConfig, out: Path, progress: Progress | None = None
                      ) -> list[MasterPoint]:
    """Master curves of all four laws at the paper's simulation parameters (Figs. 7-12)."""
    points = compute_master(config, config.rig, LAWS, config.kappas, progress=progress)
    write_csv(out / "master_curves.csv", rows=[p.row() for p in points])
    r = config.rig
    alpha = (config.friction.alpha if config.friction is not None else 1.0)
    plot_master(points, LAWS, out / "master_curves.png", alpha=alpha,
                title=(f"f = {r.vibration_frequency_Hz:g} Hz, v_d = "
                       f"{r.drive_velocity_m_per_s / MM_PER_S:g} mm/s, F_N = "
                       f"{r.normal_force_N:g} N, k_t = "
                       f"{config.friction_for('dahl', r).contact_stiffness_N_per_m / N_PER_UM:g}"
                       " N/um"))
    return points


# ----------------------------------------------------------------------------- Figs. 7-10
def _trace_rows(traces: Sequence[Trace], label: Callable[[Trace], dict]) -> list[dict]:
    rows = []
    for tr in traces:
        cols = tr.columns()
        fixed = label(tr)
        for i in range(tr.time_s.shape[0]):
            row = dict(fixed)
            row.update({k: float(v[i]) for k, v in cols.items()})
            rows.append(row)
    return rows


def _case_label(tr: Trace) -> dict:
    return {"law": tr.friction.law,
            "vibration_velocity_amplitude_m_per_s": tr.rig.vibration_velocity_amplitude_m_per_s,
            "contact_stiffness_N_per_m": tr.friction.contact_stiffness_N_per_m,
            "timestep_s": tr.timestep_s}


def compute_time_traces(config: StudyConfig, progress: Progress | None = None
                        ) -> dict[tuple[str, float], Trace]:
    """Dahl and Coulomb at v_a = 0.25, 0.75, 3.0 mm/s (Figs. 7-9), keyed (law, v_a)."""
    cases: list[Case] = []
    for va in TRACE_VIBRATION_VELOCITIES_M_PER_S:
        r = replace(config.rig, vibration_velocity_amplitude_m_per_s=va).validate()
        for law in ("dahl", "coulomb"):
            cases.append((r, config.friction_for(law, r)))
    traces = run_traces(cases, config, periods=config.trace_periods, progress=progress)
    return {(tr.friction.law, tr.rig.vibration_velocity_amplitude_m_per_s): tr
            for tr in traces}


def plot_time_traces(traces: dict[tuple[str, float], Trace], va: float, number: int,
                     path: Path) -> Path:
    """Plot one of Figs. 7-9 and save it: Dahl (left) and Coulomb (right) at one v_a, with the
    slider position (um), the velocities v_A, v_d, v_v, v_r (mm/s) and the friction force F_F
    (N) over time (us).

    Parameters
    ----------
    traces : dict of (str, float) to Trace
        The traces keyed (law, v_a in m/s), as ``compute_time_traces`` returns them; those of
        dahl and coulomb at ``va`` are drawn.
    va : float
        The vibration velocity amplitude v_a (m/s).
    number : int
        The paper's figure number, for the title.
    path : Path
        The image file to write (its folder is made).

    Returns
    -------
    Path
        ``path``.
    """
    fig = new_figure(7.2, 5.6)
    axes = fig.subplots(3, 2, sharex=True)
    for col, law in enumerate(("dahl", "coulomb")):
        tr = traces[(law, va)]
        t_us = tr.time_s / UM
        ax = axes[0, col]
        ax.plot(t_us, tr.slider_position_m / UM, color="k", lw=1)
        ax.set_ylabel(r"$x_A$ (µm)")
        ax.set_title(f"{LAW_LABELS[law]}: F_dv/F_ds = {tr.ratio:.3f}"
                     + (", F_F changes sign" if tr.summary.sign_change else ""), fontsize=9)
        ax = axes[1, col]
        ax.plot(t_us, tr.slider_velocity_m_per_s / MM_PER_S, label=r"$v_A$", lw=1)
        ax.plot(t_us, np.full_like(t_us, tr.rig.drive_velocity_m_per_s / MM_PER_S),
                label=r"$v_d$", lw=1, ls="--")
        ax.plot(t_us, tr.support_velocity_m_per_s / MM_PER_S, label=r"$v_v$", lw=1)
        ax.plot(t_us, tr.relative_velocity_m_per_s / MM_PER_S, label=r"$v_r$", lw=1)
        ax.set_ylabel("velocity (mm/s)")
        ax.axhline(0, color="0.7", lw=0.5)
        if col == 0:
            ax.legend(fontsize=7, ncol=4, loc="upper right")
        ax = axes[2, col]
        ax.plot(t_us, tr.friction_force_N, color=LAW_COLORS[law], lw=1.2)
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set_ylabel(r"$F_F$ (N)")
        ax.set_xlabel("t (µs, last whole periods)")
    r = next(iter(traces.values())).rig
    fig.suptitle(f"Fig. {number}: f = {r.vibration_frequency_Hz:g} Hz, v_a = "
                 f"{va / MM_PER_S:g} mm/s, v_d = {r.drive_velocity_m_per_s / MM_PER_S:g} mm/s",
                 fontsize=10)
    return save_figure(fig, path)


TRACE_FIGURE_NAMES = {0.25 * MM_PER_S: (7, "fig07_traces_va0.25"),
                      0.75 * MM_PER_S: (8, "fig08_traces_va0.75"),
                      3.0 * MM_PER_S: (9, "fig09_traces_va3.0")}


def fig_time_traces(config: StudyConfig, out: Path, progress: Progress | None = None
                    ) -> dict[tuple[str, float], Trace]:
    """Figs. 7, 8 and 9 (PNG + CSV each)."""
    traces = compute_time_traces(config, progress)
    for va, (number, name) in TRACE_FIGURE_NAMES.items():
        sel = [traces[(law, va)] for law in ("dahl", "coulomb")]
        write_csv(out / f"{name}.csv", rows=_trace_rows(sel, _case_label))
        plot_time_traces(traces, va, number, out / f"{name}.png")
    return traces


def fig_hysteresis(traces: dict[tuple[str, float], Trace], out: Path) -> Path:
    """Fig. 10: Dahl, the three cases of Figs. 7-9: F_F against the contact deflection z (top;
    a line F_F = k_t z, its extent shows how far z travels between -z_max and z_max) and
    against the slider's displacement on the support with the mean sliding removed (bottom:
    the hysteresis loops)."""
    fig = new_figure(7.6, 4.6)
    axes = fig.subplots(2, 3, sharey="col")
    rows = []
    for col, (letter, va) in enumerate(zip("abc", TRACE_VIBRATION_VELOCITIES_M_PER_S)):
        tr = traces[("dahl", va)]
        zmax = tr.static_drive_force_N / tr.friction.contact_stiffness_N_per_m
        ax = axes[0, col]
        ax.plot(tr.deflection_m / UM, tr.friction_force_N, "-o", ms=1.5,
                color=LAW_COLORS["dahl"], lw=1)
        for sign in (-1, 1):
            ax.axvline(sign * zmax / UM, color="0.6", lw=0.8, ls=":")
        ax.set_xlim(-1.15 * zmax / UM, 1.15 * zmax / UM)
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set_xlabel("z (µm);  dotted: ±z_max = ±µF_N/k_t", fontsize=7)
        ax.set_title(f"({letter}) v_a = {va / MM_PER_S:g} mm/s", fontsize=9)
        ax = axes[1, col]
        rel = tr.relative_oscillation_m
        ax.plot(rel / UM, tr.friction_force_N, color=LAW_COLORS["dahl"], lw=1)
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set_xlabel(r"$x - u - v_d t$ (µm, mean removed)", fontsize=7)
        for z, f, r in zip(tr.deflection_m, tr.friction_force_N, rel):
            rows.append({"vibration_velocity_amplitude_m_per_s": va, "deflection_m": float(z),
                         "relative_displacement_m": float(r), "friction_force_N": float(f)})
    axes[0, 0].set_ylabel(r"$F_F$ (N)")
    axes[1, 0].set_ylabel(r"$F_F$ (N)")
    fig.suptitle("Fig. 10: Dahl, F_F against the contact deflection z and the displacement on "
                 "the support (last whole periods)", fontsize=9)
    write_csv(out / "fig10_hysteresis.csv", rows=rows)
    return save_figure(fig, out / "fig10_hysteresis.png")


# ----------------------------------------------------------------------------- Fig. 11
def fig_profiles(config: StudyConfig, out: Path, progress: Progress | None = None
                 ) -> list[Trace]:
    """Fig. 11: F_F profiles, Dahl at 0.60 ... 8.0 mm/s and Coulomb at 8.0 mm/s."""
    cases: list[Case] = []
    for va in PROFILE_VIBRATION_VELOCITIES_M_PER_S:
        r = replace(config.rig, vibration_velocity_amplitude_m_per_s=va).validate()
        cases.append((r, config.friction_for("dahl", r)))
    r = replace(config.rig, vibration_velocity_amplitude_m_per_s=(
        PROFILE_COULOMB_VIBRATION_VELOCITY_M_PER_S)).validate()
    cases.append((r, config.friction_for("coulomb", r)))
    traces = run_traces(cases, config, periods=2, progress=progress)
    fig = new_figure(6.4, 4.0)
    ax = fig.subplots()
    cmap = __import__("matplotlib").colormaps["viridis"]
    for k, tr in enumerate(traces):
        period = 1.0 / tr.rig.vibration_frequency_Hz
        law = tr.friction.law
        style = dict(color="k", ls="--", lw=1) if law == "coulomb" else dict(
            color=cmap(k / max(1, len(traces) - 2)), lw=1.2)
        ax.plot(tr.time_s / period, tr.friction_force_N, **style,
                label=(f"{LAW_LABELS[law]} v_a = "
                       f"{tr.rig.vibration_velocity_amplitude_m_per_s / MM_PER_S:g} mm/s "
                       f"(ratio {tr.ratio:.3f})"))
    ax.axhline(0, color="0.7", lw=0.5)
    ax.set_xlabel("t / T (last two periods)")
    ax.set_ylabel(r"$F_F$ (N)")
    kt = traces[0].friction.contact_stiffness_N_per_m / N_PER_UM
    ax.set_title(f"Fig. 11: f = {traces[0].rig.vibration_frequency_Hz:g} Hz, v_d = "
                 f"{traces[0].rig.drive_velocity_m_per_s / MM_PER_S:g} mm/s, k_t = {kt:g} N/um",
                 fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    write_csv(out / "fig11_profiles.csv", rows=_trace_rows(traces, _case_label))
    save_figure(fig, out / "fig11_profiles.png")
    return traces


# ----------------------------------------------------------------------------- Fig. 12
@dataclass(frozen=True)
class StiffnessStudy:
    """The Fig. 12 study (Dahl): the F_F profiles at v_a = 0.75 mm/s and the master-curve
    points, one set per contact stiffness, and the true (the study's) k_t (N/m)."""

    profiles: list[Trace]
    points: list[MasterPoint]
    true_stiffness_N_per_m: float


def fig_stiffness(config: StudyConfig, out: Path, progress: Progress | None = None
                  ) -> StiffnessStudy:
    """Fig. 12: influence of k_t on (a) the F_F profile at v_a = 0.75 mm/s and (b) the master
    curve, Dahl."""
    va = STIFFNESS_PROFILE_VIBRATION_VELOCITY_M_PER_S
    r = replace(config.rig, vibration_velocity_amplitude_m_per_s=va).validate()
    cases = [(r, config.friction_for("dahl", r, kt)) for kt in config.stiffness_values_N_per_m]
    profiles = run_traces(cases, config, periods=2)
    points: list[MasterPoint] = []
    n = len(config.stiffness_values_N_per_m)
    for k, kt in enumerate(config.stiffness_values_N_per_m):
        points += compute_master(config, config.rig, ("dahl",), config.stiffness_kappas,
                                 contact_stiffness_N_per_m=kt, kinematic=False)
        if progress:
            progress(k + 1, n)
    true_kt = config.friction_for("dahl", config.rig).contact_stiffness_N_per_m
    write_csv(out / "fig12a_stiffness_profiles.csv", rows=_trace_rows(profiles, _case_label))
    write_csv(out / "fig12b_stiffness_master.csv", rows=[p.row() for p in points])
    fig = new_figure(7.6, 3.4)
    ax_a, ax_b = fig.subplots(1, 2)
    cmap = __import__("matplotlib").colormaps["plasma"]
    for k, (tr, kt) in enumerate(zip(profiles, config.stiffness_values_N_per_m)):
        color = cmap(k / max(1, n - 1) * 0.85)
        lw = 2.0 if math.isclose(kt, true_kt) else 1.0
        label = f"k_t = {kt / N_PER_UM:g} N/um"
        ax_a.plot(tr.time_s * tr.rig.vibration_frequency_Hz, tr.friction_force_N, color=color,
                  lw=lw, label=label)
        c = curve(points, "dahl", stiffness=kt)
        ax_b.plot([p.kappa for p in c], [p.ratio for p in c], "o-", ms=2.5, color=color, lw=lw,
                  label=label)
    ax_a.set_xlabel("t / T")
    ax_a.set_ylabel(r"$F_F$ (N)")
    ax_a.set_title(f"(a) v_a = {va / MM_PER_S:g} mm/s", fontsize=9)
    ax_a.legend(fontsize=6.5)
    _master_axes(ax_b, "(b) Dahl master curve")
    fig.suptitle("Fig. 12: influence of the contact stiffness k_t (Dahl, f = "
                 f"{config.rig.vibration_frequency_Hz:g} Hz, v_d = "
                 f"{config.rig.drive_velocity_m_per_s / MM_PER_S:g} mm/s)", fontsize=10)
    save_figure(fig, out / "fig12_stiffness.png")
    return StiffnessStudy(profiles=profiles, points=points, true_stiffness_N_per_m=true_kt)


# ----------------------------------------------------------------------------- Figs. 13-14
@dataclass(frozen=True)
class ExperimentTraces:
    """The Fig. 13 analogue's traces: every law at each v_a of the experiment with F_N = p S,
    and Dahl with F_N = F_e + m g (the alternative normal force)."""

    traces: list[Trace]
    # Dahl with F_N = F_e + m g instead of p S, same v_a order as the experiment's.
    alternative_normal_force: list[Trace]


def experiment_base(config: StudyConfig, experiment: ExperimentConfig) -> RigParameters:
    """The rig of an experimental configuration without vibration (v_a = 0).

    Parameters
    ----------
    config : StudyConfig
        The study; its ``rig`` gives every value the experiment does not set.
    experiment : ExperimentConfig
        The configuration (Fig. 13 or 14): its mass, vibration frequency, drive velocity
        and normal force F_N = p S.

    Returns
    -------
    RigParameters
        The rig, validated.
    """
    return experiment.rig(0.0, base=config.rig)


def fig_experiment_traces(config: StudyConfig, out: Path, progress: Progress | None = None,
                          experiment: ExperimentConfig = EXPERIMENT_FIG13) -> ExperimentTraces:
    """Fig. 13 analogue: F_F over time for the four laws at the experiment's two v_a."""
    cases: list[Case] = []
    for va in experiment.vibration_velocities_m_per_s:
        r = experiment.rig(va, base=config.rig)
        for law in LAWS:
            cases.append((r, config.friction_for(law, r, experiment.contact_stiffness_N_per_m)))
    alt_cases: list[Case] = []
    for va in experiment.vibration_velocities_m_per_s:
        r = experiment.rig(va, base=config.rig,
                           normal_force_N=experiment.normal_force_from_loads_N)
        alt_cases.append((r, config.friction_for("dahl", r,
                                                 experiment.contact_stiffness_N_per_m)))
    traces = run_traces(cases + alt_cases, config, periods=3, progress=progress)
    main, alt = traces[:len(cases)], traces[len(cases):]
    fig = new_figure(7.6, 3.4)
    axes = fig.subplots(1, len(experiment.vibration_velocities_m_per_s), sharey=True)
    for ax, letter, va in zip(np.atleast_1d(axes), "ab", experiment.vibration_velocities_m_per_s):
        for tr in main:
            if tr.rig.vibration_velocity_amplitude_m_per_s != va:
                continue
            law = tr.friction.law
            ax.plot(tr.time_s / UM, tr.friction_force_N, color=LAW_COLORS[law], lw=1.1,
                    label=f"{LAW_LABELS[law]} (ratio {tr.ratio:.3f})")
        ax.axhline(0, color="0.7", lw=0.5)
        ax.set_xlabel("t (µs)")
        ax.set_title(f"({letter}) v_d = {experiment.drive_velocity_m_per_s / MM_PER_S:g} mm/s, "
                     f"v_a = {va / MM_PER_S:g} mm/s", fontsize=9)
        ax.legend(fontsize=6.5, loc="lower left")
    np.atleast_1d(axes)[0].set_ylabel(r"$F_F$ (N)")
    fig.suptitle(f"{experiment.figure} analogue: f = {experiment.vibration_frequency_Hz:g} Hz, "
                 f"F_N = p S = {experiment.normal_force_N:.1f} N, k_t = "
                 f"{experiment.contact_stiffness_N_per_m / N_PER_UM:g} N/um, "
                 f"m = {experiment.mass_kg:g} kg", fontsize=10)
    write_csv(out / f"{experiment.name}_experiment_traces.csv",
              rows=_trace_rows(main, _case_label))
    save_figure(fig, out / f"{experiment.name}_experiment_traces.png")
    return ExperimentTraces(traces=main, alternative_normal_force=alt)


def fig_experiment_master(config: StudyConfig, out: Path, progress: Progress | None = None,
                          experiment: ExperimentConfig = EXPERIMENT_FIG14) -> list[MasterPoint]:
    """Fig. 14 analogue: master curves of the four laws at the experiment's configuration."""
    base = experiment_base(config, experiment)
    points = compute_master(config, base, LAWS, config.experiment_kappas,
                            contact_stiffness_N_per_m=experiment.contact_stiffness_N_per_m,
                            progress=progress)
    write_csv(out / f"{experiment.name}_experiment_master.csv", rows=[p.row() for p in points])
    alpha = config.friction.alpha if config.friction is not None else 1.0
    plot_master(points, LAWS, out / f"{experiment.name}_experiment_master.png", alpha=alpha,
                title=(f"{experiment.figure} analogue: f = {experiment.vibration_frequency_Hz:g}"
                       f" Hz, v_d = {experiment.drive_velocity_m_per_s / MM_PER_S:g} mm/s, "
                       f"F_N = {experiment.normal_force_N:.1f} N, k_t = "
                       f"{experiment.contact_stiffness_N_per_m / N_PER_UM:g} N/um"))
    return points


__all__ = [
    "MasterPoint", "compute_master", "curve", "plot_master", "fig_master_curves",
    "compute_time_traces", "plot_time_traces", "fig_time_traces", "fig_hysteresis",
    "fig_profiles", "StiffnessStudy", "fig_stiffness", "ExperimentTraces",
    "fig_experiment_traces", "fig_experiment_master", "TRACE_FIGURE_NAMES",
]
