"""A small grid sweep on a local Dask cluster returns exactly the numbers of the local run."""
from __future__ import annotations

import math

import pytest

distributed = pytest.importorskip(
    "dask.distributed",
    reason="dask.distributed is not installed (optional extra: pip install '.[dask]')")

from vibrofriction.study.config import N_PER_UM, StudyConfig  # noqa: E402
from vibrofriction.study.sweep import SweepGrid, grid_cases, run_sweep  # noqa: E402

# 2 x 2 x 1 x 2 = 8 runs plus 4 static runs; kappa 0.5 and 3 bracket the v_a = v_d criterion.
GRID = SweepGrid(kappas=(0.5, 3.0), vibration_frequencies_Hz=(2600.0, 4000.0),
                 contact_stiffnesses_N_per_m=(80.0 * N_PER_UM,),
                 normal_forces_N=(37.2, 55.2), law="dahl")


@pytest.fixture(scope="module")
def local_result():
    return run_sweep(GRID, StudyConfig.quick_config(), chunk_size=3)


def _assert_same(a, b):
    assert len(a.records) == len(b.records) == GRID.size
    for ra, rb in zip(a.records, b.records):
        assert ra.row() == rb.row()


def test_local_sweep_numbers(local_result):
    cases, statics = grid_cases(GRID, StudyConfig.quick_config())
    assert len(cases) == GRID.size and len(statics) == 4
    by = {(r.kappa, r.vibration_frequency_Hz, r.normal_force_N): r for r in local_result.records}
    for rec in local_result.records:
        # F_d-s is mu F_N (mu = 0.2) to 1e-4; below v_a = v_d nothing is reduced.
        assert math.isclose(rec.static_drive_force_N, 0.2 * rec.normal_force_N, rel_tol=1e-4)
        if rec.kappa < 1:
            assert abs(rec.ratio - 1) < 0.01
            assert not rec.sign_change
        else:
            assert rec.ratio < 0.6
    # kappa 3: the lower normal force has the shorter pre-slip length mu F_N / k_t, so the
    # vibration amplitude is larger relative to it (epsilon = k_t u0 / (mu F_N)) and the
    # reduction is larger.
    assert by[(3.0, 4000.0, 37.2)].ratio < by[(3.0, 4000.0, 55.2)].ratio


def test_dask_local_cluster_equals_local_run(local_result):
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            via_client = run_sweep(GRID, StudyConfig.quick_config(), scheduler=client,
                                   chunk_size=2)
        # The address form (what --scheduler passes), with a different chunking.
        via_address = run_sweep(GRID, StudyConfig.quick_config(),
                                scheduler=cluster.scheduler_address, chunk_size=5)
    assert via_client.engine.startswith("dask")
    _assert_same(local_result, via_client)
    _assert_same(local_result, via_address)


def test_the_sweep_command_on_a_dask_cluster_equals_its_local_run():
    """`vibrofriction sweep --scheduler ADDRESS`: the same JSON as on local threads."""
    from vibrofriction.params import RigParameters, default_friction
    from vibrofriction.rigs.sweep import sweep

    rig = RigParameters()
    settings = dict(timestep_s=1e-5, duration_s=0.04, settle_time_s=0.03, progress=False,
                    warn=False)  # short on purpose: the equality, not the value
    local = sweep(rig, default_friction("dahl", rig), [0.75e-3, 3e-3], **settings)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        remote = sweep(rig, default_friction("dahl", rig), [0.75e-3, 3e-3],
                       scheduler=cluster.scheduler_address, **settings)
    assert remote == local


def test_a_grid_record_carries_the_mean_friction_force_of_its_run_summary(monkeypatch):
    """Each record (and grid_sweep.csv row) has mean_friction_force_N, taken from its run's
    summary, as a `vibrofriction sweep` point has."""
    import vibrofriction.study.sweep as study_sweep

    points = []
    run_points = study_sweep.run_points

    def recording_run_points(*args, **kwargs):
        result = run_points(*args, **kwargs)
        points.extend(result)
        return result

    monkeypatch.setattr(study_sweep, "run_points", recording_run_points)
    one_case = SweepGrid(kappas=(3.0,), vibration_frequencies_Hz=(4000.0,),
                         contact_stiffnesses_N_per_m=(80.0 * N_PER_UM,),
                         normal_forces_N=(55.2,), law="dahl")
    record, = run_sweep(one_case, StudyConfig.quick_config()).records
    vibrating, = [p for p in points if p.rig.vibration_velocity_amplitude_m_per_s > 0]
    assert record.mean_friction_force_N == vibrating.summary.mean_friction_force_N
    assert record.row()["mean_friction_force_N"] == record.mean_friction_force_N
