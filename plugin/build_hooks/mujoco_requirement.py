"""scikit-build-core metadata provider: the wheel requires the MuJoCo it was compiled against.

The plugin library links one libmujoco (its soname carries the version) and reads MuJoCo's
structs by their layout, so a wheel works with exactly the mujoco of its build environment.
pyproject.toml lets the build use any mujoco of the supported range; this provider writes the
one found there, pinned, into the wheel's dependencies, next to the package's other
requirements (the provider's ``requires`` setting).
"""
from __future__ import annotations

from importlib import metadata


def dynamic_metadata(field: str, settings: dict | None = None) -> list[str]:
    if field != "dependencies":
        raise RuntimeError(f"mujoco_requirement provides 'dependencies', not {field!r}")
    settings = dict(settings or {})
    requires = settings.pop("requires", [])
    if settings:
        raise RuntimeError(f"mujoco_requirement: unknown settings {sorted(settings)}; "
                           "only 'requires' (the other dependencies) is read")
    try:
        built_against = metadata.version("mujoco")
    except metadata.PackageNotFoundError:
        raise RuntimeError("vibrofriction: mujoco is not installed in the build environment; "
                           "it is a build requirement (pyproject.toml [build-system])") from None
    return [f"mujoco=={built_against}", *requires]
