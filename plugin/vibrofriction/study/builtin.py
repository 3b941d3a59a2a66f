"""The paper's rig with MuJoCo's own friction elements, beside the vibrofriction plugin.

Each built-in variant is made by editing the rig scene with MjSpec: the friction plugin's
actuator, sensor and instance are removed (the support and drive-end motion plugins stay), and
one built-in element is added on the slider:

* ``frictionloss-default`` -- joint ``frictionloss = mu F_N`` on ``slider_on_table`` with the
  default ``solreffriction`` (0.02 s, 1);
* ``frictionloss-tight`` -- the same with ``solreffriction="2e-6 1"`` (MuJoCo's ``refsafe``
  raises the time constant to 2 dt);
* ``contact-default`` / ``contact-tight`` -- box-on-box contact friction (condim 3, pyramidal
  cone, geom friction mu): the slider box rests on the table box under gravity (9.81 m/s^2) on
  an added vertical slide joint, an external load F_N - m g on that joint brings the normal
  force to F_N, ``filterparent`` is disabled so the parent table and child slider collide;
  default ``solref`` (0.02 s, 1) or ``solref="2e-6 1"``;
* ``dcmotor-lugre`` -- a passive ``dcmotor`` (input none, motorconst 0, resistance 1) with
  ``lugre="k_t sigma1 mu F_N mu F_N v_s"``: MuJoCo's native LuGre on the same joint;
* ``springyield`` -- joint spring ``stiffness = k_t`` with ``springyield = mu F_N / k_t``: the
  ideal elastic-plastic (Jenkins) contact spring.

The friction force of a built-in variant is F_F = F_d - m a (the slider's equation of motion,
eq. 2; ``a`` from the accelerometer), whose mean over whole periods equals the mean drive force.
"""
from __future__ import annotations

import functools
import math
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from .. import sim
from ..rigs import rig as rig_module
from ..params import FrictionParameters, ParameterError, RigParameters
from ..summary import RunSummary, summarize
from .config import MM_PER_S, STATIC_TIMESTEP_S, StudyConfig, period_timestep
from .output import new_figure, save_figure, write_csv
from .runner import Progress

GRAVITY_M_PER_S2 = 9.81
TIGHT_SOLREF = (2e-6, 1.0)  # frictionloss near rigid Coulomb (docs/physics.md, built-in friction)
# mjINPUT_NONE (mjtCtrlInput): a dcmotor without control inputs, a purely passive device.
_DCMOTOR_INPUT_NONE = 16


@dataclass(frozen=True)
class Variant:
    """One way of putting friction into the rig."""

    name: str
    element: str  # what MuJoCo element provides the friction
    law: str  # FrictionParameters law whose numbers it takes
    target: str  # name of the variant that is the physically matching plugin law
    builtin: bool


VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("plugin-coulomb", "vibrofriction.friction law=coulomb (stick solve)", "coulomb",
            "plugin-coulomb", False),
    Variant("plugin-dahl", "vibrofriction.friction law=dahl", "dahl", "plugin-dahl", False),
    Variant("plugin-lugre", "vibrofriction.friction law=lugre", "lugre", "plugin-lugre", False),
    Variant("plugin-dupont-jenkins", "vibrofriction.friction law=dupont, z_ba/z_ss = 0.99",
            "dupont", "plugin-dupont-jenkins", False),
    Variant("frictionloss-default", "joint frictionloss, solreffriction 0.02 1 (default)",
            "coulomb", "plugin-coulomb", True),
    Variant("frictionloss-tight", "joint frictionloss, solreffriction 2e-6 1", "coulomb",
            "plugin-coulomb", True),
    Variant("contact-default", "box-on-box contact, condim 3, solref 0.02 1 (default)",
            "coulomb", "plugin-coulomb", True),
    Variant("contact-tight", "box-on-box contact, condim 3, solref 2e-6 1", "coulomb",
            "plugin-coulomb", True),
    Variant("dcmotor-lugre", "dcmotor input=none lugre=...", "lugre", "plugin-lugre", True),
    Variant("springyield", "joint stiffness k_t + springyield mu F_N/k_t (Jenkins)", "dupont",
            "plugin-dupont-jenkins", True),
)}
BUILTIN_VARIANTS = tuple(n for n, v in VARIANTS.items() if v.builtin)
PLUGIN_VARIANTS = tuple(n for n, v in VARIANTS.items() if not v.builtin)
# The Jenkins element is Dupont's law with z_ba -> z_max (docs/physics.md); 0.99 is the closest the
# plugin allows (breakaway_ratio < 1).
JENKINS_BREAKAWAY_RATIO = 0.99


