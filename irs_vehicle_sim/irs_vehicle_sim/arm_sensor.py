"""Simulated potentiometer readings of the position-sensing arm (paper Sec. 3.2).

The true joint angles come from :func:`irs_models.arm_kinematics.inverse_kinematics` for the
car's c.g. pose ``(x, y, psi)``.  Each reading is then::

    theta_meas = Q( theta_true + n ),   n ~ N(0, sigma^2)   (if noise enabled)
    Q(a) = lsb * round(a / lsb)                             (if quantisation enabled)

with ``lsb = adc_range / 2**adc_bits`` [rad], or ``lsb`` given directly (``lsb > 0`` overrides
bits/range).  Noise is drawn from a ``numpy.random.Generator`` seeded by ``seed``: three draws
per call, in joint order; when the noise is disabled no draws are made.

It exists so that the estimator sees readings with the resolution and noise of the paper's
potentiometers; the values and why they are chosen: :class:`ArmSensorParams`.
"""

from __future__ import annotations

import math
from typing import ClassVar
from dataclasses import dataclass

import numpy as np

from irs_models.arm_kinematics import ArmGeometry, inverse_kinematics

__all__ = ['ArmSensorParams', 'ArmSensor', 'quantize', 'ENCODER_STEP', 'POT_RESOLUTION_RATIO',
           'POT_STEP']

#: Joint-encoder angle step [rad]: 1024 lines x 4 (quadrature) per turn; assumed (ArmSensorParams).
ENCODER_STEP = 2.0 * math.pi / 4096
#: Paper Sec. 3.2: the encoders had 1/10 the angular resolution of a potentiometer.
POT_RESOLUTION_RATIO = 10
#: Potentiometer angle step [rad] = ENCODER_STEP / 10 = 0.1534 mrad (default ``lsb`` and noise).
POT_STEP = ENCODER_STEP / POT_RESOLUTION_RATIO


def quantize(angle: float, lsb: float) -> float:
    """Round ``angle`` [rad] to the nearest multiple of ``lsb`` [rad] (mid-tread quantiser)."""
    return lsb * round(angle / lsb)


@dataclass
class ArmSensorParams:
    """Potentiometer model parameters.

    Resolution and noise (paper Sec. 3.2; the paper prints no numbers for either): the joint
    encoders tried first "had only 1/10 the angular resolution of a potentiometer", and the
    potentiometers were "found to be a better sensor". So the pots resolve angles **10x finer**
    than the encoders:

    * encoder step ``ENCODER_STEP = 2 pi / 4096 = 1.534 mrad`` (0.088 deg), *assumed*: a 1024-line
      quadrature encoder read x4, the common hobby/lab part of the time (the paper gives no count);
    * pot step ``POT_STEP = ENCODER_STEP / 10 = 0.1534 mrad`` (0.0088 deg), the paper's ratio, used
      as the quantisation step ``lsb`` directly (the converter is not known: 12 bit over 360 deg
      gives the encoder's 1.534 mrad, 16 bit 0.096 mrad);
    * noise ``noise_std = POT_STEP = 0.1534 mrad`` per joint, *assumed*: a sensor chain whose noise
      exceeds its step does not have the stated resolution, so the noise is taken at the largest
      value consistent with it (one step rms). On the 1 m + 1 m arm this gives y_s noise of about
      0.2 mm rms (a 0.5 mrad noise gives 0.9 mm and makes the pots noisier than the encoders they
      beat).

    ``adc_bits`` / ``adc_range`` give the step instead when ``lsb = 0`` (e.g. 12 bit over 2 pi =
    the encoder's 1.534 mrad).

    Attributes
    ----------
    noise_std : float
        Gaussian noise standard deviation per joint [rad] (default :data:`POT_STEP`, assumed).
    enable_noise : bool
    adc_bits : int
        ADC resolution [bits] (default 12; used only when ``lsb = 0``).
    adc_range : float
        Angle spanned by the full ADC range [rad] (default 2 pi; used only when ``lsb = 0``).
    lsb : float
        Quantisation step [rad] (default :data:`POT_STEP` = 0.1534 mrad, paper Sec. 3.2);
        0 means ``adc_range / 2**adc_bits``.
    enable_quantization : bool
    seed : int
        Seed of the noise generator.
    """

    noise_std: float = POT_STEP
    enable_noise: bool = True
    adc_bits: int = 12
    adc_range: float = 2.0 * math.pi
    lsb: float = POT_STEP
    enable_quantization: bool = True
    seed: int = 0

    def validate(self) -> None:
        if not (math.isfinite(self.noise_std) and self.noise_std >= 0.0):
            raise ValueError(
                f'noise_std must be a non-negative angle in rad, got {self.noise_std!r}'
            )
        if not (isinstance(self.adc_bits, int) and 1 <= self.adc_bits <= 32):
            raise ValueError(f'adc_bits must be an integer in [1, 32], got {self.adc_bits!r}')
        if not (math.isfinite(self.adc_range) and self.adc_range > 0.0):
            raise ValueError(f'adc_range must be a positive angle in rad, got {self.adc_range!r}')
        if not (math.isfinite(self.lsb) and self.lsb >= 0.0):
            raise ValueError(
                f'lsb must be a non-negative angle in rad (0 = from bits), got {self.lsb!r}'
            )

    @property
    def step_size(self) -> float:
        """Quantisation step [rad]."""
        return self.lsb if self.lsb > 0.0 else self.adc_range / 2 ** self.adc_bits


