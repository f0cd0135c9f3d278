"""Local mild wear by Archard's law with a dimensional coefficient (docs/model.md §4.6).

Wear depth per load cycle of body i at material point X (Morales-Espejel, Rycerz & Kadiric,
Wear 398–399 (2018) §2.1; [B11] §2.5):

    Δh_i(X) = ½ (|u_s|/H_i) (1/m) Σ_t k(X, t) p(X, t),   k = f_w k_lub on solid contact,
                                                         k = k_lub on the fluid film,

k_lub in seconds (paper: 0, 1e-11, 5e-11 s), f_w = 10 by default. The window-frame fields of
each time step are carried to the body's material frame, F_i(X) = F(X + (u_i − ū) t), by
periodic linear interpolation along x: unlike a Fourier shift it cannot make a non-negative
field negative at the edges of the solid-contact patches, and it keeps the sum over the grid,
so the worn volume is exactly what the load cycle produced.

**Wear integration over a sub-block [choice]** (``life.wear_integration``). docs/model.md §4.6
removes ΔN·Δh_i per block (``"explicit"``). On solid-contact spots that update is stiff: the
wear there relieves the very pressure that drives it. Lowering a contact spot by δ lowers its
pressure by δ/K₀, K₀ the combined self-compliance of one grid cell (the displacement of a
cell under unit pressure on itself, :attr:`~.dry.ElasticHalfSpaces.self_compliance`), so with
both bodies wearing at the spot the solid part of the rate decays as

    dΔh_s/dN = −ρ Δh_s,   ρ_i(X) = ½ |u_s| f_w k_lub (1/H_1 + 1/H_2) f_s,i(X) / K₀,

f_s,i(X) the share of the cycle's steps in which material point X is in solid contact. At
the MPR contact 1/ρ is about ten thousand cycles, so an explicit sub-block of 250 k cycles
digs the contact spots microns deep where their pressure would have gone after a fraction of
a micron. ``"relaxed"`` (default) integrates that linearised decay exactly over the
sub-block of n cycles:

    Δh_i(n) = n [Δh_fluid + Δh_solid (1 − e^{−ρn})/(ρn)],

which equals the explicit update when ρn ≪ 1 and is bounded by n Δh_fluid plus the local
elastic deflection K₀ p̄_solid/(1 + H_i/H_j) when ρn ≫ 1 (an exponential integrator of the
locally linearised Archard–contact system; Johnson, *Contact Mechanics* (1985) §3.2 for the
cell compliance). The film part (k_lub) is not stiff and stays explicit. The relief is
local: the load a worn spot sheds is taken to go to the film, as the flow balance lets it
in mixed lubrication. Where the solids must keep their load (dry contact, φ = 1) the shed
load moves to other spots instead and ``relaxed`` under-counts their wear; docs/life.md
gives the measurements of both cases.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from micropit_hpc.spectral import to_material_frame

__all__ = ["RATE_INTEGRATIONS", "WearRate", "archard_wear", "solid_weight", "to_material_frame"]

#: The integrations :meth:`WearRate.depth` does from one rate (module docstring); the default
#: ``life.wear_integration = "implicit"`` re-solves the contact (:mod:`micropit_hpc.implicit_wear`).
RATE_INTEGRATIONS = ("relaxed", "explicit")


@dataclass(frozen=True)
class WearRate:
    """Archard wear of one body per load cycle [m] in its material frame, split into the part
    from solid-contact steps and the part from the film, and the relaxation rate ρ [1/cycle]
    of the solid part (module docstring)."""

    solid: np.ndarray
    fluid: np.ndarray
    relax: np.ndarray

    @property
    def rate(self) -> np.ndarray:
        """Δh_i per load cycle on the current surfaces (docs/model.md §4.6)."""
        return self.solid + self.fluid

    def depth(self, n: float, integration: str = "relaxed") -> np.ndarray:
        """Wear depth [m] over ``n`` load cycles: n Δh_i (``explicit``, docs/model.md §4.6), or
        n [Δh_fluid + Δh_solid (1 − e^{−ρn})/(ρn)] (``relaxed``, module docstring)."""
        if integration == "explicit":
            return n * self.rate
        if integration != "relaxed":
            raise ValueError(f"wear integration {integration!r} is not one of "
                             f"{', '.join(RATE_INTEGRATIONS)}")
        x = self.relax * n
        share = np.ones_like(x)
        np.divide(-np.expm1(-x), x, out=share, where=x > 1e-12)
        return n * (self.fluid + self.solid * share)


def solid_weight(clearance: np.ndarray, h_min: float, ramp: float) -> np.ndarray:
    """The share s ∈ [0, 1] of the solid-contact coefficient f_w k_lub in the Archard
    coefficient k = k_lub [1 + (f_w − 1) s] of a point with this ``clearance`` [m]
    (``wear.solid_ramp_film`` [choice], docs/life.md "Implicit wear"): 1 at or below h_min, 0
    at or above h_min + ``ramp``, linear between. ``ramp`` = 0 is the step of docs/model.md §4.6
    (k jumps tenfold at the edge of solid contact), which makes the wear rate a discontinuous
    function of the worn depth: a point at the edge wears ten times faster in contact than
    out of it, and no worn depth is consistent with its own rate."""
    if ramp <= 0.0:
        return (clearance <= h_min).astype(float)
    # np.clip's value, without np.clip's per-call checks
    return np.minimum(np.maximum((h_min + ramp - clearance) / ramp, 0.0), 1.0)


def archard_wear(pressures: Sequence[np.ndarray], solids: Sequence[np.ndarray],
                 shifts: Sequence[float], dx: float, u_s: float, hardness: float,
                 counter_hardness: float, k_lub: float, f_w: float,
                 cell_compliance: float, weights: Sequence[float] | None = None) -> WearRate:
    """Δh_i per load cycle [m] of body i in its material frame, split by regime, with the
    relaxation rate of its solid part (module docstring).

    ``pressures``/``solids``: the window-frame pressure [Pa] and solid-contact share s
    (:func:`solid_weight`; a mask is s ∈ {0, 1}) of each of the m time steps; ``shifts``: the
    body's slip (u_i − ū) t_j at each step [m]; ``u_s`` the sliding speed, ``hardness`` H_i
    and ``counter_hardness`` H_j [Pa], ``k_lub`` [s], ``f_w`` the solid-contact factor,
    ``cell_compliance`` K₀ [m/Pa]; ``weights``: each step's share of the transit time (Σ = 1;
    None: 1/m each, uniform steps).
    """
    shape = np.shape(pressures[0])
    if k_lub == 0.0 or u_s == 0.0:
        return WearRate(np.zeros(shape), np.zeros(shape), np.zeros(shape))
    solid_acc, fluid_acc, share = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    ws = [1.0] * len(pressures) if weights is None else weights
    for p, solid, shift, w in zip(pressures, solids, shifts, ws, strict=True):
        s = np.asarray(solid, dtype=float)
        sp, fp = s * p, (1.0 - s) * p
        if weights is not None:
            sp, fp, s = w * sp, w * fp, w * s
        solid_acc += to_material_frame(sp, shift, dx)
        fluid_acc += to_material_frame(fp, shift, dx)
        share += to_material_frame(s, shift, dx)
    m = len(pressures) if weights is None else 1.0
    scale = 0.5 * abs(u_s) / hardness * k_lub / m
    relax = (0.5 * abs(u_s) * f_w * k_lub * (1.0 / hardness + 1.0 / counter_hardness)
             / cell_compliance) * (share / m)
    return WearRate(solid=f_w * scale * solid_acc, fluid=scale * fluid_acc, relax=relax)
