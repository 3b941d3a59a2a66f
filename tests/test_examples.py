"""Every script in examples/ runs as a user would run it, and prints what it promises."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
# What each example's output must show (the numbers' meaning, checked loosely: the physics
# is tested elsewhere).
EXPECTED = {
    "add_friction_to_your_scene.py": r"friction 4\.9\d* N",
    "sweep_master_curve.py": r"kappa 40\.0\): F_dv/F_ds = 0\.0",
    "identify_a_record.py": r"mu 0\.21\d* \(true 0\.21\), effects selected: none",
    "robot_push.py": r"vibration on : part moved",
    "gym_style_env.py": r"vibration gate 1: part moved",
    "own_effect.py": r"selected: run_in\n.*run_in_excess = 0\.1[45]",
    "fit_with_mujoco_sysid.py": r"mu 0\.1700 \(true 0\.17\), contact stiffness 60\.00 N/um",
    # (the batched extra absent: the example says why it skipped)
    "batched_feeder_env.py": r"conveying speed after 200 ms: 7\.0\d* mm/s|skipped: ",
}
NEEDS_MUJOCO_SYSID = {"fit_with_mujoco_sysid.py"}


def _mujoco_sysid_installed() -> bool:
    try:
        from mujoco import sysid
    except ImportError:
        return False
    return hasattr(sysid, "optimize")  # it imports empty without mujoco's sysid extra


def test_every_example_is_checked():
    if not EXAMPLES.is_dir():
        pytest.skip("examples/ is not in this checkout")
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_example_runs(name):
    path = EXAMPLES / name
    if not path.is_file():
        pytest.skip("examples/ is not in this checkout")
    if name in NEEDS_MUJOCO_SYSID and not _mujoco_sysid_installed():
        pytest.skip('mujoco.sysid is not installed (pip install ".[test]" brings mujoco[sysid])')
    run = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    assert re.search(EXPECTED[name], run.stdout), run.stdout
