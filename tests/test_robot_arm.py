"""A real arm with the drop-in elements (``vibrofriction.robots.robot_arm``): dm_control's Kinova Jaco
sets a part on a vibrating inclined plate and picks a part off a vibratory feeder, at its own
1 ms timestep. Checked: the placed part creeps down the slope at the heavy-body value with
vibration and holds without; the feeder conveys the part to the stop, where the arm picks it
and drops it into the tray, and conveys nothing without vibration; the resolved cell steps."""
from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from vibrofriction.params import ParameterError

pytestmark = pytest.mark.skipif(importlib.util.find_spec("dm_control") is None,
                                reason="dm-control (the Kinova Jaco model) is not installed: "
                                       "pip install 'vibrofriction[robots]'")


@pytest.fixture(scope="module")
def robot_arm():
    from vibrofriction.robots import robot_arm
    return robot_arm


@pytest.fixture(scope="module")
def runs(robot_arm):
    return {vibration: robot_arm.run_cell("robot", vibration) for vibration in (True, False)}


def _down_the_slope(robot_arm, run) -> np.ndarray:
    p = run.sensor("plate_part_position")
    tilt = robot_arm.CELL_PLATE_TILT_RAD
    return p[:, 0] * math.cos(tilt) - p[:, 2] * math.sin(tilt)


def test_the_placed_part_creeps_down_the_vibrating_slope_and_holds_without(robot_arm, runs):
    """Set down at about 4.5 s; from 6 s on it creeps at v_a sin(pi/2 tan(theta)/mu), within 2 %
    (the averaged table against the arcsin law), and does not move without vibration."""
    for vibration, run in runs.items():
        assert not run.warnings
        late = run.time_s >= 6.0
        speed = np.polyfit(run.time_s[late], _down_the_slope(robot_arm, run)[late], 1)[0]
        if vibration:
            assert speed == pytest.approx(robot_arm.plate_creep_velocity_m_per_s(), rel=0.02)
        else:
            assert abs(speed) < 1e-6
        # it was carried from the pedestal onto the plate either way
        end = run.sensor("plate_part_position")[-1]
        assert abs(end[1] - robot_arm.PLATE_CENTRE[1]) < 0.02


def test_the_feeder_brings_the_part_the_arm_picks_and_nothing_without_vibration(robot_arm, runs):
    tray = np.array(robot_arm.TRAY_CENTRE[:2])
    on = runs[True].sensor("feeder_part0_position")
    assert np.linalg.norm(on[-1, :2] - tray) < 0.05  # picked at the stop, dropped in the tray
    at_stop = (robot_arm.TRACK_CENTRE[0] + robot_arm.TRACK_HALF[0] - 0.01
               - robot_arm.CELL_PART_HALF_M)  # against the stop's face
    arrived = runs[True].time_s[np.argmax(on[:, 0] >= at_stop - 1e-3)]
    assert 1.0 < arrived < 5.9  # conveyed there before the arm comes down
    off = runs[False].sensor("feeder_part0_position")
    assert abs(off[-1, 0] - off[0, 0]) < 1e-3  # still on the track where it started
    assert abs(off[-1, 2] - off[0, 2]) < 1e-3


def test_the_resolved_cell_steps_without_warnings(robot_arm):
    run = robot_arm.run_cell("resolved", True, duration_s=0.05)
    assert not run.warnings
    assert run.model.opt.timestep == 1e-5


def test_a_missing_dm_control_is_one_clear_message(robot_arm, monkeypatch):
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ParameterError, match=r"pip install 'vibrofriction\[robots\]'"):
        robot_arm.jaco_model_dir()
    with pytest.raises(ParameterError, match="unknown arm cell mode"):
        robot_arm.build_model("fast")
