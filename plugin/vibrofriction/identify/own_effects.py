"""A researcher's own effects: a form of the friction level the vocabulary does not have, that
the selection then treats like its own effects (a candidate, fitted, judged, reported).

An own effect is the friction level times a factor g(s; theta) over one regressor s -- the
time since the record's first sample, the relative speed |v_r|, or the relative position --
with named parameters theta. It runs in the plugin as that regressor's level map (the C++
``LevelMap``: a natural cubic spline through ``knots`` values of g over the record's range of s),
so the model that is fitted is still the model MuJoCo simulates, and one implementation of the
level map serves both. It therefore excludes the built-in free-form map over the same regressor
(``time_map``, ``velocity_map``, ``position_map``) and other own effects over it.

    from vibrofriction.identify.own_effects import OwnParameter, LevelEffect, register_effect

    register_effect(LevelEffect(
        name="run_in",
        over="time",
        parameters=(OwnParameter("run_in_drop", -0.5, 0.5, 0.05),
                    OwnParameter("run_in_time_s", 1e-4, 10.0, 0.01, log=True)),
        factor=lambda t, p: 1.0 - p["run_in_drop"] * (1.0 - np.exp(-t / p["run_in_time_s"])),
        description="the level falls by run_in_drop with time constant run_in_time_s"))

The effect is off when every linear parameter is 0 (g must then be 1): the selection's
linearized start projects the residual on the linear parameters with the log ones (positive
scales, time constants) at their ``scale``. ``vibrofriction identify --effects-from FILE.py``
runs a file of such registrations; ``--with run_in`` declares one, and without it the effect is
a candidate of the automatic selection like the built-in ones.
"""
from __future__ import annotations

import math
import runpy
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..errors import InputError
from ..vocabulary import MAX_MAP_KNOTS
from . import model

# the regressor an own effect's factor takes -> the plugin's level map that runs it
REGRESSORS = {"time": "time_map", "relative_speed": "velocity_map", "position": "position_map"}
DEFAULT_KNOTS = 12


@dataclass(frozen=True)
class OwnParameter:
    """One fitted parameter of an own effect (its unit in its name, as the vocabulary's).

    Linear parameters switch the effect off at 0; ``log`` ones are positive (a time constant,
    a speed scale), fitted in log, started at ``scale``."""

    name: str
    lower: float
    upper: float
    scale: float  # a typical size (the fit's unit of this coordinate)
    log: bool = False


@dataclass(frozen=True)
class LevelEffect:
    """The friction level times ``factor(s, values)`` over the regressor ``over`` (see the
    module head). ``factor`` takes an array of s and a name -> value mapping and returns
    positive factors, 1 where every linear parameter is 0."""

    name: str
    over: str
    parameters: tuple[OwnParameter, ...]
    factor: Callable[[np.ndarray, Mapping[str, float]], np.ndarray]
    knots: int = DEFAULT_KNOTS
    description: str = ""

    @property
    def level_map(self) -> str:
        return REGRESSORS[self.over]

    @property
    def linear_names(self) -> list[str]:
        return [p.name for p in self.parameters if not p.log]

    def factors(self, knots: np.ndarray, values: Mapping[str, float]) -> tuple[float, ...]:
        """The level map's factors (g - 1) at ``knots``; InputError naming a bad g."""
        g = np.asarray(self.factor(np.asarray(knots, dtype=float), values), dtype=float)
        g = np.broadcast_to(g, np.shape(knots))
        if not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise InputError(f"own effect {self.name}: its factor is not a positive finite "
                             f"number at every knot ({np.array2string(g, precision=4)}) with "
                             f"{dict(values)}; make the factor positive over the bounds of its "
                             "parameters")
        return tuple(float(x) - 1.0 for x in g)


_REGISTERED: dict[str, LevelEffect] = model.OWN_EFFECTS  # (the model reads them there)


