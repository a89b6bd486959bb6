"""The Welch sums of a random run: a segment's windowed rows and the sums of their spectra.

A segment of S steps holds a column per trajectory (``N/F_s - 1``, float[S, T]) or per
realisation (the unit forcing g, float[S, R]). :func:`column_means` forms every column's
mean; :func:`windowed` writes a block of columns, each with its mean removed and times
the window, as rows of the buffer that the driver transforms (a real FFT of length S a
row, one row at a time, so that a column's spectrum does not depend on how many columns
there are); :func:`add_spectra` adds a block of the trajectories' spectra ``X`` to their
sums ``S_NN``, ``S_ff`` and ``S_fN`` with the force ``F = level G`` of their realisation
(G its spectrum).

``|X|^2`` is ``re^2 + im^2`` and ``conj(F) X`` is ``(a c - b d, a d + b c)`` for ``conj(F)
= a + i b``, ``X = c + i d`` (numpy's complex product may fuse its multiply-adds: the
same to round-off).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import CACHE


@njit(cache=CACHE, error_model="numpy", nogil=True)
def column_means(x, out):
    """``out[c]`` = the mean of column c of x (float[S, n]): the values summed in step
    order, every column at once (a row at a time, vectorised across the columns), then
    divided by S. A column's mean does not depend on the other columns."""
    out[:] = 0.0
    columns = x.shape[1]
    for i in range(x.shape[0]):
        row = x[i]
        for c in range(columns):
            out[c] += row[c]
    for c in range(columns):
        out[c] /= x.shape[0]


@njit(cache=CACHE, error_model="numpy", nogil=True)
def windowed(x, columns, mean, window, rows):
    """``rows[j, :S] = (x[:, c + j] - mean[c + j]) * window`` for ``columns = (c,
    width)``, j < width: x float[S, n], window float[S], rows float[>= width, >= S]; the
    columns' means removed, times the window."""
    c0, width = columns
    means = mean[c0 : c0 + width].copy()
    steps = x.shape[0]
    grouped = steps - steps % 4
    for i in range(0, grouped, 4):  # 4 steps at a time: 4 adjacent values of each row
        w0 = window[i]
        w1 = window[i + 1]
        w2 = window[i + 2]
        w3 = window[i + 3]
        for j in range(width):
            c = c0 + j
            m = means[j]
            out = rows[j]
            out[i] = (x[i, c] - m) * w0
            out[i + 1] = (x[i + 1, c] - m) * w1
            out[i + 2] = (x[i + 2, c] - m) * w2
            out[i + 3] = (x[i + 3, c] - m) * w3
    for i in range(grouped, steps):
        for j in range(width):
            rows[j, i] = (x[i, c0 + j] - means[j]) * window[i]


@njit(cache=CACHE, error_model="numpy", nogil=True)
def add_spectra(spectra, force, drive, trajectories, sums):
    """Add the spectra of trajectories ``c .. c + width - 1`` (``trajectories = (c,
    width)``; ``spectra`` complex[>= width, >= K + 1], row j trajectory c + j) to their
    rows of ``sums = (nn, ff, fn)`` (float[T, K], float[T, K], complex[T, K]): with
    ``X = spectra[j, 1 : K + 1]`` (the bins inside (0, Nyquist)) and ``F = level G``
    (``G = force[realisation, 1 : K + 1]``, ``drive`` a RandomDrive), ``|X|^2``,
    ``|F|^2`` and ``conj(F) X``."""
    nn, ff, fn = sums
    c0, width = trajectories
    for j in range(width):
        t = c0 + j
        level = drive.level[t]
        g = force[drive.realisation[t]].view(np.float64)  # re, im of bin b at 2b, 2b + 1
        x = spectra[j].view(np.float64)
        power, forcing, cross = nn[t], ff[t], fn[t].view(np.float64)
        for k in range(nn.shape[1]):  # bin k + 1
            xr = x[2 * k + 2]
            xi = x[2 * k + 3]
            fr = level * g[2 * k + 2]
            fi = -(level * g[2 * k + 3])  # conj(F)
            power[k] += xr * xr + xi * xi
            forcing[k] += fr * fr + fi * fi
            cross[2 * k] += fr * xr - fi * xi
            cross[2 * k + 1] += fr * xi + fi * xr
