"""`vibrofriction view SCENE`: every bundled scene loads; the viewer gets the model; without a
display, one message (the scene still checked)."""
from __future__ import annotations

import mujoco
import mujoco.viewer
import pytest

import vibrofriction
from vibrofriction import cli
from vibrofriction.commands.view import bundled_names, scene_file


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_scene_loads(name):
    vibrofriction.load()
    model = mujoco.MjModel.from_xml_path(str(scene_file(name)))
    assert model.nbody > 1


def test_the_viewer_gets_the_scene(monkeypatch):
    opened = []
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(mujoco.viewer, "launch", lambda model: opened.append(model))
    assert cli.main(["view", "rig-lugre"]) == 0
    assert len(opened) == 1 and opened[0].nplugin > 0


def test_no_display_and_no_scene_are_one_message_each(monkeypatch, capsys, tmp_path):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(mujoco.viewer, "launch", lambda model: pytest.fail("no display"))
    assert cli.main(["view", "rig"]) == 2
    assert "no display" in capsys.readouterr().err
    assert cli.main(["view", str(tmp_path / "missing.xml")]) == 2
    assert "does not exist" in capsys.readouterr().err
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body><geom type='nonsense'/></body></worldbody></mujoco>")
    assert cli.main(["view", str(broken)]) == 2
    assert "does not load" in capsys.readouterr().err
