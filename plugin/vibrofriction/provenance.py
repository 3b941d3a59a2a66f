"""What every JSON output says about how it was made: the schema version of the outputs and
the versions of vibrofriction and MuJoCo that made it."""
from __future__ import annotations

import json
import math
from typing import Any

# Raised when a key of an existing JSON output changes meaning or goes away (new keys do not).
SCHEMA_VERSION = 1


def versions() -> dict[str, str]:
    """The versions of vibrofriction and of the installed MuJoCo, as every JSON output states
    them."""
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
    """The text of a JSON output file: stamped, indented, one trailing newline; a non-finite
    number (an unconverged point's NaN) is written null, which every JSON reader takes."""
    return json.dumps(_finite_or_null(stamped(payload)), indent=2, allow_nan=False) + "\n"


def _finite_or_null(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(v) for v in value]
    return value