@functools.lru_cache(maxsize=None)
def _missing_builtins() -> tuple[tuple[str, str], ...]:
    missing = []
    if not hasattr(mujoco.MjSpec().worldbody.add_body().add_joint(), "springyield"):
        missing.append(("springyield", "joint attribute springyield"))
    spec = mujoco.MjSpec()
    spec.worldbody.add_body(name="b").add_joint(name="j", type=mujoco.mjtJoint.mjJNT_SLIDE)
    spec.body("b").add_geom(size=[0.1, 0, 0])
    try:
        actuator = spec.add_actuator(target="j", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        error = actuator.set_to_dcmotor(motorconst=[0.0, 0.0], resistance=1.0,
                                        lugre=[1e5, 0.0, 1.0, 1.0, 1e-3],
                                        ctrlspec=_DCMOTOR_INPUT_NONE)
        if error:
            raise ValueError(error)
        spec.compile()
    except (AttributeError, TypeError, ValueError) as exc:
        missing.append(("dcmotor-lugre", f"a passive dcmotor with LuGre friction ({exc})"))
    return tuple(missing)


def unavailable_variants() -> dict[str, str]:
    """Built-in variants the installed MuJoCo cannot build, with what it lacks (MuJoCo 4.0
    added both joint springyield and the passive LuGre dcmotor)."""
    return dict(_missing_builtins())


def available_variants(names: Sequence[str]) -> tuple[str, ...]:
    """Those of ``names`` that the installed MuJoCo can build (``unavailable_variants`` left
    out), in their order."""
    missing = unavailable_variants()
    return tuple(n for n in names if n not in missing)


def variant_friction(variant: Variant, rig: RigParameters, config: StudyConfig
                     ) -> FrictionParameters:
    """The friction parameters whose numbers a variant takes.

    Parameters
    ----------
    variant : Variant
        The variant; its ``law`` names the plugin law whose parameters it uses.
    rig : RigParameters
        The rig (SI units); LuGre's default bristle damping follows its mass.
    config : StudyConfig
        The study, whose ``friction_for`` gives the law's parameters.

    Returns
    -------
    FrictionParameters
        The study's parameters of the law; for Dupont with ``breakaway_ratio`` 0.99
        (``JENKINS_BREAKAWAY_RATIO``: the closest the plugin allows to the Jenkins element).
    """
    friction = config.friction_for(variant.law, rig)
    if variant.law == "dupont":
        friction = replace(friction, breakaway_ratio=JENKINS_BREAKAWAY_RATIO).validate()
    return friction


def _strip_friction_plugin(spec: mujoco.MjSpec) -> None:
    spec.delete(spec.actuator("friction"))
    spec.delete(spec.sensor("friction_state"))
    for plugin in list(spec.plugins):
        if plugin.name == "friction":
            spec.delete(plugin)


def build_variant_spec(name: str, rig: RigParameters, config: StudyConfig,
                       timestep_s: float) -> mujoco.MjSpec:
    """MjSpec of the rig with the friction of variant ``name``."""
    variant = VARIANTS[name]
    friction = variant_friction(variant, rig, config)
    if not variant.builtin:
        return rig_module.build_spec(rig, friction, timestep_s)
    # Start from the Coulomb scene with all rig numbers applied, then swap the friction.
    spec = rig_module.build_spec(rig, replace(friction, law="coulomb"), timestep_s)
    _strip_friction_plugin(spec)
    mu, fn = friction.friction_coefficient, rig.normal_force_N
    joint = spec.joint("slider_on_table")
    if name.startswith("frictionloss"):
        joint.frictionloss = mu * fn
        if name == "frictionloss-tight":
            joint.solref_friction = list(TIGHT_SOLREF)
    elif name.startswith("contact"):
        _add_contact(spec, rig, mu, tight=(name == "contact-tight"))
    elif name == "dcmotor-lugre":
        actuator = spec.add_actuator(name="lugre", target="slider_on_table",
                                     trntype=mujoco.mjtTrn.mjTRN_JOINT)
        g = mu * fn
        error = actuator.set_to_dcmotor(
            motorconst=[0.0, 0.0], resistance=1.0,
            lugre=[friction.contact_stiffness_N_per_m, friction.bristle_damping_N_s_per_m, g,
                   g * friction.static_ratio, friction.stribeck_velocity_m_per_s],
            ctrlspec=_DCMOTOR_INPUT_NONE)
        if error:
            raise RuntimeError(f"dcmotor: {error}")
        actuator.damping[0] = friction.viscous_N_s_per_m
    elif name == "springyield":
        joint.stiffness[0] = friction.contact_stiffness_N_per_m
        joint.springyield = mu * fn / friction.contact_stiffness_N_per_m
    else:  # pragma: no cover - VARIANTS and this function list the same names
        raise KeyError(name)
    return spec


def _add_contact(spec: mujoco.MjSpec, rig: RigParameters, mu: float, *, tight: bool) -> None:
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    spec.option.gravity = [0.0, 0.0, -GRAVITY_M_PER_S2]
    slider = spec.body("slider")
    slider.add_joint(name="slider_normal", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1],
                     armature=0.0)
    for geom_name in ("table", "slider"):
        geom = spec.geom(geom_name)
        geom.contype = 1
        geom.conaffinity = 1
        geom.condim = 3
        geom.friction = [mu, 0.0, 0.0]
        if tight:
            geom.solref = list(TIGHT_SOLREF)
    external = rig.normal_force_N - rig.mass_kg * GRAVITY_M_PER_S2
    load = spec.add_actuator(name="normal_load", target="slider_normal",
                             trntype=mujoco.mjtTrn.mjTRN_JOINT)
    load.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    load.gainprm[0] = 0.0
    load.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    load.biasprm[:3] = [-external, 0.0, 0.0]  # constant downward force F_e = F_N - m g


@dataclass(frozen=True)
class VariantRun:
    """One run of a variant: its rig, timestep (s), wall and CPU time (s; NaN where runs
    shared a rollout), the summary, and with ``keep_periods`` the last periods' friction
    force (N) over time (s, from 0), else None."""

    variant: str
    rig: RigParameters
    timestep_s: float
    wall_s: float  # single-thread wall time of the whole run
    cpu_s: float  # CPU time of the calling thread for it (insensitive to other load)
    summary: RunSummary
    time_s: np.ndarray | None = None
    friction_force_N: np.ndarray | None = None


def _friction_series(model: mujoco.MjModel, sensordata: np.ndarray, rig: RigParameters,
                     builtin: bool) -> tuple[np.ndarray, np.ndarray]:
    slices = sim.sensor_slices(model)
    drive = rig_module.drive_force_columns(model, rig, sensordata)
    if builtin:
        accel = sensordata[:, slices["slider_acceleration"]][:, 0]
        return drive, drive - rig.mass_kg * accel
    return drive, sensordata[:, slices["friction_state"]][:, 4]


