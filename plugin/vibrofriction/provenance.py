"""What every JSON output says about how it was made: the schema version of the outputs and
the versions of vibrofriction and MuJoCo that made it."""
from __future__ import annotations

import json
from typing import Any

# Raised when a key of an existing JSON output changes meaning or goes away (new keys do not).
SCHEMA_VERSION = 1


def versions() -> dict[str, str]:
    import mujoco

    from . import __version__
    return {"vibrofriction": __version__, "mujoco": mujoco.__version__}


def stamped(payload: Any) -> Any:
    """A JSON object with ``schema_version`` and ``versions`` first (its own keys win);
    anything else as it is."""
    if not isinstance(payload, dict):
        return payload
    return {"schema_version": SCHEMA_VERSION, "versions": versions(), **payload}


def json_text(payload: Any) -> str:
    """The text of a JSON output file: stamped, indented, one trailing newline."""
    return json.dumps(stamped(payload), indent=2) + "\n"