class ArmSensor:
    """Three potentiometer angles for a car pose.

    Parameters
    ----------
    geometry : irs_models.arm_kinematics.ArmGeometry
    params : ArmSensorParams
    """

    def __init__(self, geometry: ArmGeometry | None = None, params: ArmSensorParams | None = None):
        self.geometry = geometry if geometry is not None else ArmGeometry()
        self.params = params if params is not None else ArmSensorParams()
        self.params.validate()
        self.reset()

    #: Standard normal draws taken from the generator at a time. The generator's stream is
    #: consumed in the same order as by three ``normal(0, sigma)`` draws per call, and
    #: ``0 + sigma z`` is what numpy computes for each of them, so every reading is the same to
    #: the bit (tested); drawn one at a time, numpy's per-call overhead on 3-element arrays is
    #: most of the arm model's cost in the 1 kHz loop.
    NOISE_BLOCK: ClassVar[int] = 3 * 1024

    def reset(self) -> None:
        """Re-seed the noise generator."""
        self.rng = np.random.default_rng(self.params.seed)
        self._z: list = []     # standard normals drawn ahead, consumed from index _zi
        self._zi = 0

    def true_angles(self, x: float, y: float, psi: float) -> tuple:
        """Noise-free joint angles (theta1, theta2, theta3) [rad]; raises ``ArmReachError``."""
        return inverse_kinematics(x, y, psi, self.geometry)

    def measure(self, x: float, y: float, psi: float) -> np.ndarray:
        """Measured joint angles [rad], shape (3,)."""
        return np.array(self.measure_tuple(x, y, psi))

    def measure_tuple(self, x: float, y: float, psi: float) -> tuple:
        """Measured joint angles (theta1, theta2, theta3) [rad] as floats (module docstring)."""
        t1, t2, t3 = self.true_angles(x, y, psi)
        p = self.params
        if p.enable_noise and p.noise_std > 0.0:
            z, i = self._z, self._zi
            if i + 3 > len(z):
                z = self._z = self.rng.standard_normal(self.NOISE_BLOCK).tolist()
                i = 0
            s = p.noise_std
            t1 += 0.0 + s * z[i]
            t2 += 0.0 + s * z[i + 1]
            t3 += 0.0 + s * z[i + 2]
            self._zi = i + 3
        if p.enable_quantization:
            q = p.step_size
            t1, t2, t3 = _on_grid(t1, q), _on_grid(t2, q), _on_grid(t3, q)
        return t1, t2, t3


def _on_grid(a: float, q: float) -> float:
    """``q * rint(a / q)`` exactly as numpy computes it: half to even, and the sign of a zero
    kept (numpy's ``round(-0.3)`` is ``-0.0``, Python's ``round`` the integer 0).
    """
    k = round(a / q)
    return q * (k if k else math.copysign(0.0, a))