def run_variants(requests: Sequence[tuple[str, RigParameters, float]], config: StudyConfig, *,
                 keep_periods: int = 0, parallel: bool = True,
                 progress: Progress | None = None) -> list[VariantRun]:
    """Run (variant, rig, timestep) requests. parallel=False runs each on the calling thread
    and times it (the wall times reported); parallel=True runs same-variant, same-timestep
    requests together on rollout threads (no per-run wall time)."""
    times = [rig_module.default_times(r, variant_friction(VARIANTS[v], r, config))
             for v, r, _ in requests]
    duration = max(t[0] for t in times)
    settle = max(t[1] for t in times)
    out: list[VariantRun | None] = [None] * len(requests)
    groups: dict[tuple[str, float], list[int]] = {}
    for i, (v, _, dt) in enumerate(requests):
        groups.setdefault((v, dt) if parallel else (v, dt, i), []).append(i)
    done = 0
    nthread = sim.cpu_count()
    for key, idx in groups.items():
        v, dt = key[0], key[1]
        builtin = VARIANTS[v].builtin
        for start in range(0, len(idx), max(1, 2 * nthread)):
            part = idx[start:start + max(1, 2 * nthread)]
            models = [build_variant_spec(v, requests[i][1], config, dt).compile() for i in part]
            nstep = int(round(duration / dt))
            data = mujoco.MjData(models[0])
            states = np.stack([sim.initial_state(m, data) for m in models])
            threads = min(nthread, len(models)) if parallel and len(models) > 1 else 0
            with mj_rollout.Rollout(nthread=threads) as pool:
                datas = [mujoco.MjData(models[0]) for _ in range(max(1, threads))]
                t0, c0 = time.perf_counter(), time.thread_time()
                _, sensordata = pool.rollout(models, datas, states, nstep=nstep)
                wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
            for k, i in enumerate(part):
                r = requests[i][1]
                drive, friction = _friction_series(models[k], sensordata[k], r, builtin)
                t = np.arange(nstep) * dt
                period = (1.0 / r.vibration_frequency_Hz
                          if r.vibration_velocity_amplitude_m_per_s > 0 else 0.0)
                summary = summarize(t, drive, friction, period, settle)
                keep_t = keep_f = None
                if keep_periods and period > 0:
                    keep = t >= t[-1] - keep_periods * period - 0.5 * dt
                    keep_t, keep_f = t[keep] - t[keep][0], friction[keep].copy()
                out[i] = VariantRun(variant=v, rig=r, timestep_s=dt,
                                    wall_s=wall if len(part) == 1 else math.nan,
                                    cpu_s=cpu if len(part) == 1 and threads == 0 else math.nan,
                                    summary=summary, time_s=keep_t, friction_force_N=keep_f)
            done += len(part)
            if progress:
                progress(done, len(requests))
    return [r for r in out if r is not None]


# ----------------------------------------------------------------------------- the study
@dataclass(frozen=True)
class ComparisonConfig:
    """Grids of the built-in comparison."""

    variants: tuple[str, ...] = PLUGIN_VARIANTS + BUILTIN_VARIANTS
    # Operating points of the timestep study: Fig. 8 (no sign change) and Fig. 9 (sign change).
    operating_kappas: tuple[float, ...] = (1.5, 6.0)
    # Steps per vibration period of the timestep ladder (dt = T / (N + 0.382)); the finest is
    # each variant's "converged" run.
    ladder_steps: tuple[int, ...] = (25, 50, 100, 200, 400, 800)
    master_kappas: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 3.0, 6.0, 12.0, 24.0)
    master_steps: int = 200
    tolerance: float = 0.01
    # The cost of the converged master curve at 1 % per law family (converged_curve_costs):
    # its kappa_v grid (empty: not run), the built-in's refinements of the rule's step, and
    # the product's route (rigs.sweep.run_cases method).
    cost_kappas: tuple[float, ...] = tuple(float(k) for k in np.geomspace(0.5, 50.0, 30))
    cost_refinements: int = 4
    method: str = "auto"

    @classmethod
    def quick(cls) -> "ComparisonConfig":
        return cls(operating_kappas=(1.5, 6.0), ladder_steps=(25, 100, 400),
                   master_kappas=(1.0, 1.5, 6.0), master_steps=100,
                   cost_kappas=(1.5, 6.0, 24.0), cost_refinements=1)


@dataclass(frozen=True)
class LadderResult:
    """One run of the timestep ladder: the variant at kappa_v, N steps per vibration period
    (dt = T/(N + 0.382), in s), its single-thread wall and CPU time (s) and the mean drive
    force (N)."""

    variant: str
    kappa: float
    steps: int
    timestep_s: float
    wall_s: float
    cpu_s: float
    mean_drive_force_N: float


@dataclass(frozen=True)
class VariantSummary:
    """One row of the comparison table."""

    variant: str
    element: str
    target: str
    ratios: dict[float, float]  # kappa -> F_dv/F_ds on the master grid
    sign_change: dict[float, bool]
    errors_vs_target: dict[float, list[float]]  # kappa -> relative error per ladder step
    errors_vs_own: dict[float, list[float]]
    dt_own_s: float | None  # largest ladder dt within tolerance of its own finest run
    dt_target_s: float | None  # ... of the target plugin law's finest run
    wall_own_s: float | None  # single-thread wall time of one run at dt_own_s (max over kappas)
    wall_target_s: float | None
    cpu_own_s: float | None  # its CPU time (the thread's), the load-independent cost
    cpu_target_s: float | None

    def row(self) -> dict[str, object]:
        return {"variant": self.variant, "element": self.element, "target": self.target,
                "dt_own_s": self.dt_own_s, "dt_target_s": self.dt_target_s,
                "wall_own_s": self.wall_own_s, "wall_target_s": self.wall_target_s,
                "cpu_own_s": self.cpu_own_s, "cpu_target_s": self.cpu_target_s,
                **{f"ratio_kappa_{k:g}": v for k, v in self.ratios.items()}}


