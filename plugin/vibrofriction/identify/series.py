"""The final model's predicted and residual series of every record, beside report.json.

One ``series_<dataset>.csv`` per record, the training record's and each held-out record's:
``time_s``, then for each predicted channel ``measured_<channel>``, ``predicted_<channel>`` and
``residual_<channel>`` (measured - predicted). The inverse path predicts the measured force
(``friction_force_N`` or ``drive_force_N``; with ``--lowpass`` both the measured and the
predicted force are the filtered ones its errors are of); the simulation path every channel
it fitted. The held-out errors in report.json are of these series (the RMSE of the residual
of the measured force). With figures, ``series_<dataset>.png`` shows each channel measured
and predicted with its residual, over the whole record and over a short window where the
measured force's residual is largest: a few vibration periods (a record without vibration:
5 % of it, where a reversal or a slip the model misses usually puts it).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

ZOOM_PERIODS = 5  # vibration periods in the figure's window
ZOOM_FRACTION = 0.05  # of a record without vibration
ZOOM_MIN_SAMPLES = 50
_SKIP_START = 0.01  # the window's centre is not taken from the record's first 1 %
_DPI = 90
_MAX_POINTS = 6000


@dataclass(frozen=True, eq=False)
class Series:
    """The final model's prediction of one record."""

    dataset: str
    role: str  # "train" or "validation"
    file: str  # series_<dataset>.csv
    time_s: np.ndarray
    channels: dict[str, tuple[np.ndarray, np.ndarray]]  # channel -> (measured, predicted)
    primary: str  # the measured force (the figure's window follows its residual)
    vibration_frequency_Hz: float | None = None  # when the support vibrates

    def residual(self, channel: str) -> np.ndarray:
        measured, predicted = self.channels[channel]
        return measured - predicted

    def columns(self) -> dict[str, np.ndarray]:
        out = {"time_s": self.time_s}
        for channel, (measured, predicted) in self.channels.items():
            out[f"measured_{channel}"] = measured
            out[f"predicted_{channel}"] = predicted
            out[f"residual_{channel}"] = measured - predicted
        return out


# ------------------------------------------------------------------------------------ names

def file_names(train: str, validation: Sequence[str]) -> list[str]:
    """``series_<dataset>.csv`` of each record, training first: characters outside
    [A-Za-z0-9._-] become _, and a name met again gets _2, _3, ..."""
    out: list[str] = []
    for name in (train, *validation):
        stem = "series_" + (re.sub(r"[^A-Za-z0-9._-]", "_", name) or "record")
        candidate, k = stem, 1
        while f"{candidate}.csv" in out:
            k += 1
            candidate = f"{stem}_{k}"
        out.append(f"{candidate}.csv")
    return out


def listing(train: str, validation: Sequence[str]) -> dict:
    """report.json's ``series``: {"train": file, "validation": [file, ...]}."""
    names = file_names(train, validation)
    return {"train": names[0], "validation": names[1:]}


# ------------------------------------------------------------------------------ the series

def inverse_series(result) -> list[Series]:
    """The final model's predicted measured force on every record of an inverse-path
    ``Identification`` (one run of the law a record, as its errors were computed)."""
    from .fit import Problem

    problem = Problem(result.train, result.validation)
    train, held = problem.predicted(result.final.model, result.final.values)
    records = [result.train, *result.validation]
    names = file_names(records[0].name, [r.name for r in records[1:]])
    channel = f"{result.train.target}_force_N"
    out = []
    for index, (record, predicted) in enumerate(zip(records, [train, *held])):
        out.append(Series(
            dataset=record.name, role="validation" if index else "train", file=names[index],
            time_s=record.time_s, channels={channel: (record.lowpass(record.target_N),
                                                      np.asarray(predicted, dtype=float))},
            primary=channel,
            vibration_frequency_Hz=record.vibration_frequency_Hz if record.vibrating
            else None))
    return out


def simulation_series(result) -> list[Series]:
    """Every fitted channel of the final model on every record of a
    ``SimIdentification``: the training record's prediction is the final fit's own, each
    held-out record's the one its error was computed from."""
    fit = result.final
    replays = [result.train, *result.validation]
    names = file_names(replays[0].name, [r.name for r in replays[1:]])
    predictions = [fit.predicted, *fit.validation_predicted]
    if len(predictions) != len(replays):
        raise ValueError("the final fit holds no prediction of the held-out records")
    channels = result.train.channels
    out = []
    for index, (replay, predicted) in enumerate(zip(replays, predictions)):
        vibrating = bool(getattr(replay, "vibrating", False))
        frequency = getattr(replay.rig, "vibration_frequency_Hz", None) if vibrating else None
        out.append(Series(
            dataset=replay.name, role="validation" if index else "train", file=names[index],
            time_s=replay.time_s,
            channels={c: (np.asarray(replay.measured[c], dtype=float),
                          np.asarray(predicted[c], dtype=float))
                      for c in channels if c in replay.measured and c in predicted},
            primary=result.primary, vibration_frequency_Hz=frequency or None))
    return out


