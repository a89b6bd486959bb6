"""Single-sided amplitude spectra of records over whole periods, through FFTW.

A record of M samples covering P whole excitation periods has its discrete Fourier
transform ``X_b = sum_j x_j exp(-2 pi i b j / M)`` on bins b = 0 .. M/2; bin b lies at
``b / P`` times the excitation frequency, so harmonic k is bin ``k P`` exactly (no
leakage). The amplitudes follow the lock-in's convention (:mod:`hertzsweep.lockin`):
``A_0 = X_0 / M`` is the mean, ``A_b = 2 |X_b| / M`` the peak amplitude of the line for
0 < b < M/2, and ``A_{M/2} = |X_{M/2}| / M`` at the Nyquist bin (M even), where the real
signal's line is ``A cos(pi j)``. For a record of every integration step the lines at
k P equal the lock-in's H_k to rounding.

The transforms go through pyfftw (FFTW), planned with ``FFTW_MEASURE`` once per size;
the planner's wisdom is kept on disk under ``$XDG_CACHE_HOME/hertzsweep`` (or
``~/.cache/hertzsweep``) so that a size measured once is planned at once afterwards.
numpy.fft is used only when pyfftw cannot be imported.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

try:
    import pyfftw
except ImportError:  # pragma: no cover - pyfftw is a dependency; numpy.fft is the fallback
    pyfftw = None

BACKEND = "pyfftw" if pyfftw is not None else "numpy"
WISDOM_FILE = "fftw-wisdom-double"  # FFTW's double-precision wisdom, as exported
PLANNING_TIME_LIMIT = 1.0  # [s] cap on one FFTW_MEASURE planning (FFTW keeps the best
# plan found by then): a new size costs at most about a second once, then its wisdom is
# cached; unbounded, a record of 10^5-10^6 samples took 2-5 s to plan here.
FFTW_THREADS = 1  # one transform per record, small next to the integration: no threads

_wisdom_loaded = False


def cache_directory() -> Path:
    """``$XDG_CACHE_HOME/hertzsweep``, or ``~/.cache/hertzsweep`` when it is unset."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hertzsweep"


def wisdom_path() -> Path:
    """The file holding FFTW's wisdom between runs."""
    return cache_directory() / WISDOM_FILE


def load_wisdom() -> bool:
    """Import the cached wisdom once per process; False if there is none (or it is
    unreadable: the cache is only an accelerator, never an error)."""
    global _wisdom_loaded
    if pyfftw is None:
        return False
    if _wisdom_loaded:
        return True
    _wisdom_loaded = True
    try:
        data = wisdom_path().read_bytes()
    except OSError:
        return False
    return bool(pyfftw.import_wisdom((data, b"", b""))[0])


def save_wisdom() -> None:
    """Write FFTW's double-precision wisdom to the cache (temporary file, then rename,
    so that concurrent runs never read a partial file). Failures are ignored."""
    if pyfftw is None:
        return
    data = pyfftw.export_wisdom()[0]
    path = wisdom_path()
    try:
        if path.exists() and path.read_bytes() == data:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError:
        return


def harmonic_orders(samples: int, periods: int) -> np.ndarray:
    """Bin b -> ``b / P``: the frequency of each line in multiples of the excitation's."""
    orders = np.arange(samples // 2 + 1, dtype=float)
    orders /= periods  # in place: no second array of the record's length
    return orders


class AmplitudeSpectrum:
    """Amplitude spectra of real records of one length, planned once.

    Parameters
    ----------
    samples : int
        Record length M.
    backend : {"pyfftw", "numpy"}, optional
        Default :data:`BACKEND`; "numpy" forces numpy.fft (tests compare the two).

    Notes
    -----
    With pyfftw the transform is in place: the record (minus ``offset``) is copied into
    the real view of the aligned complex output, so the only buffer besides the caller's
    arrays is M + 2 doubles.
    """

    def __init__(self, samples: int, backend: str | None = None) -> None:
        if samples < 1:
            raise ValueError(f"samples must be at least 1, got {samples}")
        self.samples = int(samples)
        self.bins = self.samples // 2 + 1
        self.backend = backend or BACKEND
        if self.backend not in ("pyfftw", "numpy"):
            raise ValueError(f"backend must be 'pyfftw' or 'numpy', got {self.backend!r}")
        if self.backend == "pyfftw" and pyfftw is None:
            raise ValueError("backend 'pyfftw' requested but pyfftw cannot be imported")
        self._plan = None
        if self.backend == "pyfftw":
            load_wisdom()
            output = pyfftw.empty_aligned(self.bins, dtype="complex128")
            self._input = output.view("float64")[: self.samples]
            self._output = output
            self._plan = pyfftw.FFTW(
                self._input,
                output,
                flags=("FFTW_MEASURE",),
                threads=FFTW_THREADS,
                planning_timelimit=PLANNING_TIME_LIMIT,
            )
            save_wisdom()

    def transform(self, signal: np.ndarray, offset: float = 0.0) -> np.ndarray:
        """``X_b`` of ``signal - offset`` (complex, M/2 + 1 bins). With pyfftw the result
        is the plan's buffer, overwritten by the next call."""
        signal = np.asarray(signal, dtype=float)
        if signal.shape != (self.samples,):
            raise ValueError(f"expected {self.samples} samples, got shape {signal.shape}")
        if self._plan is None:
            return np.fft.rfft(signal - offset)
        np.subtract(signal, offset, out=self._input)
        self._plan()
        return self._output

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
    "amplitude_spectrum",
    "cache_directory",
    "harmonic_orders",
    "load_wisdom",
    "save_wisdom",
    "wisdom_path",
]