@dataclass(frozen=True)
class Comparison:
    """The result of ``compare``: the timestep ladder, the master-curve runs, each variant's
    static mean drive force (N), the traces at the operating points, the table rows, the
    vibration frequency (Hz), the simulated time of a run (s) and, where run, the costs of the
    converged master curve (``converged_curve_costs``)."""

    config: ComparisonConfig
    ladder: list[LadderResult]
    master: list[VariantRun]
    static: dict[str, float]
    traces: list[VariantRun]
    rows: list[VariantSummary]
    frequency_Hz: float
    duration_s: float
    costs: dict | None = None  # converged_curve_costs over config.cost_kappas


def _required(errors: Sequence[float], dts: Sequence[float], tol: float, *,
              skip_last: bool) -> float | None:
    """Largest dt (ladder coarse -> fine) from which on every finer dt is within ``tol``;
    ``skip_last``: the finest run is the reference itself and proves nothing."""
    best = None
    last = len(dts) - (2 if skip_last else 1)
    for i in range(last, -1, -1):
        if errors[i] > tol:
            break
        best = dts[i]
    return best


def compare(config: StudyConfig, comparison: ComparisonConfig, *,
            progress: Callable[[str], Progress | None] | None = None) -> Comparison:
    """Ladder, master curves and traces for every variant (see the module docstring)."""
    missing = {v: why for v, why in unavailable_variants().items() if v in comparison.variants}
    if missing:
        raise ParameterError(
            f"MuJoCo {mujoco.__version__} lacks what these variants need: "
            + "; ".join(f"{v}: {why}" for v, why in missing.items())
            + "; use MuJoCo >= 4.0 or leave them out (compare-builtin --variants)")
    base = config.rig
    f = base.vibration_frequency_Hz
    prog = progress or (lambda label: None)
    # 1. Timestep ladder at the operating points, one run at a time (timed).
    requests = []
    for v in comparison.variants:
        for kappa in comparison.operating_kappas:
            r = replace(base, vibration_velocity_amplitude_m_per_s=kappa
                        * base.drive_velocity_m_per_s)
            for n in comparison.ladder_steps:
                requests.append((v, r, period_timestep(f, n)))
    runs = run_variants(requests, config, parallel=False, progress=prog("timestep ladder"))
    ladder = []
    for (v, r, dt), run in zip(requests, runs):
        ladder.append(LadderResult(variant=v, kappa=r.kappa, steps=int(round(
            1 / (f * dt))), timestep_s=dt, wall_s=run.wall_s, cpu_s=run.cpu_s,
            mean_drive_force_N=run.summary.mean_drive_force_N))
    # 2. Master curves at a common fine step, and the static runs (F_d-s).
    master_dt = period_timestep(f, comparison.master_steps)
    master_requests = []
    for v in comparison.variants:
        for kappa in comparison.master_kappas:
            master_requests.append((v, replace(base, vibration_velocity_amplitude_m_per_s=kappa
                                               * base.drive_velocity_m_per_s), master_dt))
    static_requests = [(v, replace(base, vibration_velocity_amplitude_m_per_s=0.0),
                        STATIC_TIMESTEP_S if not VARIANTS[v].builtin else master_dt)
                       for v in comparison.variants]
    master = run_variants(master_requests, config, parallel=True,
                          progress=prog("master curves"))
    static_runs = run_variants(static_requests, config, parallel=True)
    static = {run.variant: run.summary.mean_drive_force_N for run in static_runs}
    # 3. Traces at the operating points.
    trace_requests = [(v, replace(base, vibration_velocity_amplitude_m_per_s=kappa
                                  * base.drive_velocity_m_per_s), master_dt)
                      for v in comparison.variants for kappa in comparison.operating_kappas]
    traces = run_variants(trace_requests, config, parallel=True, keep_periods=2,
                          progress=prog("traces"))
    rows = _summaries(comparison, ladder, master, static)
    duration = rig_module.default_times(base, config.friction_for("coulomb", base))[0]
    costs = None
    laws = [law for law, v in PLUGIN_OF_LAW.items() if v in comparison.variants]
    if comparison.cost_kappas and laws:
        # 4. What the converged curve costs by each route (the converged curve: the product's
        # own route at a quarter of the rule's step, validated against transients in tests)
        report = prog("converged master curves")
        costs = converged_curve_costs(
            config, comparison.cost_kappas, laws=laws, truth_method=comparison.method,
            method=comparison.method, builtin_refinements=comparison.cost_refinements,
            variants=comparison.variants,
            log=(lambda text: _cost_line(text, report, laws)) if report else None)
    return Comparison(config=comparison, ladder=ladder, master=master, static=static,
                      traces=traces, rows=rows, frequency_Hz=f, duration_s=duration,
                      costs=costs)


def _cost_line(text: str, report: Progress, laws: Sequence[str]) -> None:
    """A stage of the converged-cost measurement on stderr (each within ~25 s of the last),
    and the laws done on the progress bar."""
    print(f"  {text}", file=sys.stderr, flush=True)
    report(laws.index(text.split(":")[0]) + 1, len(laws))