# ----------------------------------------------------------------------------------- write

def write_series(series: Sequence[Series], folder: Path, *, figures: bool = True,
                 title: str = "") -> list[Path]:
    """Each record's CSV (and, with ``figures``, its PNG) into ``folder``."""
    paths = []
    for s in series:
        path = folder / s.file
        path.write_text(csv_text(s))
        paths.append(path)
    if figures:
        import matplotlib
        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        for s in series:
            paths.append(figure(s, folder / (Path(s.file).stem + ".png"), plt, title))
    return paths


def csv_text(series: Series) -> str:
    """Header and rows; numbers in Python's shortest round-trip repr (as the dataset
    format's writer), so reading gives back exactly the values compared."""
    columns = series.columns()
    rows = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()]).tolist()
    return ",".join(columns) + "\n" + "\n".join(",".join(map(repr, row)) for row in rows) + "\n"


def zoom(series: Series) -> np.ndarray:
    """The figure's window (a boolean mask over the samples): ``ZOOM_PERIODS`` vibration
    periods, or ``ZOOM_FRACTION`` of a record without vibration (either at least
    ``ZOOM_MIN_SAMPLES`` samples), placed where the residual of the measured force is largest
    (its mean square over the window; the record's first 1 % left out, where a record and a
    model differ by their start)."""
    t = series.time_s
    n = len(t)
    duration = float(t[-1] - t[0]) if n > 1 else 0.0
    dt = duration / (n - 1) if n > 1 else 0.0
    span = ZOOM_PERIODS / series.vibration_frequency_Hz if series.vibration_frequency_Hz \
        else ZOOM_FRACTION * duration
    span = max(span, ZOOM_MIN_SAMPLES * dt)
    if span >= duration:
        return np.ones(n, dtype=bool)
    width = max(1, min(n, int(round(span / dt)) + 1))
    squared = np.nan_to_num(series.residual(series.primary) ** 2, nan=0.0, posinf=0.0)
    squared[:min(int(_SKIP_START * n), n - width)] = 0.0
    sums = np.convolve(squared, np.ones(width), mode="valid")  # sums[i]: samples i..i+width-1
    best = np.flatnonzero(sums >= sums.max() * (1 - 1e-12))  # (ties: the middle one)
    first = int(best[len(best) // 2])
    return (np.arange(n) >= first) & (np.arange(n) < first + width)


def figure(series: Series, path: Path, plt, title: str = "") -> Path:
    """Per channel: measured and predicted above, the residual below; the whole record on
    the left, the window (``zoom``, shaded on the left) on the right."""
    t = series.time_s
    window = zoom(series)
    every = slice(None, None, max(1, int(math.ceil(len(t) / _MAX_POINTS))))
    rows = 2 * len(series.channels)
    fig, axes = plt.subplots(rows, 2, figsize=(10.0, 1.9 * rows + 0.6), squeeze=False,
                             gridspec_kw={"width_ratios": (1.4, 1.0)})
    for k, (channel, (measured, predicted)) in enumerate(series.channels.items()):
        residual = measured - predicted
        norm = float(np.linalg.norm(measured))
        relerr = 100 * float(np.linalg.norm(residual)) / norm if norm > 0 else math.nan
        rmse = float(np.sqrt(np.mean(residual ** 2)))
        value, error = axes[2 * k], axes[2 * k + 1]
        for column, rows_shown in ((0, every), (1, window)):
            value[column].plot(t[rows_shown], measured[rows_shown], color="0.5", lw=1.4,
                               label="measured")
            value[column].plot(t[rows_shown], predicted[rows_shown], color="tab:red", lw=0.8,
                               ls="--", label="predicted")
            error[column].plot(t[rows_shown], residual[rows_shown], color="tab:blue", lw=0.6)
            error[column].axhline(0.0, color="0.6", lw=0.6)
        value[0].set_ylabel(channel, fontsize=8)
        error[0].set_ylabel("measured - predicted", fontsize=8)
        value[0].set_title(f"{channel}: RMSE {rmse:.4g}, relerr {relerr:.3g} %", fontsize=8,
                           loc="left")
        value[1].set_title("window: " + (f"{ZOOM_PERIODS} vibration periods"
                                         if series.vibration_frequency_Hz else "a stretch")
                           + " where the residual is largest", fontsize=8, loc="left")
        value[0].legend(fontsize=7, loc="best")
        for ax in (value[0], error[0]):
            if not window.all():
                ax.axvspan(float(t[window][0]), float(t[window][-1]), color="gold",
                           alpha=0.25, lw=0)
        for ax in (*value, *error):
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)", fontsize=8)
    role = "training record" if series.role == "train" else "held-out record"
    fig.suptitle(f"{series.dataset} ({role}), final model" + (f": {title}" if title else ""),
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


__all__ = ["Series", "file_names", "listing", "inverse_series", "simulation_series",
           "write_series", "csv_text", "zoom", "figure"]
