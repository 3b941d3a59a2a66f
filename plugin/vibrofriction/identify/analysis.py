"""Residual analysis: what the residual depends on, its spectrum, its autocorrelation.

* Binned means of the residual against each regressor (relative velocity, position on the
  support, support phase, time) and the share of the residual variance they explain (eta^2):
  structure that a missing effect leaves behind.
* Welch spectrum and its peaks that stand clearly above the noise floor (the running median of
  the spectrum): ``PEAK_FACTOR`` = 10 (10 dB), and carry at least 1 % of the residual variance. For white noise the largest of ~500 Welch bins
  averaged over >= 8 segments exceeds its mean by less than 3x, so 10x is not reached by chance.
* Autocorrelation and the integrated autocorrelation time tau (Sokal's automatic window): the
  residual carries n/tau independent samples, the sample size the selection criterion uses.
* Ringing after reversals: the residual after each reversal of the sliding direction, signed
  by the new direction and averaged over the reversals, fitted with a damped sinusoid
  (frequency, damping ratio): a resonance the model lacks (a compliance, backlash), reported
  when it carries a clear share of that averaged residual.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks, welch
from scipy.ndimage import median_filter
from scipy.optimize import least_squares

from .record import Record

PEAK_FACTOR = 10.0
PEAK_MIN_SHARE = 0.01
MAX_PEAKS = 5
# Sokal's window constant: sum the autocorrelation up to the first lag M >= C tau(M).
SOKAL_C = 5.0


@dataclass(frozen=True)
class Binned:
    """The residual's means in bins of one regressor (its unit ``unit``) and the share
    of the residual variance they carry."""

    regressor: str
    unit: str
    centers: np.ndarray
    means: np.ndarray
    counts: np.ndarray
    explained: float  # eta^2: share of the residual variance the bin means carry


@dataclass(frozen=True)
class Spectrum:
    """The residual's power spectral density (N^2/Hz for a force), its noise floor and the
    frequencies (Hz) of the peaks standing out of it."""

    frequency_Hz: np.ndarray
    psd: np.ndarray  # N^2/Hz
    floor: np.ndarray
    peaks_Hz: list[float]


@dataclass(frozen=True)
class Ringing:
    """A damped oscillation of the residual after the reversals (averaged, signed)."""

    frequency_Hz: float  # damped frequency
    damping_ratio: float
    amplitude_N: float  # at the reversal
    explained: float  # share of the averaged post-reversal residual's variance (detrended)
    reversals: int
    window_s: float

    def as_dict(self) -> dict:
        return {"frequency_Hz": self.frequency_Hz, "damping_ratio": self.damping_ratio,
                "amplitude_N": self.amplitude_N, "explained": self.explained,
                "reversals": self.reversals, "window_s": self.window_s}


# A ringing is reported when the damped sinusoid carries this share of the averaged
# post-reversal residual (detrended), completes two cycles in the window and is underdamped.
RINGING_MIN_SHARE = 0.3
RINGING_MIN_CYCLES = 2.0
RINGING_MAX_DAMPING = 0.5
RINGING_MIN_AMPLITUDE = 0.05  # of the residual's RMS


@dataclass(frozen=True)
class ResidualAnalysis:
    """What a residual shows: its means against each regressor, its spectrum, its
    autocorrelation (lags in s) and effective sample count, a ringing after reversals."""

    binned: dict[str, Binned]
    spectrum: Spectrum | None
    acf_lags_s: np.ndarray
    acf: np.ndarray
    tau_samples: float
    n_eff: float
    ringing: Ringing | None = None

    def strongest(self) -> Binned | None:
        if not self.binned:
            return None
        return max(self.binned.values(), key=lambda b: b.explained)


def analyse(record: Record, residual: np.ndarray) -> ResidualAnalysis:
    """The residual (prediction - measurement, N) of ``record`` against the relative
    velocity, the position on the support, the support's phase, the time and the time since
    the last reversal; its spectrum and autocorrelation."""
    binned: dict[str, Binned] = {}
    v = record.relative_velocity_m_per_s
    binned["relative_velocity"] = _binned("relative velocity", "m/s", v, residual,
                                          edges=np.unique(np.quantile(v, np.linspace(0, 1, 41))))
    x = record.relative_position_m
    if np.ptp(x) > 0:
        binned["position"] = _binned("position on the support", "m", x, residual,
                                     edges=np.linspace(x.min(), x.max(), 41))
    if record.vibrating:
        psi = np.mod(record.support_phase_rad, 2 * math.pi)
        binned["support_phase"] = _binned("support phase", "rad", psi, residual,
                                          edges=np.linspace(0, 2 * math.pi, 37))
    t = record.time_s
    binned["time"] = _binned("time", "s", t, residual, edges=np.linspace(t[0], t[-1], 41))
    since = time_since_reversal(t, v)
    if np.isfinite(since).sum() > 40 and np.ptp(since[np.isfinite(since)]) > 0:
        known = np.isfinite(since)
        binned["time_since_reversal"] = _binned(
            "time since the last reversal", "s", since[known], residual[known],
            edges=np.unique(np.quantile(since[known], np.linspace(0, 1, 41))))
    spectrum = residual_spectrum(record, residual)
    lags, acf = autocorrelation(residual, max_lag=min(len(residual) // 4, 2000))
    tau = integrated_time(acf)
    dt = float(np.median(np.diff(t)))
    return ResidualAnalysis(binned=binned, spectrum=spectrum, acf_lags_s=lags * dt, acf=acf,
                            tau_samples=tau, n_eff=len(residual) / tau,
                            ringing=ringing_after_reversals(t, v, residual))


def reversal_indices(velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Samples where the sliding direction reverses (the sign of v changes, zeros skipped,
    and the new direction reaches a tenth of the RMS speed before the next change), and
    the new direction (+1 / -1)."""
    sign = np.sign(velocity)
    moving = np.flatnonzero(sign != 0)
    if len(moving) < 2:
        return np.array([], dtype=int), np.array([])
    changes = moving[1:][sign[moving[1:]] != sign[moving[:-1]]]
    rms = float(np.sqrt(np.mean(velocity ** 2)))
    keep = []
    direction = sign[moving[0]]
    for k, i in enumerate(changes):
        end = changes[k + 1] if k + 1 < len(changes) else len(velocity)
        # a reversal, not noise at rest, and not the return to the direction kept before
        # a blip of the other sign (a stop-and-go)
        if sign[i] != direction and np.max(np.abs(velocity[i:end])) >= 0.1 * rms:
            keep.append(i)
            direction = sign[i]
    keep = np.array(keep, dtype=int)
    return keep, sign[keep] if len(keep) else np.array([])


