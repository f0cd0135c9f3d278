"""The S–N (Wöhler) line of the Dang Van stress and the damage per cycle (docs/model.md §4.4).

σ_f = A ln N + B with the equivalent normal stress σ_f = √3 τ (the paper's Wöhler curve of the
gear steel, A = −40 MPa, B = 1600 MPa; the paper prints A = 40 MPa as a "slope", but it must be
negative for a falling curve), so

    N(τ) = exp[(√3 τ − B)/A],   1/N(τ) = exp[(√3 τ − B)/(−A)],

and no damage where τ ≤ 0 (the Dang Van stress is then below the fatigue limit of any finite
life). Morales-Espejel, Rycerz & Kadiric, Wear 398–399 (2018) §2.1; [B11] used A = −43 MPa,
B = 1220 MPa for 52100 bearing steel.

**Range of the line [decision].** The ln line is fitted to high-cycle data; extrapolated, it
predicts failure within one cycle at τ = B/√3 (924 MPa for the gear steel), below the steel's
shear yield. Below ``n_min`` cycles (``fatigue.n_min``, default 1e4) it is outside its data:
``low_cycle = "extrapolate"`` (default, as the paper) keeps using it and the life loop reports
the share of the damage and of the new pits that came from there (:meth:`WoehlerLine.low_damage`);
``"cap"`` takes N = max(N, n_min), a sensitivity run (docs/life.md, "The S–N line's range").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from micropit_hpc.scene import FatigueSpec

__all__ = ["LOW_CYCLE", "WoehlerLine"]

#: What the line does below ``n_min`` cycles (module docstring).
LOW_CYCLE = ("extrapolate", "cap")

_MAX_EXP = 700.0      # exp(700) ≈ 1e304: a damage per cycle this large means instant failure


@dataclass(frozen=True)
class WoehlerLine:
    """σ_f = A ln N + B on σ_f = √3 τ_DV; A < 0 and B in Pa. ``n_min``: the fewest cycles the
    line's data cover; ``low_cycle``: ``extrapolate`` or ``cap`` below them. The scene's
    ``[fatigue]`` table declares them with their defaults (:meth:`from_spec`)."""

    A: float
    B: float
    n_min: float
    low_cycle: str

    @classmethod
    def from_spec(cls, spec: FatigueSpec) -> WoehlerLine:
        """The line of the scene's fatigue settings (``scene.fatigue``)."""
        return cls(spec.A, spec.B, spec.n_min, spec.low_cycle)

    def __post_init__(self):
        if not (self.A < 0 and math.isfinite(self.A)):
            raise ValueError(f"Wöhler slope A = {self.A!r} Pa: must be negative (a falling "
                             "curve σ_f = A ln N + B)")
        if not (self.B > 0 and math.isfinite(self.B)):
            raise ValueError(f"Wöhler intercept B = {self.B!r} Pa: must be positive")
        if not (self.n_min >= 1 and math.isfinite(self.n_min)):
            raise ValueError(f"n_min = {self.n_min!r}: must be a finite number of cycles ≥ 1")
        if self.low_cycle not in LOW_CYCLE:
            raise ValueError(f"low_cycle = {self.low_cycle!r}: one of {LOW_CYCLE}")

    def life(self, tau: np.ndarray) -> np.ndarray:
        """N(τ) = exp[(√3 τ − B)/A] cycles; infinite where τ ≤ 0."""
        tau = np.asarray(tau, dtype=float)
        with np.errstate(over="ignore"):
            n = np.exp(np.minimum((math.sqrt(3.0) * tau - self.B) / self.A, _MAX_EXP))
        return np.where(tau > 0.0, n, np.inf)

    def damage(self, tau: np.ndarray) -> np.ndarray:
        """1/N(τ) per cycle; 0 where τ ≤ 0; at most 1/n_min with ``low_cycle = "cap"``."""
        tau = np.asarray(tau, dtype=float)
        x = np.minimum((math.sqrt(3.0) * tau - self.B) / -self.A, _MAX_EXP)
        if self.low_cycle == "cap":
            x = np.minimum(x, -math.log(self.n_min))
        return np.where(tau > 0.0, np.exp(x), 0.0)

    def low_damage(self, tau: np.ndarray) -> np.ndarray:
        """The part of :meth:`damage` that comes from below the line's data: the damage where
        N(τ) < n_min (with ``cap``: where N was capped), 0 elsewhere."""
        tau = np.asarray(tau, dtype=float)
        low = math.sqrt(3.0) * tau > self.B + self.A * math.log(self.n_min)
        return np.where(low, self.damage(tau), 0.0)

    def strength(self, cycles: np.ndarray) -> np.ndarray:
        """The Dang Van shear strength τ_f(N) = (A ln N + B)/√3 for a life of N cycles."""
        return (self.A * np.log(np.asarray(cycles, dtype=float)) + self.B) / math.sqrt(3.0)
