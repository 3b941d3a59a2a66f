"""Forward selection of effects, one driver for both identification paths.

Each round the back end evaluates every remaining candidate effect against the current model
(the inverse path fits them all; the simulation path screens them linearized, fits the
promising ones and converges the leaders); the driver picks the justified candidate with the
lowest dBIC -- unless another justified one explains the training record alike (at least
``ALIKE_FRACTION`` of the best's dBIC) and held-out records clearly prefer it (its held-out RMSE
at least ``HELD_OUT_MARGIN`` below the dBIC-best's): a drift in time and a map along a travel
that grows with time are told apart by a record that moves otherwise; the held-out records then
took part in the choice, as they do in every candidate's guard -- the back end accepts it (the simulation path refits it to convergence where the
round had not) and takes its backward step (the simulation path drops an earlier effect the
same test no longer justifies; the inverse path has none). Rounds end when no candidate is
justified or none remains; a last backward step follows (the simulation path's on its last
choice). What "justified" means, and the fits, stay in the back ends: ``selection``
(``Problem``) and ``simulation`` (``SimulationProblem``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Generic, Protocol, Sequence, TypeVar

from .model import excluded_by

# A justified candidate whose held-out RMSE is this fraction or more below the dBIC-best's
# is chosen instead (the held-out records are the direct measure of prediction).
HELD_OUT_MARGIN = 0.10
# ... among the candidates whose dBIC is at least this fraction of the dBIC-best's (both < 0)
ALIKE_FRACTION = 0.5

F = TypeVar("F")  # a fitted model
C = TypeVar("C", bound="Judged")  # a judged candidate


class Judged(Protocol):
    """A candidate effect as a round has evaluated it (``selection.Candidate``,
    ``simulation.SimCandidate``)."""

    @property
    def effect(self) -> str: ...

    @property
    def justified(self) -> bool: ...

    @property
    def delta_bic(self) -> float: ...

    @property
    def validation_log_ratio(self) -> float | None: ...  # mean ln(RMSE with / without)

    @property
    def held_out_evidence(self) -> float: ...  # added to delta_bic (``held_out_evidence``)

    @property
    def fit(self): ...  # the current model plus the effect (or the current model, unfitted)


class BackEnd(Protocol[C, F]):
    """What a path does in each step of the forward selection."""

    # what a round does to its candidates, in the round's progress line ("fitting",
    # "screening")
    round_action: str

    def evaluate_round(self, current: F, remaining: Sequence[str],
                       index: int) -> list[C]:
        """Every candidate of ``remaining`` judged against ``current`` in round ``index``
        (each reported in a progress line)."""

    def accept(self, best: C, current: F, index: int) -> C:
        """``best`` as it joins the model: its ``fit`` is the model the selection goes on
        with."""

    def selected_note(self, accepted: C) -> str:
        """What the round's "selected" progress line adds after the effect's name."""

    def backward_step(self, current: F, selected: list[str], index: int,
                      final: bool) -> F:
        """The model after dropping what the test no longer justifies, removed from
        ``selected``: the earlier choices after round ``index`` (``final`` False), the last
        choice once no round selects anything more (``final`` True)."""


@dataclass(frozen=True, eq=False)
class Selection(Generic[C, F]):
    """The outcome of a forward selection: the final fit, each effect's last evaluation, the
    rounds' candidates, the effects selected in order."""

    final: F
    candidates: dict[str, C]  # the last evaluation of each effect
    rounds: list[list[C]]
    selected: list[str]


