"""Central EHL film thickness of the smooth contact and the specific film thickness Λ.

docs/model.md §2.4. Dimensionless groups: U = η0 ū / (E' R), G = α E', W = w / (E' R) (line) or
W = F / (E' R_x²) (point). η0 is the inlet viscosity [Pa s], α the pressure-viscosity
coefficient [1/Pa], ū the entrainment speed [m/s]. All functions are vectorised over their
array arguments.
"""

from __future__ import annotations

import numpy as np

FILM_MODELS = ("DH61", "DH66", "HD77c")
THERMAL_MODELS = ("none", "wilson_sheu")


def dowson_higginson_1961(R, u_mean, w, E_prime, eta0, alpha):
    """Line contact, h_c = 1.6 R G^0.6 U^0.7 W^-0.13.

    Dowson & Higginson (1961), the form used by ISO/TS 6336-22 and ISO/TR 15144-1; it
    reproduces the h_c column of the paper's Table 3 (docs/model.md §2.4, §2.5).
    """
    R, u, w = (np.asarray(v, dtype=float) for v in (R, u_mean, w))
    U = eta0 * u / (E_prime * R)
    G = alpha * E_prime
    W = w / (E_prime * R)
    return 1.6 * R * G**0.6 * U**0.7 * W**-0.13


def dowson_higginson_1966(R, u_mean, w, E_prime, eta0, alpha):
    """Line contact, h_c = 2.65 R U^0.70 G^0.54 W^-0.13 (Dowson & Higginson 1966;
    docs/model.md §2.4)."""
    R, u, w = (np.asarray(v, dtype=float) for v in (R, u_mean, w))
    U = eta0 * u / (E_prime * R)
    G = alpha * E_prime
    W = w / (E_prime * R)
    return 2.65 * R * U**0.70 * G**0.54 * W**-0.13


def ellipticity_parameter(Rx, Ry):
    """k ≈ 1.0339 (R_y/R_x)^0.636 (Hamrock & Brewe 1983), used by :func:`hamrock_dowson_1977`."""
    return 1.0339 * (np.asarray(Ry, dtype=float) / np.asarray(Rx, dtype=float)) ** 0.636


def hamrock_dowson_1977(Rx, Ry, u_mean, F, E_prime, eta0, alpha):
    """Elliptical point contact, central film (Hamrock & Dowson 1977; docs/model.md §2.4):

    h_c = 2.69 R_x U^0.67 G^0.53 W^-0.067 (1 - 0.61 e^{-0.73 k}),
    U = η0 ū / (E' R_x), W = F / (E' R_x²), k = 1.0339 (R_y/R_x)^0.636.
    """
    Rx, u, F = (np.asarray(v, dtype=float) for v in (Rx, u_mean, F))
    U = eta0 * u / (E_prime * Rx)
    G = alpha * E_prime
    W = F / (E_prime * Rx**2)
    k = ellipticity_parameter(Rx, Ry)
    return 2.69 * Rx * U**0.67 * G**0.53 * W**-0.067 * (1.0 - 0.61 * np.exp(-0.73 * k))


def thermal_factor_wilson_sheu(S, u_mean, eta0, beta, conductivity):
    """Inlet shear-heating reduction of the film, φ_T = [1 + 0.241 (1 + 14.8 Z^0.83) L^0.64]^-1.

    Z = |S|/2, thermal loading parameter L = η0 β ū² / k_f (β the temperature-viscosity
    coefficient [1/K], k_f the oil's thermal conductivity [W/(m K)]). Wilson & Sheu (1983), as
    specified in docs/model.md §2.4. φ_T = 1 in the isothermal limit L → 0.
    """
    Z = np.abs(np.asarray(S, dtype=float)) / 2.0
    L = eta0 * beta * np.asarray(u_mean, dtype=float) ** 2 / conductivity
    return 1.0 / (1.0 + 0.241 * (1.0 + 14.8 * Z**0.83) * L**0.64)


def composite_rq(Rq1: float, Rq2: float) -> float:
    """R_q = √(R_q1² + R_q2²), the composite roughness of two surfaces (docs/model.md §2.4)."""
    return float(np.hypot(Rq1, Rq2))


def specific_film_thickness(hc, Rq):
    """Λ = h_c / R_q (docs/model.md §2.4); infinite for a smooth pair (R_q = 0)."""
    hc = np.asarray(hc, dtype=float)
    if Rq == 0.0:
        return np.full_like(hc, np.inf)
    return hc / Rq


def iso_lambda_gf(h, Ra1: float, Ra2: float):
    """ISO/TS 6336-22:2018 Method B specific lubricant film thickness λ_GF = h / R_a with the
    mean arithmetic roughness R_a = ½(R_a1 + R_a2) of the two flanks (docs/model.md §6). ``h`` is
    the local film (the standard's h_Y, a Dowson–Higginson form: our ``film.model = "DH61"``
    at the local load and speeds, without its thermal sliding parameter S_GF). Infinite for two
    smooth flanks."""
    h = np.asarray(h, dtype=float)
    ra = 0.5 * (Ra1 + Ra2)
    if ra == 0.0:
        return np.full_like(h, np.inf)
    return h / ra
