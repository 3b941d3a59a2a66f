#!/usr/bin/env python3
"""Memory of the vibration fit (identification's `vibration_band`) on long records.

A measured support velocity (4 kHz, an amplitude modulated at 5 Hz so that the envelopes need
a knot every period, white noise) of N samples at 100 kHz is fitted twice in one run: with the
design assembled in chunks (`replay.ENVELOPE_CHUNK_SAMPLES`, the default) and all at once (the
same code with one chunk as long as the record; the fit before chunking, with a general sparse
solve, needed as much or more). Prints the peak Python allocation (tracemalloc) per
sample of each, their ratio, the time of each and the largest difference between the fits.

    python scripts/bench_band_memory.py [--seconds 2.0 4.0]
"""
from __future__ import annotations

import argparse
import math
import time
import tracemalloc

import numpy as np

from vibrofriction.identify import replay

DT_S, FREQUENCY_HZ = 1e-5, 4000.0


def measured(n: int, chunk: int) -> tuple[np.ndarray, float, float]:
    t = DT_S * np.arange(n)
    noise = 2e-5 * np.random.default_rng(0).standard_normal(n)
    velocity = 1.5e-3 * (1 + 0.3 * np.sin(2 * math.pi * 5 * t)) * np.cos(
        2 * math.pi * FREQUENCY_HZ * t) + noise
    saved = replay.ENVELOPE_CHUNK_SAMPLES
    replay.ENVELOPE_CHUNK_SAMPLES = chunk
    try:
        tracemalloc.start()
        started = time.perf_counter()
        band = replay._vibration_band(velocity, DT_S, FREQUENCY_HZ)
        seconds = time.perf_counter() - started
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        replay.ENVELOPE_CHUNK_SAMPLES = saved
    return band, peak / n, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, nargs="+", default=[2.0, 4.0],
                        help="record lengths at 100 kHz (default: 2 4)")
    args = parser.parse_args()
    print("| record | chunked: bytes/sample, s | at once: bytes/sample, s | memory ratio | "
          "largest difference (of the amplitude) |")
    print("|---|---|---|---|---|")
    for seconds in args.seconds:
        n = int(round(seconds / DT_S))
        chunked, chunked_bytes, chunked_s = measured(n, replay.ENVELOPE_CHUNK_SAMPLES)
        whole, whole_bytes, whole_s = measured(n, n)
        difference = float(np.max(np.abs(chunked - whole))) / 1.5e-3
        print(f"| {seconds:g} s ({n} samples) | {chunked_bytes:.0f}, {chunked_s:.1f} | "
              f"{whole_bytes:.0f}, {whole_s:.1f} | {whole_bytes / chunked_bytes:.1f}x | "
              f"{difference:.1e} |", flush=True)


if __name__ == "__main__":
    main()
