"""Packaging: the wheel requires exactly the MuJoCo it was built against, within one range."""
from __future__ import annotations

import importlib.util
import re
from importlib import metadata
from pathlib import Path

import mujoco
import pytest

from vibrofriction import build_info
from vibrofriction.laws._mujoco_plugins import SUPPORTED_MUJOCO

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"
PROVIDER = ROOT / "plugin" / "build_hooks" / "mujoco_requirement.py"


def _version_tuple(version: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", version)[:3])


def test_the_installed_package_requires_the_mujoco_it_was_built_against():
    pins = [r for r in metadata.requires("vibrofriction") or [] if re.match(r"mujoco\b", r)
            and "extra ==" not in r]
    assert pins == [f"mujoco=={build_info.MUJOCO_VERSION}"]
    assert mujoco.__version__ == build_info.MUJOCO_VERSION


def test_the_running_mujoco_is_in_the_supported_range():
    low, high = re.fullmatch(r">=([\d.]+),<([\d.]+)", SUPPORTED_MUJOCO).groups()
    assert _version_tuple(low) <= _version_tuple(mujoco.__version__) < _version_tuple(high)


def _source_checkout():
    if not (PYPROJECT.is_file() and PROVIDER.is_file()):
        pytest.skip("pyproject.toml and plugin/build_hooks are not in this checkout")


def test_the_build_requirement_is_the_supported_range():
    _source_checkout()
    text = PYPROJECT.read_text(encoding="utf-8")
    build_system = text.split("[build-system]", 1)[1].split("\n[", 1)[0]
    assert f'"mujoco{SUPPORTED_MUJOCO}"' in build_system


def _provider():
    spec = importlib.util.spec_from_file_location("mujoco_requirement", PROVIDER)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_metadata_provider_pins_the_build_environments_mujoco():
    _source_checkout()
    provider = _provider()
    assert provider.dynamic_metadata("dependencies", {"requires": ["numpy>=1.24"]}) == [
        f"mujoco=={metadata.version('mujoco')}", "numpy>=1.24"]
    with pytest.raises(RuntimeError, match="provides 'dependencies'"):
        provider.dynamic_metadata("version", {})
    with pytest.raises(RuntimeError, match="unknown settings"):
        provider.dynamic_metadata("dependencies", {"require": []})


def test_the_library_and_models_are_found_in_whichever_package_folder_holds_them(
        tmp_path, monkeypatch):
    """An editable install's package spans the source folder (Python files only) and the
    installed one (the library and the models the build put there): each is looked up in the
    first folder that holds it. (Looked up beside the sources, an editable install found
    neither.)"""
    import vibrofriction
    from vibrofriction.laws._mujoco_plugins import LIBRARY_NAME, library_path, package_file
    source, installed = tmp_path / "source", tmp_path / "installed"
    source.mkdir()
    (installed / "mjcf_models").mkdir(parents=True)
    (installed / LIBRARY_NAME).write_bytes(b"")
    monkeypatch.setattr(vibrofriction, "__path__", [str(source), str(installed)])
    assert library_path() == installed.resolve() / LIBRARY_NAME
    assert package_file("mjcf_models") == installed.resolve() / "mjcf_models"
    assert package_file("missing.txt") == source.resolve() / "missing.txt"