def held_out_evidence(n_eff: float, train_samples: int, held_out_samples: Sequence[int],
                      larger: Sequence, smaller: Sequence) -> float:
    """The held-out records' evidence for the larger model on the dBIC scale (<= 0; 0 where
    they do not favour it): sum over records of n_eff_r ln(RMSE_larger^2 / RMSE_smaller^2),
    n_eff_r = n_eff n_r / n_train (a held-out record of the training record's kind).

    Out-of-sample, the likelihood ratio needs no penalty for the parameters: it adds to the
    training record's dBIC. It matters where the training residual is slow and n_eff small
    (a machine in closed loop: EMPS's residual of 12420 samples holds about 13 independent
    ones, and an offset that lowers the force error by 37 % on both halves had a dBIC of
    -9.5 alone); with a white residual the training dBIC decides anyway."""
    total = 0.0
    for n, a, b in zip(held_out_samples, larger, smaller):
        if a.rmse_N > 0 and b.rmse_N > 0:
            total += max(n_eff, 2.0) * n / max(train_samples, 1) * 2.0 * math.log(
                a.rmse_N / b.rmse_N)
    return min(total, 0.0)


def select(back_end: BackEnd[C, F], start: F, effects: Sequence[str],
           say: Callable[[str], None]) -> Selection[C, F]:
    """Forward selection of ``effects`` from the model ``start``."""
    current = start
    remaining = list(effects)
    candidates: dict[str, C] = {}
    rounds: list[list[C]] = []
    selected: list[str] = []
    held_back: set[str] = set()  # out of the candidates while an exclusive partner is selected
    dropped: set[str] = set()  # dropped by a backward step: not a candidate again
    while remaining:
        index = len(rounds) + 1
        say(f"round {index}: {back_end.round_action} {len(remaining)} candidate(s): "
            f"{', '.join(remaining)}")
        evaluated = back_end.evaluate_round(current, remaining, index)
        for c in evaluated:
            candidates[c.effect] = c
        rounds.append(evaluated)
        justified = [c for c in evaluated if c.justified]
        if not justified:
            break
        best, why = _choose(justified)
        selected.append(best.effect)
        remaining.remove(best.effect)
        # (one of an exclusive group: a load modulation at one harmonic of the vibration)
        held_back.update(e for e in remaining if e in excluded_by(selected))
        remaining = [e for e in remaining if e not in held_back]
        accepted = back_end.accept(best, current, index)
        candidates[best.effect] = accepted
        current = accepted.fit
        say(f"round {index}: selected {best.effect}{back_end.selected_note(accepted)}{why}")
        # (an effect dropped is not a candidate again: no cycles)
        before = list(selected)
        current = back_end.backward_step(current, selected, index, final=False)
        dropped.update(set(before) - set(selected))
        # an exclusive partner of a dropped effect is a candidate again (the load modulation
        # at another harmonic, once the one selected is dropped)
        freed = [e for e in effects if e in held_back and e not in excluded_by(selected)
                 and e not in dropped]
        if freed:
            held_back.difference_update(freed)
            remaining = [e for e in effects if e in remaining or e in freed]
    current = back_end.backward_step(current, selected, len(rounds), final=True)
    say("selected: " + (", ".join(selected) if selected else "nothing"))
    return Selection(final=current, candidates=candidates, rounds=rounds, selected=selected)


def _choose(justified: Sequence[C]) -> tuple[C, str]:
    """The justified candidate the round selects, and why when not the dBIC-best (the
    criterion: the training dBIC with the held-out records' evidence, as the test)."""
    def criterion(c: C) -> float:
        return c.delta_bic + c.held_out_evidence

    best = min(justified, key=criterion)
    if best.validation_log_ratio is None:
        return best, ""
    held = [c for c in justified if c.validation_log_ratio is not None
            and criterion(c) <= ALIKE_FRACTION * criterion(best)]
    if not held:  # (justified: the criterion is below the threshold, < 0, so best is in)
        return best, ""
    clearer = min(held, key=lambda c: c.validation_log_ratio)
    gain = 1.0 - math.exp(clearer.validation_log_ratio - best.validation_log_ratio)
    if clearer is best or gain < HELD_OUT_MARGIN:
        return best, ""
    return clearer, (f" (held out: its RMSE {100 * gain:.0f} % below that of {best.effect}, "
                     "the training record's first choice)")


__all__ = ["HELD_OUT_MARGIN", "ALIKE_FRACTION", "held_out_evidence", "select", "Selection", "BackEnd", "Judged"]
