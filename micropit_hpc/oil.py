"""A lubricant by its grade: viscosity at temperature (ASTM D341) and pressure–viscosity α.

``[lubricant]`` may give the oil as an engineer knows it, the ISO viscosity grade (``iso_vg``,
ISO 3448: the grade is the kinematic viscosity at 40 °C in mm²/s, the midpoint of a ±10 %
class) or ``nu40_cSt``, with ``nu100_cSt`` and the oil temperature ``temperature_C``. From them:

* ν(θ) by the Ubbelohde–Walther equation of ASTM D341,
  ``log10 log10(ν + 0.7) = A − B log10 T`` (ν in mm²/s, T in K), A and B through the two
  given points (40 °C and 100 °C). The constant 0.7 is the standard's for ν ≥ 2 mm²/s.
* ρ(θ) = ρ15 [1 − 0.0007 (θ − 15 °C)] (a linear thermal expansion of 0.07 %/K, typical of
  mineral gear oils; ``density_15C_kg_m3`` default 880 kg/m³), η0 = ν ρ.
* α by Wooster's correlation (W. A. Wooster, Br. J. Appl. Phys. 8 (1957); as given in
  G. W. Stachowiak & A. W. Batchelor, *Engineering Tribology*, ch. 2):
  ``α = (0.6 + 0.965 log10 η0[cP]) × 10⁻⁸ m²/N`` at the temperature's η0. It reproduces the
  measured α of the mineral oils tabulated there (30–100 °C) within 20 %
  (tests/test_oil.py). A synthetic oil (PAO, PAG, ester) has its own α: give
  ``alpha_pv_1_per_GPa`` from its datasheet.

Explicit ``eta0_mPas`` and ``alpha_pv_1_per_GPa`` always win over the derived values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: ISO 3448 viscosity grades (kinematic viscosity at 40 °C, mm²/s, midpoint).
ISO_VG = (2, 3, 5, 7, 10, 15, 22, 32, 46, 68, 100, 150, 220, 320, 460, 680, 1000, 1500, 2200,
          3200)
WALTHER_C = 0.7          #: ASTM D341's constant for ν ≥ 2 mm²/s
EXPANSION_PER_K = 7e-4   #: linear thermal expansion of the density (mineral oils)
DEFAULT_DENSITY_15C = 880.0


def walther_constants(nu40: float, nu100: float) -> tuple[float, float]:
    """(A, B) of ASTM D341, ``log10 log10(ν + 0.7) = A − B log10 T``, through ν(40 °C) and
    ν(100 °C) [mm²/s]."""
    t40, t100 = math.log10(313.15), math.log10(373.15)
    w40 = math.log10(math.log10(nu40 + WALTHER_C))
    w100 = math.log10(math.log10(nu100 + WALTHER_C))
    B = (w40 - w100) / (t100 - t40)
    return w40 + B * t40, B


def walther_viscosity(nu40: float, nu100: float, temperature_C: float) -> float:
    """Kinematic viscosity ν(θ) [mm²/s] by ASTM D341 (Ubbelohde–Walther):
    ν = 10^(10^(A − B log10 T)) − 0.7, T = θ + 273.15 K, A and B from
    :func:`walther_constants`."""
    A, B = walther_constants(nu40, nu100)
    return 10.0 ** (10.0 ** (A - B * math.log10(temperature_C + 273.15))) - WALTHER_C


def density(rho15: float, temperature_C: float) -> float:
    """ρ(θ) = ρ15 [1 − 0.0007 (θ − 15 °C)] [kg/m³] (linear expansion of mineral oils)."""
    return rho15 * (1.0 - EXPANSION_PER_K * (temperature_C - 15.0))


def wooster_alpha(eta_Pas: float) -> float:
    """Barus pressure–viscosity coefficient α [1/Pa] from the viscosity at the same
    temperature, Wooster (1957): α = (0.6 + 0.965 log10 η[cP]) × 10⁻⁸ m²/N (η in mPa·s = cP)."""
    return (0.6 + 0.965 * math.log10(eta_Pas * 1e3)) * 1e-8


@dataclass(frozen=True)
class OilAtTemperature:
    """What a grade gives at ``temperature_C``: ν [mm²/s], ρ [kg/m³], η0 [Pa·s], α [1/Pa]
    and a line saying how each was obtained (printed and recorded in results.h5)."""

    temperature_C: float
    nu40: float
    nu100: float
    nu: float
    rho: float
    eta0: float
    alpha: float

    def describe(self, eta_given: bool = False, alpha_given: bool = False) -> str:
        eta = ("η0 given by lubricant.eta0_mPas" if eta_given else
               f"η0 = ν ρ = {self.eta0 * 1e3:.4g} mPa·s (ν = {self.nu:.4g} mm²/s by ASTM D341 "
               f"Walther from ν40 = {self.nu40:g}, ν100 = {self.nu100:g} mm²/s; ρ = "
               f"{self.rho:.4g} kg/m³)")
        alpha = ("α given by lubricant.alpha_pv_1_per_GPa" if alpha_given else
                 f"α = {self.alpha * 1e9:.4g} 1/GPa (Wooster 1957: (0.6 + 0.965 log10 η0[cP])"
                 " × 1e-8 m²/N)")
        return f"lubricant at {self.temperature_C:g} °C: {eta}; {alpha}"


def oil_at(nu40: float, nu100: float, temperature_C: float,
           rho15: float = DEFAULT_DENSITY_15C) -> OilAtTemperature:
    """The oil of ν40, ν100 [mm²/s] and density ρ15 [kg/m³] at ``temperature_C``."""
    nu = walther_viscosity(nu40, nu100, temperature_C)
    rho = density(rho15, temperature_C)
    eta = nu * 1e-6 * rho
    return OilAtTemperature(temperature_C=temperature_C, nu40=nu40, nu100=nu100, nu=nu,
                            rho=rho, eta0=eta, alpha=wooster_alpha(eta))
