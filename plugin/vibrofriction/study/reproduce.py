"""One call that regenerates every computational figure of the paper and the claims summary."""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from . import builtin, figures
from ..provenance import json_text
from .claims import Claim, StudyResults, write_summary
from .config import StudyConfig
from .output import StageLog, write_csv
from .sweep import SweepGrid, plot_sweep, run_sweep

DEFAULT_OUT = Path("vibrofriction-results")


def study_config(quick: bool, **changes: Any) -> StudyConfig:
    """The study's configuration, quick or full, with fields replaced.

    Parameters
    ----------
    quick : bool
        ``StudyConfig.quick_config()`` (small grids) instead of ``StudyConfig.full()``.
    **changes
        ``StudyConfig`` fields to replace, e.g. ``rig``, ``friction``, ``timestep_s`` (s),
        ``method``.

    Returns
    -------
    StudyConfig
        The configuration.
    """
    config = StudyConfig.quick_config() if quick else StudyConfig.full()
    return replace(config, **changes) if changes else config


def comparison_config(quick: bool, costs: bool = False) -> builtin.ComparisonConfig:
    """The comparison's grids, with the variants this MuJoCo can build (builtin.md names any
    left out). ``costs``: also the converged master curve's cost by each route
    (compare-builtin's; reproduce leaves out these minutes of CPU its own numbers do not
    need)."""
    variants = builtin.available_variants(builtin.ComparisonConfig().variants)
    if not quick:
        full = builtin.ComparisonConfig(variants=variants)
        return full if costs else replace(full, cost_kappas=())
    return builtin.ComparisonConfig(variants=variants, operating_kappas=(1.5, 6.0),
                                    ladder_steps=(25, 50, 200), master_kappas=(1.0, 1.5, 6.0),
                                    master_steps=50,
                                    cost_kappas=(1.5, 6.0, 24.0) if costs else (),
                                    cost_refinements=1)


def reproduce(out: Path = DEFAULT_OUT, *, config: StudyConfig | None = None,
              scheduler: Any = None, with_builtin: bool = True, with_sweep: bool = True,
              quiet: bool = False, command: str = "vibrofriction reproduce"
              ) -> tuple[StudyResults, list[Claim]]:
    """Run the whole study into ``out``; returns the results and the claims."""
    config = config or StudyConfig.full()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    stages = 8 + int(with_sweep) + int(with_builtin)
    log = StageLog(stages, quiet=quiet)
    start = time.perf_counter()
    log.stage("Figs. 7-9: time traces, Dahl and Coulomb at v_a = 0.25, 0.75, 3.0 mm/s")
    traces = figures.fig_time_traces(config, out, log.progress("runs"))
    log.stage("Fig. 10: F_F against z (Dahl)")
    figures.fig_hysteresis(traces, out)
    log.stage("Fig. 11: F_F profiles")
    profiles = figures.fig_profiles(config, out, log.progress("runs"))
    log.stage(f"master curves, four laws, {len(config.kappas)} values of kappa_v "
              "(+ kinematic limits)")
    master = figures.fig_master_curves(config, out, log.progress("runs"))
    log.stage(f"Fig. 12: k_t influence ({len(config.stiffness_values_N_per_m)} values)")
    stiffness = figures.fig_stiffness(config, out, log.progress("k_t values"))
    log.stage("Fig. 13 analogue: experimental configuration 1, four laws")
    fig13 = figures.fig_experiment_traces(config, out, log.progress("runs"))
    log.stage("Fig. 14 analogue: experimental configuration 2, four laws, v_a swept")
    fig14 = figures.fig_experiment_master(config, out, log.progress("runs"))
    sweep = None
    if with_sweep:
        grid = SweepGrid.from_config(config)
        log.stage(f"grid sweep: {grid.size} runs over v_a x f x k_t x F_N "
                  f"({'dask at ' + str(scheduler) if scheduler else 'local threads'})")
        sweep = run_sweep(grid, config, scheduler=scheduler, progress=log.progress("runs"))
        write_csv(out / "grid_sweep.csv", rows=[r.row() for r in sweep.records])
        plot_sweep(sweep, out / "grid_sweep.png")
    if with_builtin:
        cmp_config = comparison_config(config.quick)
        log.stage(f"built-in friction: {len(cmp_config.variants)} variants, timestep ladder "
                  f"{list(cmp_config.ladder_steps)} steps per period")
        comparison = builtin.compare(config, cmp_config, progress=log.progress)
        builtin.write_comparison(comparison, out)
        (out / "builtin.json").write_text(json_text(comparison_json(comparison)))
    files = sorted(p.name for p in out.iterdir() if p.suffix in (".png", ".csv", ".md", ".json"))
    results = StudyResults(config=config, traces=traces, profiles=profiles, master=master,
                           stiffness=stiffness, fig13=fig13, fig14=fig14, sweep=sweep,
                           command=command, wall_s=time.perf_counter() - start,
                           files=sorted(set(files) | {"summary.md", "claims.json"}))
    log.stage("summary.md and claims.json")
    claims = write_summary(results, out)
    return results, claims


def comparison_json(result: builtin.Comparison) -> dict[str, Any]:
    """The content of builtin.json: the comparison's settings, each variant's static drive
    force (N), the variants not run, each variant's row (ratios, errors, timesteps in s, wall
    and CPU times in s, None where not measured) and the converged-curve costs."""
    def clean(v):
        return None if v is None or v != v else v
    return {
        "frequency_Hz": result.frequency_Hz, "duration_s": result.duration_s,
        "operating_kappas": list(result.config.operating_kappas),
        "ladder_steps_per_period": list(result.config.ladder_steps),
        "master_steps_per_period": result.config.master_steps,
        "tolerance": result.config.tolerance,
        "static_drive_force_N": result.static,
        "variants_not_run": builtin.unavailable_variants(),
        "variants": [{
            "variant": r.variant, "element": r.element, "target": r.target,
            "ratios": {f"{k:g}": v for k, v in r.ratios.items()},
            "sign_change": {f"{k:g}": v for k, v in r.sign_change.items()},
            "errors_vs_target": {f"{k:g}": v for k, v in r.errors_vs_target.items()},
            "errors_vs_own": {f"{k:g}": v for k, v in r.errors_vs_own.items()},
            "dt_own_s": r.dt_own_s, "dt_target_s": r.dt_target_s,
            "wall_own_s": clean(r.wall_own_s), "wall_target_s": clean(r.wall_target_s),
            "cpu_own_s": clean(r.cpu_own_s), "cpu_target_s": clean(r.cpu_target_s),
        } for r in result.rows],
        "converged_costs": result.costs,
    }


__all__ = ["reproduce", "study_config", "comparison_config", "comparison_json", "DEFAULT_OUT"]
