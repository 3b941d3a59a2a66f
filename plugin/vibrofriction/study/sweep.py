"""Large parameter sweeps of the rig: a grid over v_a x f x k_t x F_N.

Runs locally on MuJoCo's rollout threads by default; with ``scheduler="HOST:PORT"`` (or a
``dask.distributed.Client``) the same chunks go to an existing Dask cluster. Dask is an
optional extra (``pip install vibrofriction[dask]``) and is imported only then.

Both paths run identical chunks, each case to its own steady state (``steady``), so each
case's result depends only on its own parameters and a distributed sweep returns the same
numbers as the local one.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Any

from ..errors import InputError
from ..rigs.sweep import DaskUnavailable, joint_convergence  # noqa: F401 (re-exported)
from .config import STATIC_TIMESTEP_S, StudyConfig, friction_for, study_timestep
from .runner import DEFAULT_CHUNK_SIZE, Case, Progress, run_points


@dataclass(frozen=True)
class SweepGrid:
    """The grid: every combination of the four axes (v_a as kappa_v = v_a / v_d)."""

    kappas: tuple[float, ...]
    vibration_frequencies_Hz: tuple[float, ...]
    contact_stiffnesses_N_per_m: tuple[float, ...]
    normal_forces_N: tuple[float, ...]
    law: str = "dahl"

    @classmethod
    def from_config(cls, config: StudyConfig, law: str = "dahl") -> "SweepGrid":
        return cls(kappas=tuple(config.sweep_kappas),
                   vibration_frequencies_Hz=tuple(config.sweep_frequencies_Hz),
                   contact_stiffnesses_N_per_m=tuple(config.sweep_stiffnesses_N_per_m),
                   normal_forces_N=tuple(config.sweep_normal_forces_N), law=law)

    @property
    def size(self) -> int:
        return (len(self.kappas) * len(self.vibration_frequencies_Hz)
                * len(self.contact_stiffnesses_N_per_m) * len(self.normal_forces_N))


@dataclass(frozen=True)
class SweepRecord:
    """One point of the grid sweep: its kappa_v and parameters, the mean drive force with and
    without vibration, the mean, minimum and maximum friction force (all forces in N), whether
    F_F changes sign, and the convergence (``estimated_remaining_error``: relative)."""

    kappa: float
    vibration_velocity_amplitude_m_per_s: float
    vibration_frequency_Hz: float
    contact_stiffness_N_per_m: float
    normal_force_N: float
    friction_coefficient: float
    timestep_s: float
    mean_drive_force_N: float
    static_drive_force_N: float
    mean_friction_force_N: float
    friction_min_N: float
    friction_max_N: float
    sign_change: bool
    converged: bool  # the run and its static run reached steady state
    estimated_remaining_error: float

    @property
    def ratio(self) -> float:
        return self.mean_drive_force_N / self.static_drive_force_N

    def row(self) -> dict[str, object]:
        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["ratio"] = self.ratio
        return out


@dataclass(frozen=True)
class SweepResult:
    """A grid sweep: the grid, one record per vibrating case (``grid_cases`` order), the engine
    that ran it (local rollout threads or Dask) and the wall time of its runs (s)."""

    grid: SweepGrid
    records: list[SweepRecord]
    engine: str
    wall_s: float


def grid_cases(grid: SweepGrid, config: StudyConfig) -> tuple[list[Case], list[Case]]:
    """(vibrating cases, static cases): the static rig of each (f, k_t, F_N) once."""
    cases: list[Case] = []
    statics: list[Case] = []
    for f, kt, fn in itertools.product(grid.vibration_frequencies_Hz,
                                       grid.contact_stiffnesses_N_per_m, grid.normal_forces_N):
        base = replace(config.rig, vibration_frequency_Hz=f, normal_force_N=fn,
                       vibration_velocity_amplitude_m_per_s=0.0).validate()
        friction = friction_for(grid.law, base, contact_stiffness_N_per_m=kt,
                                base=config.friction)
        statics.append((base, friction))
        for kappa in grid.kappas:
            r = replace(base, vibration_velocity_amplitude_m_per_s=kappa
                        * base.drive_velocity_m_per_s).validate()
            cases.append((r, friction))
    return cases, statics


def run_sweep(grid: SweepGrid, config: StudyConfig, *, scheduler: Any = None,
              chunk_size: int = DEFAULT_CHUNK_SIZE, progress: Progress | None = None
              ) -> SweepResult:
    """Run the grid (and its static runs); local unless ``scheduler`` is given."""
    if grid.size == 0:
        raise InputError("the sweep grid is empty")
    cases, statics = grid_cases(grid, config)
    start = time.perf_counter()
    points = run_points(cases, config, scheduler=scheduler, chunk_size=chunk_size,
                        progress=progress)
    static_runs = run_points(statics, config, timesteps=[STATIC_TIMESTEP_S] * len(statics),
                             scheduler=scheduler, chunk_size=chunk_size)
    wall = time.perf_counter() - start
    engine = ("local rollout threads" if scheduler is None else
              f"dask ({scheduler if isinstance(scheduler, str) else 'client'})")
    per_static = len(grid.kappas)
    records = []
    for i, ((r, f), p) in enumerate(zip(cases, points)):
        static = static_runs[i // per_static]
        converged, remaining = joint_convergence(p, static)
        s = p.summary
        records.append(SweepRecord(
            kappa=r.kappa, vibration_velocity_amplitude_m_per_s=r.vibration_velocity_amplitude_m_per_s,
            vibration_frequency_Hz=r.vibration_frequency_Hz,
            contact_stiffness_N_per_m=f.contact_stiffness_N_per_m,
            normal_force_N=r.normal_force_N, friction_coefficient=f.friction_coefficient,
            timestep_s=p.timestep_s, mean_drive_force_N=s.mean_drive_force_N,
            static_drive_force_N=static.mean_drive_force_N,
            mean_friction_force_N=s.mean_friction_force_N, friction_min_N=s.friction_min_N,
            friction_max_N=s.friction_max_N, sign_change=bool(s.sign_change),
            converged=converged, estimated_remaining_error=remaining))
    return SweepResult(grid=grid, records=records, engine=engine, wall_s=wall)


def plot_sweep(result: SweepResult, path, *, title: str | None = None):
    """Ratio against kappa_v for every (f, k_t, F_N), coloured by the amplitude ratio
    epsilon = k_t u0 / (mu F_N) at kappa_v = 1 (vibration amplitude over pre-slip length)."""
    from .output import new_figure, save_figure
    import matplotlib
    fig = new_figure(6.4, 4.0)
    ax = fig.subplots()
    groups: dict[tuple, list[SweepRecord]] = {}
    for rec in result.records:
        groups.setdefault((rec.vibration_frequency_Hz, rec.contact_stiffness_N_per_m,
                           rec.normal_force_N), []).append(rec)
    eps = {}
    for key, recs in groups.items():
        f, kt, fn = key
        vd = recs[0].vibration_velocity_amplitude_m_per_s / recs[0].kappa
        u0 = vd / (2 * math.pi * f)
        eps[key] = kt * u0 / (recs[0].friction_coefficient * fn)
    lo, hi = min(eps.values()), max(eps.values())
    cmap = matplotlib.colormaps["viridis"]
    norm = matplotlib.colors.LogNorm(vmin=lo, vmax=hi if hi > lo else lo * 1.01)
    for key, recs in groups.items():
        recs = sorted(recs, key=lambda r: r.kappa)
        ax.plot([r.kappa for r in recs], [r.ratio for r in recs], "o-", ms=2.5, lw=0.8,
                color=cmap(norm(eps[key])))
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=ax, label=r"$\varepsilon_1 = k_t v_d / (2\pi f\,\mu F_N)$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"$\kappa_v$")
    ax.set_ylabel(r"$F_{d\text{-}v}/F_{d\text{-}s}$")
    ax.axvline(1, color="0.8", lw=0.8)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.set_title(title or (f"{result.grid.law}: grid of {len(result.records)} runs over "
                           "v_a x f x k_t x F_N"), fontsize=9)
    return save_figure(fig, path)


__all__ = ["SweepGrid", "SweepRecord", "SweepResult", "grid_cases", "run_sweep", "plot_sweep",
           "DaskUnavailable", "DEFAULT_CHUNK_SIZE", "study_timestep"]
