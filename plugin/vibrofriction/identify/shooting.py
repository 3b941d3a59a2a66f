"""Multiple shooting: the record as segments whose start states are fitted with the model.

A segmented replay (``replay.Replayer`` with segment steps) starts each segment from the
record's state estimate; its fit is smooth but biased by those estimates (measured on a
noise-free stick-slip record: the contact's damping 7.6 % off, and the whole-record fit from
there stays). Here each segment after the first starts from that estimate plus an offset in the
slider's (position, velocity, deflection), fitted with the model's values, and continuity
residuals tie each segment's end to the next one's start: at the optimum of a record the model
explains, the segments join into one run and the offsets are the estimates' errors. The result
starts the whole-record fit (``simulation.SimulationProblem.fit``).

Continuity is weighed like a segment's samples: a gap of one position sd, of the velocity that
moves the slider one sd in a sample, of the deflection that holds one force sd, counts as much
as every sample of a segment off by one sd. The Jacobian takes the model's columns and three
runs for every start offset together (an offset moves its own segment's samples and the
continuity at both its ends, and its direct effect on its own start is known).
"""
from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from .model import Model, forward_steps
from .replay import Replayer

SHOOTING_EVALUATIONS = 40
_FD_STEP = 1e-5  # in the internal coordinates (O(1) scaled)
_TOL = 1e-10


class MultipleShooting:
    """The training record of ``problem`` (a ``simulation.SimulationProblem``) as segments
    starting at ``segment_steps``, fitted with their start offsets."""

    def __init__(self, problem, model: Model, segment_steps: Sequence[int]):
        train = problem.train
        self.problem, self.model = problem, model
        self.runner = Replayer(train, problem.runner.threads, segment_steps)
        starts = self.runner.segment_starts
        rows = np.floor(np.arange(train.n) * train.steps_per_sample).astype(int)
        sample_segment = np.searchsorted(starts, rows, side="right") - 1
        self.row_segment = np.tile(sample_segment, len(train.channels))
        self.segments = len(starts)
        self.sample_dt = float(train.time_s[1] - train.time_s[0])
        self.samples_per_segment = train.n / self.segments
        self.scale = np.ones(3)  # the offsets' units (``_scales``), set by ``fit``

    def close(self) -> None:
        self.runner.close()

    def _scales(self, values: Mapping[str, float]) -> np.ndarray:
        """The offsets' units: one position sd, the velocity of one sd a sample, the
        deflection that holds one force sd."""
        noise = self.problem.noise
        position = noise.get("position_m", 1e-9)
        force = noise.get(self.problem.primary, 1e-3)
        k_t = values.get("contact_stiffness_N_per_m") or 1.0
        return np.array([position, position / self.sample_dt, force / k_t])

    def _residuals(self, values_list: Sequence[Mapping[str, float]],
                   offsets: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Weighted data residuals followed by the continuity residuals."""
        cases = [self.problem.case(self.model, v) for v in values_list]
        outs, ends = self.runner.shoot(cases, offsets)
        weight = math.sqrt(self.samples_per_segment)
        replay = self.runner.replay
        out = []
        for case, predicted, end, offset in zip(cases, outs, ends, offsets):
            starts = np.array([replay.slider_estimate(step, case[1], case[0].mass_kg)
                               for step in self.runner.segment_starts[1:]]) + offset
            if case[1].law == "coulomb":  # (no deflection: its offset stays unused)
                end, starts = end[:, :2], starts[:, :2]
                end, starts = np.column_stack([end, np.zeros(len(end))]), \
                    np.column_stack([starts, np.zeros(len(starts))])
            out.append(np.concatenate([self.problem.weighted(predicted),
                                       ((end - starts) * weight / self.scale).ravel()]))
        return out

    def fit(self, start: Mapping[str, float], max_nfev: int = SHOOTING_EVALUATIONS
            ) -> dict[str, float]:
        """The model's values (internal names) after a multiple-shooting fit from ``start``,
        every segment started at the record's estimate."""
        model, k = self.model, self.model.k
        self.scale = scale = self._scales(model.internal_values(model.internal(start)))
        count = 3 * (self.segments - 1)
        q0 = np.concatenate([model.internal(start), np.zeros(count)])
        lo, hi = model.bounds()
        lo = np.concatenate([lo, np.full(count, -np.inf)])
        hi = np.concatenate([hi, np.full(count, np.inf)])
        cache: dict[bytes, np.ndarray] = {}

        def unpack(q: np.ndarray) -> tuple[dict[str, float], np.ndarray]:
            return model.values(q[:k]), q[k:].reshape(-1, 3) * scale

        def fun(q: np.ndarray) -> np.ndarray:
            key = np.asarray(q, dtype=float).tobytes()
            if key not in cache:
                cache.clear()
                values, offsets = unpack(q)
                cache[key] = self._residuals([values], [offsets])[0]
            return cache[key]

        def jac(q: np.ndarray) -> np.ndarray:
            return self._jacobian(q, fun(q), unpack, hi[:k])

        result = least_squares(fun, q0, jac=jac, bounds=(lo, hi), method="trf",
                               x_scale="jac", ftol=_TOL, xtol=_TOL, gtol=_TOL,
                               max_nfev=max_nfev)
        return model.internal_values(result.x[:k])

    def _jacobian(self, q: np.ndarray, r0: np.ndarray, unpack, hi: np.ndarray) -> np.ndarray:
        k, segments = self.model.k, self.segments
        moved = forward_steps(q, hi, k, _FD_STEP)
        trials, steps = [t for t, _ in moved], [h for _, h in moved]
        for component in range(3):  # every segment's offset in one component at once
            shifted = np.array(q, dtype=float)
            shifted[k + component::3] += _FD_STEP
            trials.append(shifted)
        unpacked = [unpack(t) for t in trials]
        runs = self._residuals([u[0] for u in unpacked], [u[1] for u in unpacked])
        jacobian = np.zeros((len(r0), k + 3 * (segments - 1)))
        for j in range(k):
            jacobian[:, j] = (runs[j] - r0) / steps[j]
        data_rows = len(self.row_segment)
        direct = -math.sqrt(self.samples_per_segment)  # d(continuity)/d(its start's offset)
        for component in range(3):
            change = (runs[k + component] - r0) / _FD_STEP
            for s in range(1, segments):  # segment s starts from offset row s - 1
                column = k + 3 * (s - 1) + component
                rows = np.flatnonzero(self.row_segment == s)
                jacobian[rows, column] = change[rows]
                # its start: the continuity with segment s - 1's end
                at = data_rows + 3 * (s - 1)
                jacobian[at + component, column] = direct
                if s + 1 < segments:  # its end: the continuity at segment s + 1's start,
                    at = data_rows + 3 * s  # less that start's own shift (run with it)
                    jacobian[at:at + 3, column] = change[at:at + 3]
                    jacobian[at + component, column] -= direct
        return jacobian


__all__ = ["MultipleShooting", "SHOOTING_EVALUATIONS"]
