"""Figures of an identification (matplotlib, Agg backend, small PNGs)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .analysis import analyse
from .selection import Identification

_DPI = 90
_MAX_POINTS = 6000


def write_figures(result: Identification, folder: Path) -> list[Path]:
    """The inverse path's figures in ``folder`` (the fit, the residual against its regressors
    and its spectrum); returns their paths."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    paths = [_fit_figure(result, folder / "fit.png", plt),
             _regressor_figure(result, folder / "residual_vs_regressor.png", plt),
             _spectrum_figure(result, folder / "spectrum.png", plt)]
    return paths


def _decimate(n: int) -> slice:
    return slice(None, None, max(1, int(math.ceil(n / _MAX_POINTS))))


def _zoom(result: Identification) -> np.ndarray:
    """Samples of a short window that shows the dynamics (5 vibration periods, or 10 %)."""
    record = result.train
    t = record.time_s
    if record.vibrating:
        span = 5.0 / record.vibration_frequency_Hz
    else:
        span = 0.1 * (t[-1] - t[0])
    middle = t[0] + 0.6 * (t[-1] - t[0])
    return (t >= middle) & (t <= middle + span)


def _fit_figure(result: Identification, path: Path, plt) -> Path:
    record = result.train
    t = record.time_s
    measured = record.lowpass(record.target_N)
    baseline = measured + result.baseline.residual
    final = measured + result.final.residual
    final_label = "final: + " + (", ".join(result.selected) or "nothing")
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 7.0))
    s = _decimate(len(t))
    for ax, window, title in ((axes[0], s, "whole record"), (axes[1], _zoom(result), "detail")):
        ax.plot(t[window], measured[window], color="0.55", lw=1.6, label="measured")
        ax.plot(t[window], baseline[window], color="tab:blue", lw=0.9,
                label=f"baseline ({result.baseline.train.relerr_pct:.3g} %)")
        ax.plot(t[window], final[window], color="tab:red", lw=0.9, ls="--",
                label=f"{final_label} ({result.final.train.relerr_pct:.3g} %)")
        ax.set_ylabel(f"{record.target} force (N)")
        ax.set_title(f"{record.name}: {title}", fontsize=9)
    axes[2].plot(t[s], result.baseline.residual[s], color="tab:blue", lw=0.6,
                 label="baseline residual")
    axes[2].plot(t[s], result.final.residual[s], color="tab:red", lw=0.6, label="final residual")
    axes[2].set_ylabel("model - measured (N)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(fontsize=7, loc="best")
    axes[0].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


def _regressor_figure(result: Identification, path: Path, plt) -> Path:
    keys = [result.exposing[e] for e in result.selected] or \
        [_strongest_key(result)]
    keys = list(dict.fromkeys(keys))
    fig, axes = plt.subplots(1, len(keys), figsize=(3.8 * len(keys) + 0.6, 3.4), squeeze=False)
    final = analyse(result.train, result.final.residual)
    for ax, key in zip(axes[0], keys):
        before = result.baseline_analysis.binned[key]
        after = final.binned[key]
        ax.plot(before.centers, before.means, "o-", ms=3, color="tab:blue",
                label=f"baseline ({100 * before.explained:.0f} % of var.)")
        ax.plot(after.centers, after.means, "s-", ms=3, color="tab:red",
                label=f"final ({100 * after.explained:.0f} % of var.)")
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set_xlabel(f"{before.regressor} ({before.unit})")
        ax.set_ylabel("mean residual (N)")
        effects = [e for e in result.selected if result.exposing[e] == key]
        ax.set_title("exposes " + ", ".join(effects) if effects else "strongest regressor",
                     fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


def _strongest_key(result: Identification) -> str:
    binned = result.baseline_analysis.binned
    return max(binned, key=lambda k: binned[k].explained)


def _spectrum_figure(result: Identification, path: Path, plt) -> Path:
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    for label, analysis, color in (("baseline", result.baseline_analysis, "tab:blue"),
                                   ("final", result.final_analysis, "tab:red")):
        spectrum = analysis.spectrum
        if spectrum is None:
            continue
        ax.semilogy(spectrum.frequency_Hz[1:], spectrum.psd[1:], color=color, lw=0.9,
                    label=f"{label} residual")
        if label == "final":
            ax.semilogy(spectrum.frequency_Hz[1:], 10 * spectrum.floor[1:], color="0.5",
                        lw=0.8, ls=":", label="10 x noise floor")
            for f in spectrum.peaks_Hz:
                ax.axvline(f, color="k", lw=0.6, ls="--")
                ax.annotate(f"{f:.4g} Hz", (f, spectrum.psd.max()), fontsize=7, rotation=90,
                            va="top", ha="right")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("PSD (N$^2$/Hz)")
    ax.set_xscale("log")
    ax.legend(fontsize=7)
    ax.set_title(f"{result.train.name}: residual spectrum (Welch)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


__all__ = ["write_figures"]