def time_since_reversal(time_s: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """Time since the last reversal at each sample (inf before the first)."""
    indices, _ = reversal_indices(velocity)
    out = np.full(len(time_s), np.inf)
    if len(indices):
        last = np.searchsorted(indices, np.arange(len(time_s)), side="right") - 1
        known = last >= 0
        out[known] = time_s[known] - time_s[indices[last[known]]]
    return out


def ringing_after_reversals(time_s: np.ndarray, velocity: np.ndarray,
                            residual: np.ndarray) -> Ringing | None:
    """The damped sinusoid in the residual after the reversals, or None when there is none
    (fewer than two reversals, or no clear, underdamped oscillation)."""
    indices, directions = reversal_indices(velocity)
    if len(indices) < 2:
        return None
    dt = float(np.median(np.diff(time_s)))
    width = int(np.median(np.diff(indices)) // 2)
    usable = [(i, d) for i, d in zip(indices, directions) if i + width <= len(residual)]
    if width < 16 or len(usable) < 2:  # (a window past the record's end is left out)
        return None
    aligned = np.mean([d * residual[i:i + width] for i, d in usable], axis=0)
    t = np.arange(width) * dt
    trend = np.column_stack([np.ones(width), t / t[-1]])

    def fit(sigma: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """(coefficients, residual vector) of the trend + damped sinusoid at (sigma, omega),
        linear in the rest (variable projection)."""
        decay = np.exp(-sigma * t)
        a = np.column_stack([trend, decay * np.sin(omega * t), decay * np.cos(omega * t)])
        coef, *_ = np.linalg.lstsq(a, aligned, rcond=None)
        return coef, a @ coef - aligned

    base_coef, *_ = np.linalg.lstsq(trend, aligned, rcond=None)
    base_rss = float(np.sum((trend @ base_coef - aligned) ** 2))
    if base_rss <= 1e-12 * float(np.sum(aligned ** 2)):  # a step or a ramp, nothing rings
        return None
    lowest = 2 * math.pi * RINGING_MIN_CYCLES / t[-1]
    best = None
    for omega in np.geomspace(lowest, math.pi / dt * 0.8, 60):
        for ratio in (0.0, 0.05, 0.15, 0.3):
            sigma = ratio * omega
            rss = float(np.sum(fit(sigma, omega)[1] ** 2))
            if best is None or rss < best[0]:
                best = (rss, sigma, omega)
    refined = least_squares(lambda p: fit(p[0], p[1])[1], [best[1], best[2]],
                            bounds=([0.0, lowest], [np.inf, math.pi / dt]), x_scale="jac")
    sigma, omega = float(refined.x[0]), float(refined.x[1])
    coef, vector = fit(sigma, omega)
    rss = float(np.sum(vector ** 2))
    if rss > best[0]:
        sigma, omega = best[1], best[2]
        coef, vector = fit(sigma, omega)
        rss = float(np.sum(vector ** 2))
    explained = 1.0 - rss / base_rss
    zeta = sigma / math.hypot(sigma, omega)
    amplitude = float(math.hypot(coef[2], coef[3]))
    if explained < RINGING_MIN_SHARE or zeta > RINGING_MAX_DAMPING or \
            amplitude < RINGING_MIN_AMPLITUDE * float(np.sqrt(np.mean(residual ** 2))):
        return None
    return Ringing(frequency_Hz=float(omega / (2 * math.pi)), damping_ratio=float(zeta),
                   amplitude_N=amplitude, explained=float(explained),
                   reversals=len(usable), window_s=float(t[-1]))


def _binned(name: str, unit: str, values: np.ndarray, residual: np.ndarray,
            edges: np.ndarray) -> Binned:
    if len(edges) < 3:
        edges = np.array([values.min(), values.max() + 1e-300])
    index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, len(edges) - 2)
    counts = np.bincount(index, minlength=len(edges) - 1)
    sums = np.bincount(index, weights=residual, minlength=len(edges) - 1)
    means = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 0)
    # Each bin at the mean regressor value of its samples (quantile bins may be very uneven).
    centers = np.divide(np.bincount(index, weights=values, minlength=len(edges) - 1), counts,
                        out=0.5 * (edges[1:] + edges[:-1]), where=counts > 0)
    total = float(np.sum((residual - residual.mean()) ** 2))
    between = float(np.sum(counts * (means - residual.mean()) ** 2))
    keep = counts > 0
    return Binned(regressor=name, unit=unit, centers=centers[keep], means=means[keep],
                  counts=counts[keep], explained=between / total if total > 0 else 0.0)


def residual_spectrum(record: Record, residual: np.ndarray) -> Spectrum | None:
    """Welch PSD (on a uniform resampling when the record is not uniform) and its peaks."""
    t = record.time_s
    if len(t) < 64:
        return None
    if record.uniform_dt_s is not None:
        dt, values = record.uniform_dt_s, residual
    else:
        dt = float(np.median(np.diff(t)))
        grid = np.arange(t[0], t[-1], dt)
        values = np.interp(grid, t, residual)
    return uniform_spectrum(values, dt)


def uniform_spectrum(values: np.ndarray, dt: float) -> Spectrum:
    """Welch PSD of a uniformly sampled residual, its smoothed floor and its peaks (both
    identification paths' ``residual_peaks_Hz``)."""
    n = len(values)
    # Segments of a quarter of the record (7 half-overlapping): fine enough to resolve a tone
    # of a few cycles per segment, averaged enough that the noise floor is smooth.
    nperseg = int(2 ** math.ceil(math.log2(max(64, n // 4))))
    frequency, psd = welch(values - values.mean(), fs=1.0 / dt, nperseg=min(nperseg, n))
    floor = median_filter(psd, size=max(15, len(psd) // 8) | 1, mode="mirror")
    return Spectrum(frequency_Hz=frequency, psd=psd, floor=floor,
                    peaks_Hz=spectral_peaks(frequency, psd, floor))


def spectral_peaks(frequency: np.ndarray, psd: np.ndarray, floor: np.ndarray) -> list[float]:
    """Frequencies of the local maxima above PEAK_FACTOR x floor that carry at least
    PEAK_MIN_SHARE of the residual variance (a line 10 dB over a very low floor can still be
    negligible), strongest first, no DC."""
    ratio = np.divide(psd, floor, out=np.zeros_like(psd), where=floor > 0)
    index, _ = find_peaks(np.concatenate([[0.0], ratio[1:]]), height=PEAK_FACTOR, distance=2)
    index = index[index > 1]  # the first bins are the record's trend, not a tone
    total = float(np.sum(psd))
    share = np.array([np.sum(psd[max(i - 2, 0):i + 3] - floor[max(i - 2, 0):i + 3]) / total
                      for i in index]) if total > 0 else np.zeros(len(index))
    index = index[share >= PEAK_MIN_SHARE]
    order = index[np.argsort(psd[index])[::-1]][:MAX_PEAKS]
    return [float(_refine(frequency, psd, i)) for i in order]


def _refine(frequency: np.ndarray, psd: np.ndarray, i: int) -> float:
    """Parabolic interpolation of the peak in log power."""
    if 0 < i < len(psd) - 1 and np.all(psd[i - 1:i + 2] > 0):
        a, b, c = np.log(psd[i - 1:i + 2])
        denom = a - 2 * b + c
        if denom < 0:
            shift = 0.5 * (a - c) / denom
            return frequency[i] + shift * (frequency[1] - frequency[0])
    return frequency[i]


def autocorrelation(residual: np.ndarray, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """(lags in samples 0..max_lag, the residual's normalized autocorrelation there), by FFT."""
    x = residual - residual.mean()
    n = len(x)
    size = 1 << (2 * n - 1).bit_length()
    spectrum = np.fft.rfft(x, size)
    acov = np.fft.irfft(spectrum * np.conj(spectrum), size)[:max_lag + 1] / n
    acf = acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)
    return np.arange(max_lag + 1), acf


def integrated_time(acf: np.ndarray) -> float:
    """tau = 1 + 2 sum_{k=1}^{M} rho_k with Sokal's window; at least 1."""
    tau = 1.0
    for m in range(1, len(acf)):
        tau += 2 * acf[m]
        if m >= SOKAL_C * tau:
            break
    return float(max(1.0, tau))


def effective_samples(residual: np.ndarray) -> float:
    """The residual's sample count over its integrated autocorrelation time: the number of
    independent samples it is worth (the BIC's n_eff)."""
    lags, acf = autocorrelation(residual, max_lag=min(len(residual) // 4, 2000))
    return len(residual) / integrated_time(acf)


__all__ = ["ResidualAnalysis", "Binned", "Spectrum", "analyse", "residual_spectrum",
           "spectral_peaks", "autocorrelation", "integrated_time", "effective_samples",
           "PEAK_FACTOR"]