def _summaries(comparison: ComparisonConfig, ladder: Sequence[LadderResult],
               master: Sequence[VariantRun], static: dict[str, float]) -> list[VariantSummary]:
    tol = comparison.tolerance
    rows = []
    for v in comparison.variants:
        variant = VARIANTS[v]
        errs_own: dict[float, list[float]] = {}
        errs_target: dict[float, list[float]] = {}
        walls: dict[float, list[float]] = {}
        cpus: dict[float, list[float]] = {}
        dts: list[float] = []
        for kappa in comparison.operating_kappas:
            mine = [x for x in ladder if x.variant == v and math.isclose(x.kappa, kappa)]
            mine.sort(key=lambda x: -x.timestep_s)
            dts = [x.timestep_s for x in mine]
            own_ref = mine[-1].mean_drive_force_N
            target = [x for x in ladder if x.variant == variant.target
                      and math.isclose(x.kappa, kappa)]
            target_ref = min(target, key=lambda x: x.timestep_s).mean_drive_force_N
            errs_own[kappa] = [abs(x.mean_drive_force_N / own_ref - 1) for x in mine]
            errs_target[kappa] = [abs(x.mean_drive_force_N / target_ref - 1) for x in mine]
            walls[kappa] = [x.wall_s for x in mine]
            cpus[kappa] = [x.cpu_s for x in mine]
        worst_own = [max(errs_own[k][i] for k in errs_own) for i in range(len(dts))]
        worst_target = [max(errs_target[k][i] for k in errs_target) for i in range(len(dts))]
        dt_own = _required(worst_own, dts, tol, skip_last=True)
        is_target = variant.target == v
        dt_target = dt_own if is_target else _required(worst_target, dts, tol,
                                                       skip_last=False)

        def at(table, dt):
            if dt is None:
                return None
            i = dts.index(dt)
            return max(table[k][i] for k in table)
        ratios = {}
        signs = {}
        for run in master:
            if run.variant == v:
                ratios[run.rig.kappa] = run.summary.mean_drive_force_N / static[v]
                signs[run.rig.kappa] = run.summary.sign_change
        rows.append(VariantSummary(
            variant=v, element=variant.element, target=variant.target, ratios=ratios,
            sign_change=signs, errors_vs_target=errs_target, errors_vs_own=errs_own,
            dt_own_s=dt_own, dt_target_s=dt_target, wall_own_s=at(walls, dt_own),
            wall_target_s=at(walls, dt_target), cpu_own_s=at(cpus, dt_own),
            cpu_target_s=at(cpus, dt_target)))
    return rows


# ----------------------------------------------------------------------------- outputs
VARIANT_STYLE = {
    "plugin-coulomb": dict(color="k", lw=1.6),
    "plugin-dahl": dict(color="tab:blue", lw=1.6),
    "plugin-lugre": dict(color="tab:orange", lw=1.6),
    "plugin-dupont-jenkins": dict(color="tab:green", lw=1.6),
    "frictionloss-default": dict(color="tab:red", lw=1, ls="--"),
    "frictionloss-tight": dict(color="tab:red", lw=1, ls="-", marker="s", ms=3),
    "contact-default": dict(color="tab:purple", lw=1, ls="--"),
    "contact-tight": dict(color="tab:purple", lw=1, ls="-", marker="^", ms=3),
    "dcmotor-lugre": dict(color="tab:brown", lw=1, ls="-", marker="o", ms=3),
    "springyield": dict(color="tab:olive", lw=1, ls="-", marker="d", ms=3),
}


