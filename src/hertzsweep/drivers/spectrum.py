"""Single-sided amplitude spectra of records over whole periods, through FFTW.

A record of M samples covering P whole excitation periods has its discrete Fourier
transform ``X_b = sum_j x_j exp(-2 pi i b j / M)`` on bins b = 0 .. M/2; bin b lies at
``b / P`` times the excitation frequency, so harmonic k is bin ``k P`` exactly (no
leakage). The amplitudes follow the lock-in's convention (:mod:`hertzsweep.core.lockin`):
``A_0 = X_0 / M`` is the mean, ``A_b = 2 |X_b| / M`` the peak amplitude of the line for
0 < b < M/2, and ``A_{M/2} = |X_{M/2}| / M`` at the Nyquist bin (M even), where the real
signal's line is ``A cos(pi j)``. For a record of every integration step the lines at
k P equal the lock-in's H_k to rounding.

The transforms go through pyfftw (FFTW), planned with ``FFTW_ESTIMATE`` (no measuring,
so planning a new length costs nothing and nothing is written to disk); a plan is kept
per length for the life of the process (:func:`fftw_plan`). numpy.fft is used when
pyfftw is not installed. pyfftw is imported only when a spectrum is first computed.

:class:`RealRows` transforms the rows of one buffer (the random run's Welch segments)
with one plan of the one-dimensional transform, a row at a time.
"""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

BACKEND = "pyfftw" if importlib.util.find_spec("pyfftw") is not None else "numpy"
BACKENDS = ("pyfftw", "numpy")
FFTW_FLAGS = ("FFTW_ESTIMATE",)  # a plan from heuristics: instant for any length, and
# one real transform per record is small next to the integration that made the record
FFTW_THREADS = 1  # one transform per record, small next to the integration: no threads
CACHED_PLANS = 4  # lengths whose plan (and M + 2 doubles of buffer) a process keeps
ROW_ALIGNMENT = 64  # bytes: where every row of a RealRows buffer starts (a cache line,
# and FFTW's SIMD alignment)


@dataclass(frozen=True)
class FFTWPlan:
    """An FFTW plan of the real transform of one length, with its aligned buffers.

    ``samples`` is the real view of ``output`` that the plan reads: the transform is in
    place, so the plan holds M + 2 doubles.
    """

    execute: Any
    samples: np.ndarray
    output: np.ndarray