def register_effect(effect: LevelEffect) -> LevelEffect:
    """Make ``effect`` a candidate and a ``--with`` name of both identification paths.
    InputError when it cannot be one (a taken name, a bad regressor or parameter)."""
    where = f"own effect {effect.name!r}"
    if not effect.name.isidentifier():
        raise InputError(f"{where}: the name must be a Python identifier (it is a --with name)")
    if effect.name in model.BUILT_IN_EFFECTS or (effect.name in _REGISTERED and
                                                 _REGISTERED[effect.name] is not effect):
        raise InputError(f"{where}: the name is taken; choose another")
    if effect.over not in REGRESSORS:
        raise InputError(f"{where}: over={effect.over!r}; use one of {', '.join(REGRESSORS)}")
    if not 2 <= effect.knots <= MAX_MAP_KNOTS:
        raise InputError(f"{where}: knots={effect.knots}; the plugin's level map takes 2 to "
                         f"{MAX_MAP_KNOTS}")
    if not effect.parameters or not effect.linear_names:
        raise InputError(f"{where}: needs at least one linear parameter (0 switches it off)")
    taken = model.taken_parameter_names()
    names = [p.name for p in effect.parameters]
    if len(set(names)) < len(names):
        raise InputError(f"{where}: parameter names repeat ({', '.join(names)}); make them "
                         "distinct")
    for p in effect.parameters:
        if p.name.startswith(model.RESERVED_PREFIXES):
            raise InputError(f"{where}: parameter name {p.name!r} starts like the fit's own "
                             f"({', '.join(model.RESERVED_PREFIXES)}); choose another")
        if p.name in taken and p.name not in (q.name for q in _own_parameters(effect.name)):
            raise InputError(f"{where}: parameter name {p.name!r} is taken; choose another")
        if not (math.isfinite(p.lower) and math.isfinite(p.upper) and p.lower < p.upper):
            raise InputError(f"{where}: parameter {p.name}: bounds [{p.lower}, {p.upper}] must "
                             "be finite with lower < upper")
        if p.log and not 0 < p.lower <= p.scale <= p.upper:
            raise InputError(f"{where}: log parameter {p.name} needs 0 < lower <= scale <= "
                             "upper")
        if not p.log and not (p.lower <= 0 <= p.upper and p.scale > 0):
            raise InputError(f"{where}: linear parameter {p.name} needs lower <= 0 <= upper "
                             "(0 switches the effect off) and scale > 0")
    off = {p.name: (p.scale if p.log else 0.0) for p in effect.parameters}
    if not np.allclose(effect.factors(np.linspace(0.0, 1.0, 5), off), 0.0, atol=1e-12):
        raise InputError(f"{where}: its factor is not 1 with the linear parameters at 0; "
                         "write it so that 0 switches the effect off")
    _REGISTERED[effect.name] = effect
    return effect


def _own_parameters(name: str) -> tuple[OwnParameter, ...]:
    return _REGISTERED[name].parameters if name in _REGISTERED else ()


def registered() -> dict[str, LevelEffect]:
    """The own effects registered so far, by name (in registration order)."""
    return dict(_REGISTERED)


def unregister(name: str) -> None:
    """Forget an own effect (tests; a session that redefines one)."""
    _REGISTERED.pop(name, None)


def load_effects_file(path: str | Path) -> list[str]:
    """Run a Python file of ``register_effect`` calls; the names it registered. InputError
    naming the file when it is missing or fails."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"--effects-from {path}: no such file; give a Python file that calls "
                         "vibrofriction.identify.own_effects.register_effect")
    before = set(_REGISTERED)

    def forget_new() -> None:  # (a file that fails half-way leaves nothing registered)
        for name in [n for n in _REGISTERED if n not in before]:
            unregister(name)

    try:
        runpy.run_path(str(path), run_name="vibrofriction_own_effects")
    except InputError as error:
        forget_new()
        raise InputError(f"--effects-from {path}: {error}") from None
    except Exception as error:  # a user's file: say where it failed, in one line
        forget_new()
        raise InputError(f"--effects-from {path}: the file failed: "
                         f"{type(error).__name__}: {error}") from None
    added = [n for n in _REGISTERED if n not in before]
    if not added:
        raise InputError(f"--effects-from {path}: it registered no effect (call "
                         "vibrofriction.identify.own_effects.register_effect)")
    return added


__all__ = ["OwnParameter", "LevelEffect", "register_effect", "registered", "unregister",
           "load_effects_file", "REGRESSORS"]
