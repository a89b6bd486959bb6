"""The one record of what a dwell reads: field names shared by results and datasets.

Every result (sweep, trace, branch, study case) stores one array per name below, with
the same name, and the dataset layer builds its variables by iterating these tuples, so
a reading added here appears everywhere at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HARMONIC_FIELDS = ("amplitude", "phase")  # per harmonic k: A_k, phi_k [degree]
SCALAR_FIELDS = (  # per dwell
    "mean_force",  # mean N/F_s
    "force_max",  # extremes of N/F_s over the measured periods
    "force_min",
    "contact_loss_fraction",  # share of the measured time out of contact
    "flight_tau",  # longest flight in tau (the dataset writes flight_time [s] = tau / Omega)
)
READING_FIELDS = HARMONIC_FIELDS + SCALAR_FIELDS
BALL_FIELDS = {  # the ball model's own readings (model.kind = "ball"), and how two blocks
    # of readings combine: the force and flights above are then the lower contact's
    "upper_force_max": "max",  # extremes of the upper contact's force over F_s
    "upper_force_min": "min",
    "upper_contact_loss_fraction": "mean",  # share of the time the upper contact is open
    "ball_flight_fraction": "mean",  # share of the time both contacts are open
    "ball_flight_tau": "max",  # the ball's longest flight (both open) in tau
}


@dataclass
class Readings:
    """One array per reading field, on a result's own dimensions (those of a scalar
    reading, plus ``harmonic`` for :data:`HARMONIC_FIELDS`); the base of every result."""

    amplitude: np.ndarray
    phase: np.ndarray
    mean_force: np.ndarray
    force_max: np.ndarray
    force_min: np.ndarray
    contact_loss_fraction: np.ndarray
    flight_tau: np.ndarray


__all__ = ["BALL_FIELDS", "HARMONIC_FIELDS", "READING_FIELDS", "SCALAR_FIELDS", "Readings"]
