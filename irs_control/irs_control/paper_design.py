"""Paper case (Eq. 6, 21-25): identified plant, reference model and MRC designs.

PROVISIONAL: full reconstruction notes follow (see docs/control_design.md).

``PAPER_PLANT_GAIN`` = 2308 * 3744 / 23779 = 363.39 [m/(rad s^3)] from T(0) = 23779 with
T = Ao Bm / b0 (all plant zeros cancelled, so B- = b0).
"""
from __future__ import annotations

import numpy as np

from .polynomials import poly_from_roots, poly_mul
from .rst_design import RstDesign, design_rst

#: Plant high-frequency gain b0 [m rad^-1 s^-3]: T(0) = Ao(0) Bm(0) / b0 = 23779.
PAPER_PLANT_GAIN = 2308.0 * 26.0 * 144.0 / 23779.0
#: Actuator pole [rad/s] (4.6 Hz first-order lag; 2 pi 4.6 = 28.90, paper prints 29).
PAPER_ACTUATOR_POLE = 29.0
PAPER_VEHICLE_POLES = (0.0, 0.0, -8.0, -20.0)
PAPER_ZEROS = (-2.4, -4.8)


def identified_plant(include_actuator: bool = True, actuator_pole: float = PAPER_ACTUATOR_POLE,
                     gain: float = PAPER_PLANT_GAIN):
    """Identified steer -> lateral-sensor-displacement plant ``B/A`` (Eq. 6), s-domain."""
    poles = list(PAPER_VEHICLE_POLES)
    if include_actuator:
        poles.append(-abs(actuator_pole))
    return poly_from_roots(PAPER_ZEROS, gain=gain), poly_from_roots(poles)


def reference_model():
    """Reference model Eq. 21 ``(Bm, Am)``."""
    return 2308.0 * np.array([1.0, 10.0, 26.0]), poly_mul([1, 8, 25], [1, 16, 80], [1, 30])


def paper_observer():
    """Observer polynomial Eq. 25, ``(s + 12)**2``."""
    return np.array([1.0, 24.0, 144.0])


def paper_mrc_design(include_actuator: bool = True) -> RstDesign:
    B, A = identified_plant(include_actuator)
    Bm, Am = reference_model()
    Ao = paper_observer() if include_actuator else np.array([1.0, 12.0])
    return design_rst(B, A, Bm, Am, Ao, cancel="stable")