@lru_cache(maxsize=CACHED_PLANS)
def fftw_plan(samples: int) -> FFTWPlan:
    """The process's plan for records of ``samples`` values (made on first use)."""
    pyfftw = _import_pyfftw()
    output = pyfftw.empty_aligned(samples // 2 + 1, dtype="complex128")
    real = output.view("float64")[:samples]
    execute = pyfftw.FFTW(real, output, flags=FFTW_FLAGS, threads=FFTW_THREADS)
    return FFTWPlan(execute, real, output)


class RealRows:
    """Real FFTs of length M, in place, of the rows of one buffer, one row at a time.

    Parameters
    ----------
    rows : int
        The buffer's rows.
    samples : int
        M, the length of each row's transform.
    backend : {"pyfftw", "numpy"}, optional
        Default :data:`BACKEND`.

    Notes
    -----
    A row's samples (``samples[i]``, float[M]) are the real view of its bins
    (``spectra[i]``, complex[M/2 + 1]): :meth:`transform` overwrites them. With pyfftw
    every row is transformed by one plan of the one-dimensional transform of length M
    (:data:`FFTW_FLAGS`, made on row 0, executed on each row in turn: each row starts at
    the same alignment, its length padded to :data:`ROW_ALIGNMENT` bytes), so that a
    row's spectrum is the same bit for bit whatever the buffer's number of rows; numpy.fft
    transforms row by row likewise.
    """

    def __init__(self, rows: int, samples: int, backend: str | None = None) -> None:
        self.backend = backend or BACKEND
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be 'pyfftw' or 'numpy', got {self.backend!r}")
        if self.backend == "pyfftw" and BACKEND != "pyfftw":
            raise ValueError("backend 'pyfftw' requested but pyfftw is not installed")
        bins = samples // 2 + 1
        per_row = ROW_ALIGNMENT // 16  # complex values in ROW_ALIGNMENT bytes
        shape = (rows, -(-bins // per_row) * per_row)
        if self.backend == "pyfftw":
            pyfftw = _import_pyfftw()
            buffer = pyfftw.empty_aligned(shape, dtype="complex128", n=ROW_ALIGNMENT)
            buffer[:] = 0.0
        else:
            buffer = np.zeros(shape, dtype=complex)
        self.samples = buffer.view("float64")[:, :samples]
        self.spectra = buffer[:, :bins]
        self._plan = None
        if self.backend == "pyfftw" and rows > 0:
            self._plan = pyfftw.FFTW(
                self.samples[0], self.spectra[0], flags=FFTW_FLAGS, threads=FFTW_THREADS
            )

    def transform(self, first: int, stop: int) -> None:
        """Rows ``first .. stop - 1``: their samples replaced by their bins."""
        for row in range(first, stop):
            if self._plan is None:
                self.spectra[row] = np.fft.rfft(self.samples[row])
            else:
                self._plan.update_arrays(self.samples[row], self.spectra[row])
                self._plan.execute()


def _import_pyfftw() -> Any:
    """pyfftw, without the dask interface it loads when dask is installed.

    ``import pyfftw`` imports ``pyfftw.interfaces``, which imports ``dask.array`` (and
    with it pandas: about 1 s) to offer a dask FFT that hertzsweep does not use. While
    dask has not been imported, it is hidden for the duration of the import (a ``None``
    entry in ``sys.modules`` makes the import fail at once, and pyfftw skips that
    interface); where dask is already loaded, pyfftw is imported as it is.
    """
    if "pyfftw" in sys.modules or "dask" in sys.modules:
        import pyfftw

        return pyfftw
    sys.modules["dask"] = None  # type: ignore[assignment]
    try:
        import pyfftw
    finally:
        del sys.modules["dask"]
    return pyfftw


def harmonic_orders(samples: int, periods: int) -> np.ndarray:
    """Bin b -> ``b / P``: the frequency of each line in multiples of the excitation's."""
    orders = np.arange(samples // 2 + 1, dtype=float)
    orders /= periods  # in place: no second array of the record's length
    return orders


class AmplitudeSpectrum:
    """Amplitude spectra of real records of one length.

    Parameters
    ----------
    samples : int
        Record length M.
    backend : {"pyfftw", "numpy"}, optional
        Default :data:`BACKEND`; "numpy" forces numpy.fft (tests compare the two).

    Notes
    -----
    With pyfftw the transform is in place: the record (minus ``offset``) is copied into
    the real view of the aligned complex output of the length's plan
    (:func:`fftw_plan`), so the only buffer besides the caller's arrays is M + 2 doubles,
    shared by every spectrum of that length in the process.
    """

    def __init__(self, samples: int, backend: str | None = None) -> None:
        if samples < 1:
            raise ValueError(f"samples must be at least 1, got {samples}")
        self.samples = int(samples)
        self.bins = self.samples // 2 + 1
        self.backend = backend or BACKEND
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be 'pyfftw' or 'numpy', got {self.backend!r}")
        if self.backend == "pyfftw" and BACKEND != "pyfftw":
            raise ValueError("backend 'pyfftw' requested but pyfftw is not installed")
        self._plan = fftw_plan(self.samples) if self.backend == "pyfftw" else None

    def buffer(self) -> np.ndarray:
        """float[M]: where to put a signal that is transformed without a copy (with pyfftw
        the plan's own input, overwritten by the next transform of this length)."""
        return np.empty(self.samples) if self._plan is None else self._plan.samples

    def transform(self, signal: np.ndarray, offset: float = 0.0) -> np.ndarray:
        """``X_b`` of ``signal - offset`` (complex, M/2 + 1 bins). With pyfftw the result
        is the plan's buffer, overwritten by the next transform of that length."""
        signal = np.asarray(signal, dtype=float)
        if signal.shape != (self.samples,):
            raise ValueError(f"expected {self.samples} samples, got shape {signal.shape}")
        if self._plan is None:
            return np.fft.rfft(signal - offset)
        np.subtract(signal, offset, out=self._plan.samples)
        self._plan.execute()
        return self._plan.output

    def amplitude(
        self, signal: np.ndarray, offset: float = 0.0, out: np.ndarray | None = None
    ) -> np.ndarray:
        """Single-sided amplitude spectrum of ``signal`` (see the module's convention).

        Parameters
        ----------
        signal : float[M]
            Samples over whole periods, the first at phase 0.
        offset : float
            A known constant removed before the transform and added back to the mean
            (the static load, so that small lines lose no digits to it).
        out : float[M/2 + 1], optional
            Where to write the amplitudes.
        """
        spectrum = self.transform(signal, offset)
        if out is None:
            out = np.empty(self.bins)
        np.abs(spectrum, out=out)
        out *= 2.0 / self.samples
        out[0] = spectrum[0].real / self.samples + offset
        if self.samples % 2 == 0 and self.bins > 1:
            out[-1] *= 0.5
        return out


def amplitude_spectrum(
    signal: np.ndarray, offset: float = 0.0, backend: str | None = None
) -> np.ndarray:
    """One-off single-sided amplitude spectrum of a record (see the module's notes)."""
    signal = np.asarray(signal, dtype=float)
    return AmplitudeSpectrum(signal.size, backend).amplitude(signal, offset)


__all__ = [
    "BACKEND",
    "AmplitudeSpectrum",
    "FFTWPlan",
    "RealRows",
    "amplitude_spectrum",
    "fftw_plan",
    "harmonic_orders",
]
