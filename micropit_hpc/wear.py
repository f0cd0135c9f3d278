"""Local mild wear by Archard's law with a dimensional coefficient (MODEL.md §4.6).

Wear depth per load cycle of body i at material point X (Morales-Espejel, Rycerz & Kadiric,
Wear 398–399 (2018) §2.1; [B11] §2.5):

    Δh_i(X) = ½ (|u_s|/H_i) (1/m) Σ_t k(X, t) p(X, t),   k = f_w k_lub on solid contact,
                                                         k = k_lub on the fluid film,

k_lub in seconds (paper: 0, 1e-11, 5e-11 s), f_w = 10 by default. The window-frame fields of
each time step are carried to the body's material frame, F_i(X) = F(X + (u_i − ū) t), by
periodic linear interpolation along x: unlike a Fourier shift it cannot make a non-negative
field negative at the edges of the solid-contact patches, and it keeps the sum over the grid,
so the worn volume is exactly what the load cycle produced.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["archard_rate", "to_material_frame"]


def to_material_frame(field: np.ndarray, shift: float, dx: float) -> np.ndarray:
    """F(X + shift) on the periodic grid, by linear interpolation along x (axis 0).

    Conserves the sum of ``field`` exactly (each value is split between two neighbours with
    weights adding to one) and keeps non-negative fields non-negative.
    """
    s = shift / dx
    q = math.floor(s)
    f = s - q
    a = np.roll(field, -q, axis=0)
    if f == 0.0:
        return a
    return (1.0 - f) * a + f * np.roll(a, -1, axis=0)


def archard_rate(pressures: Sequence[np.ndarray], solids: Sequence[np.ndarray],
                 shifts: Sequence[float], dx: float, u_s: float, hardness: float,
                 k_lub: float, f_w: float) -> np.ndarray:
    """Δh_i per load cycle [m] in the material frame of body i (module docstring).

    ``pressures``/``solids``: the window-frame pressure [Pa] and solid-contact mask of each of
    the m time steps; ``shifts``: the body's slip (u_i − ū) t_j at each step [m]; ``u_s`` the
    sliding speed, ``hardness`` H_i [Pa], ``k_lub`` [s], ``f_w`` the solid-contact factor.
    """
    acc = np.zeros(np.shape(pressures[0]))
    if k_lub == 0.0 or u_s == 0.0:
        return acc
    for p, solid, shift in zip(pressures, solids, shifts, strict=True):
        acc += to_material_frame(np.where(solid, f_w * k_lub, k_lub) * p, shift, dx)
    return 0.5 * abs(u_s) / hardness * acc / len(pressures)
