"""The one record of what a dwell reads: field names shared by results and datasets.

Every result (sweep, trace, branch, study case) stores one array per name below, with
the same name, and the dataset layer builds its variables by iterating these tuples, so
a reading added here appears everywhere at once.
"""

from __future__ import annotations

HARMONIC_FIELDS = ("amplitude", "phase")  # per harmonic k: A_k, phi_k [degree]
SCALAR_FIELDS = (  # per dwell
    "mean_force",  # mean N/F_s
    "force_max",  # extremes of N/F_s over the measured periods
    "force_min",
    "contact_loss_fraction",  # share of the measured time out of contact
    "flight_tau",  # longest flight in tau (the dataset writes flight_time [s] = tau / Omega)
)
READING_FIELDS = HARMONIC_FIELDS + SCALAR_FIELDS

__all__ = ["HARMONIC_FIELDS", "READING_FIELDS", "SCALAR_FIELDS"]