def plot_comparison(result: Comparison, path: Path) -> Path:
    """Plot the comparison in four panels and save it.

    The panels: (a) the master curves, (b) and (c) the friction force over two periods at the
    two operating points, (d) the error of the mean drive force against the target plugin law
    over the timestep ladder.

    Parameters
    ----------
    result : Comparison
        What ``compare`` returned.
    path : Path
        The image file to write (its folder is made).

    Returns
    -------
    Path
        ``path``.
    """
    fig = new_figure(9.0, 6.4)
    grid = fig.subplots(2, 2)
    ax = grid[0, 0]
    for row in result.rows:
        ks = sorted(row.ratios)
        ax.plot(ks, [max(row.ratios[k], 1e-4) for k in ks], label=row.variant,
                **VARIANT_STYLE[row.variant])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(3e-3, 1.5)
    ax.set_xlabel(r"$\kappa_v$")
    ax.set_ylabel(r"$F_{d\text{-}v}/F_{d\text{-}s}$")
    ax.set_title(f"(a) master curves, dt = T/{result.config.master_steps}.4", fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=5.5, ncol=2, loc="lower left")
    for ax, kappa, letter in zip((grid[0, 1], grid[1, 0]), result.config.operating_kappas, "bc"):
        for run in result.traces:
            if math.isclose(run.rig.kappa, kappa) and run.time_s is not None:
                style = dict(VARIANT_STYLE[run.variant])
                style.pop("marker", None)
                style.pop("ms", None)
                if run.variant.startswith("contact"):  # chatters: draw it faint
                    style.update(lw=0.5, alpha=0.35)
                ax.plot(run.time_s * result.frequency_Hz, run.friction_force_N, **style,
                        label=run.variant)
        ax.axhline(0, color="0.7", lw=0.5)
        # Contact friction with a tight solref chatters; clip to keep the others readable.
        level = result.static.get("plugin-coulomb", 0.0)
        if level > 0:
            ax.set_ylim(-1.7 * level, 1.7 * level)
            peaks = {run.variant: float(np.max(np.abs(run.friction_force_N)))
                     for run in result.traces if math.isclose(run.rig.kappa, kappa)
                     and run.friction_force_N is not None}
            clipped = [f"{v} up to {p:.0f} N" for v, p in peaks.items() if p > 1.7 * level]
            if clipped:
                ax.text(0.01, 0.02, "clipped: " + ", ".join(clipped), fontsize=6,
                        transform=ax.transAxes, color="0.3")
        ax.set_xlabel("t / T")
        ax.set_ylabel(r"$F_F$ (N)")
        va = kappa * result.traces[0].rig.drive_velocity_m_per_s / MM_PER_S
        ax.set_title(f"({letter}) F_F at kappa_v = {kappa:g} (v_a = {va:g} mm/s); built-in: "
                     "F_d - m a", fontsize=8)
    ax = grid[1, 1]
    for row in result.rows:
        dts = sorted({x.timestep_s for x in result.ladder if x.variant == row.variant},
                     reverse=True)
        worst = [max(row.errors_vs_target[k][i] for k in row.errors_vs_target)
                 for i in range(len(dts))]
        if row.target == row.variant:  # its finest run is the reference itself
            dts, worst = dts[:-1], worst[:-1]
        style = dict(VARIANT_STYLE[row.variant])
        ax.plot(np.array(dts) * 1e6, np.maximum(worst, 1e-5) * 100, **style, label=row.variant)
    ax.axhline(result.config.tolerance * 100, color="0.5", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.invert_xaxis()
    ax.set_xlabel("timestep (µs)")
    ax.set_ylabel("error of mean F_d vs target (%)")
    ax.set_title("(d) timestep convergence (worst of the operating points)", fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    fig.suptitle("The rig with MuJoCo's built-in friction vs the vibrofriction plugin "
                 f"(f = {result.frequency_Hz:g} Hz)", fontsize=10)
    return save_figure(fig, path)


def _us(dt: float | None) -> str:
    return "not reached" if dt is None else f"{dt * 1e6:.3g} µs"


def _s(seconds: float | None) -> str:
    return "—" if seconds is None or math.isnan(seconds) else f"{seconds:.2f} s"


def comparison_table(result: Comparison) -> str:
    """Markdown table of the comparison (README-ready)."""
    ks = list(result.config.master_kappas)
    shown = [k for k in (1.5, 6.0, 24.0) if k in ks] or ks[:3]
    coarse = result.config.ladder_steps[0]
    head = ("| variant | MuJoCo element | target | "
            + " | ".join(f"F_dv/F_ds κ={k:g}" for k in shown)
            + f" | F_ds (N) | error vs target at T/{coarse} | dt for 1 % (own) | "
            "dt for 1 % (target) | CPU (wall) per run at that dt |")
    sep = "|" + "---|" * (8 + len(shown))
    lines = [head, sep]
    for row in result.rows:
        worst_coarse = max(row.errors_vs_target[k][0] for k in row.errors_vs_target)
        use_target = row.dt_target_s is not None
        wall = row.wall_target_s if use_target else row.wall_own_s
        cpu = row.cpu_target_s if use_target else row.cpu_own_s
        wall_note = "" if row.dt_target_s is not None or row.dt_own_s is None else " (own)"
        ratios = " | ".join(
            f"{row.ratios.get(k, math.nan):.4f}" + (" ±" if row.sign_change.get(k) else "")
            for k in shown)
        lines.append(
            f"| {row.variant} | {row.element} | {row.target} | {ratios} | "
            f"{result.static.get(row.variant, math.nan):.4g} | {worst_coarse * 100:.2g} % | {_us(row.dt_own_s)} | {_us(row.dt_target_s)} | "
            f"{_s(cpu)} ({_s(wall)}){wall_note} |")
    return "\n".join(lines)


def write_comparison(result: Comparison, out: Path) -> dict[str, Path]:
    """Write the comparison's figure, CSV tables and markdown report to a folder.

    Parameters
    ----------
    result : Comparison
        What ``compare`` returned.
    out : Path
        The folder: builtin_comparison.png, builtin_table.csv, builtin_timestep_ladder.csv,
        builtin_master.csv, builtin_traces.csv and builtin.md go in it.

    Returns
    -------
    dict of str to Path
        Each file by its key: png, table_csv, ladder_csv, master_csv, traces_csv, md.
    """
    out = Path(out)
    paths = {}
    paths["png"] = plot_comparison(result, out / "builtin_comparison.png")
    paths["table_csv"] = write_csv(out / "builtin_table.csv",
                                   rows=[r.row() for r in result.rows])
    paths["ladder_csv"] = write_csv(out / "builtin_timestep_ladder.csv", rows=[
        {"variant": x.variant, "kappa": x.kappa, "steps_per_period": x.steps,
         "timestep_s": x.timestep_s, "wall_s": x.wall_s, "cpu_s": x.cpu_s,
         "mean_drive_force_N": x.mean_drive_force_N} for x in result.ladder])
    paths["master_csv"] = write_csv(out / "builtin_master.csv", rows=[
        {"variant": r.variant, "kappa": r.rig.kappa, "timestep_s": r.timestep_s,
         "mean_drive_force_N": r.summary.mean_drive_force_N,
         "static_drive_force_N": result.static[r.variant],
         "ratio": r.summary.mean_drive_force_N / result.static[r.variant],
         "friction_min_N": r.summary.friction_min_N, "friction_max_N": r.summary.friction_max_N,
         "sign_change": r.summary.sign_change} for r in result.master])
    rows = []
    for run in result.traces:
        for t, ff in zip(run.time_s, run.friction_force_N):
            rows.append({"variant": run.variant, "kappa": run.rig.kappa, "time_s": float(t),
                         "friction_force_N": float(ff)})
    paths["traces_csv"] = write_csv(out / "builtin_traces.csv", rows=rows)
    paths["md"] = out / "builtin.md"
    paths["md"].write_text(comparison_markdown(result))
    return paths


def comparison_markdown(result: Comparison) -> str:
    """The text of builtin.md: what was compared and how, the comparison table and, where
    run, the costs of the converged master curve."""
    c = result.config
    f = result.frequency_Hz
    ladder = ", ".join(f"{period_timestep(f, n) * 1e6:.3g}" for n in c.ladder_steps)
    return f"""# MuJoCo's built-in friction in the paper's rig

The rig of Figs. 7-12 (f = {f:g} Hz, v_d = 0.5 mm/s, F_N = 55.2 N, mu = 0.2, k_t = 80 N/um,
k_d = 1e6 N/m) with each friction element in turn. F_dv/F_ds on the master grid is at
dt = T/({c.master_steps} + 0.382); "±" marks a friction force that changes sign (for the
built-in elements F_F = F_d - m a); F_ds is the mean drive force without vibration (mu F_N =
{result.static.get("plugin-coulomb", math.nan):.3g} N for a friction element that holds).

Timestep study: mean drive force over whole periods at kappa_v = {', '.join(f'{k:g}' for k in
c.operating_kappas)} on the ladder dt = {ladder} µs (T/(N + 0.382), N = {', '.join(str(n) for n
in c.ladder_steps)}). The error is |F_d(dt) - F_ref| / F_ref, the worst of the operating
points. **own**: F_ref is the variant's own run at the finest dt (does it converge?);
**target**: F_ref is the finest run of the plugin law it models (Coulomb for frictionloss
and contact, LuGre for dcmotor, Dupont with z_ba/z_ss = 0.99 = Jenkins for springyield) --
does it converge to the right answer? "dt for 1 %" is the largest ladder step from which on
every finer step stays within {c.tolerance * 100:g} %; the cost is the CPU time (and wall
time) of one single-thread run of {result.duration_s * 1e3:.0f} ms of simulated time at that step
(the calling thread's CPU time does not depend on other load on the machine).
{_not_run_note()}
{comparison_table(result)}
{_costs_markdown(result)}"""


def _costs_markdown(result: Comparison) -> str:
    if not result.costs:
        return ""
    c = result.costs
    return f"""
## The converged master curve: what it costs by each route

{len(c['kappas'])} values of kappa_v from {c['kappas'][0]:g} to {c['kappas'][-1]:g} and the
static run, per law family, CPU seconds (single thread, measured side by side in this run) to
every point within {c['accuracy']:.0%} of the converged curve (the plugin at a quarter of the
rule's step, by the {c['truth_method']} route). **periodic**: the product's route (each point's
periodic orbit, `vibrofriction.rigs.periodic`; the transient where none is found);
**transient**: the plugin run from rest until its windows settle; **built-in**: MuJoCo's
element run from rest as long as the plugin's transient of each point, at the coarsest
refinement of the rule's step within {c['accuracy']:.0%}.

{converged_costs_table(c)}
"""


def _not_run_note() -> str:
    missing = unavailable_variants()
    if not missing:
        return ""
    return (f"\nNot run: MuJoCo {mujoco.__version__} lacks "
            + "; ".join(f"{why} ({v})" for v, why in missing.items()) + ".\n")


__all__ = ["Variant", "VARIANTS", "BUILTIN_VARIANTS", "PLUGIN_VARIANTS", "build_variant_spec",
           "unavailable_variants", "available_variants",
           "run_variants", "VariantRun", "ComparisonConfig", "Comparison", "compare",
           "comparison_table", "comparison_markdown", "write_comparison", "plot_comparison",
           "BUILTIN_ROUTES", "converged_curve_costs", "converged_costs_table", "curve_cases"]


# ----------------------------------------------------------------------------- converged cost
# The built-in elements that model each plugin law family (tight settings: the defaults do not
# reach 1 %); Dahl has none.
BUILTIN_ROUTES: dict[str, tuple[str, ...]] = {
    "coulomb": ("frictionloss-tight", "contact-tight"), "lugre": ("dcmotor-lugre",),
    "dupont": ("springyield",)}
PLUGIN_OF_LAW = {"coulomb": "plugin-coulomb", "dahl": "plugin-dahl", "lugre": "plugin-lugre",
                 "dupont": "plugin-dupont-jenkins"}
CURVE_ACCURACY = 0.01
MAX_PLUGIN_REFINEMENTS = 2  # the plugin's timestep: the rule's / 2^j, j <= 2
MAX_BUILTIN_REFINEMENTS = 4  # the built-in's: the rule's / 2^j, j <= 4
TRUTH_REFINEMENT = 2  # the converged curve: the plugin at a quarter of the rule's timestep


def curve_cases(law: str, kappas: Sequence[float], config: StudyConfig) -> list[tuple]:
    """The static run and one run per kappa_v of the plugin law's master curve."""
    base = config.rig
    cases = []
    for kappa in [0.0, *kappas]:
        rig = replace(base, vibration_velocity_amplitude_m_per_s=kappa
                      * base.drive_velocity_m_per_s)
        cases.append((rig, variant_friction(VARIANTS[PLUGIN_OF_LAW[law]], rig, config)))
    return cases


def _timed_curve(cases: list[tuple], refine: int, method: str) -> tuple[list, float]:
    from ..rigs.sweep import run_cases
    dts = [rig_module.recommended_timestep(r) / 2 ** refine for r, _ in cases]
    start = time.process_time()
    runs = run_cases(cases, timesteps=dts, nthread=1, method=method)
    return runs, time.process_time() - start


def _builtin_point(variant: str, run, config: StudyConfig, timestep_s: float
                   ) -> tuple[float, float]:
    """(mean drive force over ``run``'s window, CPU seconds) of a built-in variant run from
    rest to the end of that window (what a user of MuJoCo's element runs to steady state)."""
    from ..rigs.steady import hann_mean
    model = build_variant_spec(variant, run.rig, config, timestep_s).compile()
    data = mujoco.MjData(model)
    state = sim.initial_state(model, data)
    nstep = int(math.ceil(run.summary.window_end_s / timestep_s)) + 2
    start = time.process_time()
    _, sensordata = mj_rollout.rollout(model, data, state[None], nstep=nstep)
    cpu = time.process_time() - start
    drive = rig_module.drive_force_columns(model, run.rig, sensordata[0])
    t = np.arange(nstep) * timestep_s
    if not np.all(np.isfinite(drive)):
        return math.nan, cpu
    return hann_mean(t, drive, run.summary.window_start_s, run.summary.window_end_s), cpu


def converged_curve_costs(config: StudyConfig, kappas: Sequence[float], *,
                          laws: Sequence[str] = ("coulomb", "dahl", "dupont", "lugre"),
                          truth_method: str = "transient", method: str = "auto",
                          builtin_refinements: int = MAX_BUILTIN_REFINEMENTS,
                          variants: Sequence[str] | None = None,
                          log: Callable[[str], None] | None = None) -> dict:
    """CPU time to the converged master curve at CURVE_ACCURACY (every point, the static run
    included, within 1 % of the converged curve: the plugin at a quarter of the rule's
    timestep, run by ``truth_method``), per law family, measured side by side in one process,
    single thread:

    * **periodic**: the product's fastest route (``run_cases`` ``method`` auto: each point's
      periodic orbit, the transient where none is found) at the coarsest refinement of the
      rule's timestep (/2^j, j <= 2) within 1 %;
    * **transient**: the plugin's runs from rest to steady state at that refinement;
    * **built-in**: each MuJoCo element modelling the law, run from rest as long as the
      plugin's transient of that point ran and averaged over the same window, at the coarsest
      refinement of the rule's timestep (/2^j, j <= ``builtin_refinements``) within 1 %; the
      best (cheapest that reaches 1 %) is the law's built-in route (``variants``: the built-in
      elements allowed, default all this MuJoCo has)."""
    say = log or (lambda text: None)
    out: dict = {"kappas": list(kappas), "accuracy": CURVE_ACCURACY, "truth_method": truth_method,
                 "laws": {}}
    started = time.monotonic()

    def stage(text: str) -> None:  # "law: ..." at every stage: no long silence
        say(f"{text} [{time.monotonic() - started:.1f} s]")
    for law in laws:
        cases = curve_cases(law, kappas, config)
        stage(f"{law}: the converged curve ({len(cases)} runs, the plugin at dt/"
              f"{2 ** TRUTH_REFINEMENT}, {truth_method})")
        truth_runs, _ = _timed_curve(cases, TRUTH_REFINEMENT, truth_method)
        truth = [r.mean_drive_force_N for r in truth_runs]

        def error(runs):
            return max(abs(r.mean_drive_force_N / t - 1) for r, t in zip(runs, truth))
        entry: dict = {}
        for refine in range(MAX_PLUGIN_REFINEMENTS + 1):
            runs, cpu = _timed_curve(cases, refine, method)
            stage(f"{law}: {method} route at dt/{2 ** refine}: {cpu:.2f} s CPU, worst error "
                  f"{error(runs):.2%}")
            if error(runs) <= CURVE_ACCURACY or refine == MAX_PLUGIN_REFINEMENTS:
                break
        entry["periodic"] = {
            "cpu_s": cpu, "refinement": refine, "error": error(runs),
            "reached": error(runs) <= CURVE_ACCURACY,
            "periodic_points": sum(r.convergence.method == "periodic" for r in runs),
            "converged": sum(r.convergence.converged for r in runs), "runs": len(runs)}
        transient, t_cpu = _timed_curve(cases, refine, "transient")
        entry["transient"] = {"cpu_s": t_cpu, "refinement": refine, "error": error(transient),
                              "converged": sum(r.convergence.converged for r in transient)}
        say(f"{law}: periodic {cpu:.2f} s CPU at dt/{2 ** refine} (error {error(runs):.2%}, "
            f"{entry['periodic']['periodic_points']} of {len(runs)} points periodic), "
            f"transient {t_cpu:.2f} s")
        routes = []
        allowed = [v for v in BUILTIN_ROUTES.get(law, ()) if variants is None or v in variants]
        for variant in available_variants(allowed):
            for j in range(builtin_refinements + 1):
                b_cpu, worst = 0.0, 0.0
                shown = time.monotonic()
                for k, (run, target) in enumerate(zip(transient, truth)):
                    if time.monotonic() - shown > 25.0:
                        stage(f"{law}: built-in {variant} at dt/{2 ** j}: {k} of "
                              f"{len(truth)} points")
                        shown = time.monotonic()
                    dt = rig_module.recommended_timestep(run.rig) / 2 ** j
                    mean, seconds = _builtin_point(variant, run, config, dt)
                    b_cpu += seconds
                    worst = max(worst, abs(mean / target - 1)) if math.isfinite(mean) \
                        else math.inf
                stage(f"{law}: built-in {variant} at dt/{2 ** j}: {b_cpu:.2f} s CPU, worst "
                      f"error {worst:.2%}")
                if worst <= CURVE_ACCURACY:
                    break
            routes.append({"variant": variant, "cpu_s": b_cpu, "refinement": j,
                           "error": worst, "reached": worst <= CURVE_ACCURACY})
            say(f"{law}: built-in {routes[-1]}")
        entry["builtin_routes"] = routes
        if routes:
            reached = [r for r in routes if r["reached"]]
            best = min(reached or routes, key=lambda r: r["cpu_s"])
            entry["builtin"] = dict(best, ratio=best["cpu_s"] / cpu)
        out["laws"][law] = entry
    return out


def converged_costs_table(costs: dict) -> str:
    """Markdown: per law, CPU to the converged master curve by each route, side by side."""
    acc = costs["accuracy"]
    lines = [f"| law | periodic (product) | transient (product) | best built-in reaching "
             f"{acc:.0%} | built-in / periodic |", "|---|---|---|---|---|"]
    for law, e in costs["laws"].items():
        p, t = e["periodic"], e["transient"]
        b = e.get("builtin")
        built = "none" if b is None else (
            f"{b['variant']}: {b['cpu_s']:.2f} s at dt/{2 ** b['refinement']}"
            + ("" if b["reached"] else f", **not reached** ({b['error']:.1%})"))
        ratio = "-" if b is None else (f"{b['ratio']:.1f}" + ("" if b["reached"] else " (>)"))
        lines.append(
            f"| {law} | {p['cpu_s']:.2f} s at dt/{2 ** p['refinement']} ({p['error']:.2%}; "
            f"{p['periodic_points']}/{p['runs']} periodic) | {t['cpu_s']:.2f} s "
            f"({t['error']:.2%}) | {built} | {ratio} |")
    return "\n".join(lines)
