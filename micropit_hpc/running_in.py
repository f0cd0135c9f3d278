"""Plastic running-in of the asperity tips before the life (``life.running_in = "plastic"``,
a **[choice]** beyond the paper; docs/life.md, "Plastic running-in of the tips").

The contact model is elastic–perfectly plastic: the pressure is capped at p_lim and where the
material yields the clearance is negative, the overlap the tip would need to lose to carry
p_lim elastically (docs/contact.md). The life simulation otherwise leaves the surfaces as they
were where they yielded, so a tip at the cap stays a tip at the cap for ever. A real tip is
flattened by that overlap in its first passes through the contact, and the counterface then
comes down onto more of the surface (shakedown of the roughness; Johnson, *Contact
Mechanics* (1985) §9.5; Kapoor, Williams & Johnson, Wear 200 (1996) 38–44).

Here, before the first block, the load cycle is solved contact-only on the current surfaces
(no stresses, no damage, no wear) and every column of each body i is lowered by

    Δz_i(X) = s_i · max_j δ_j(X + (u_i − ū) t_j),   δ_j = max(−h_j, 0) where p_j = p_lim, else 0,

the largest plastic overlap δ it met over the cycle's steps j (window frame, moved to the body's
material frame as the pressures are: :func:`~micropit_hpc.spectral.to_material_frame`), shared
between the bodies in inverse proportion to their hardness, s_1 = H_2/(H_1 + H_2),
s_2 = H_1/(H_1 + H_2) (equal hardness: half each). One pass stands for one cycle of plastic
flow. The passes repeat until the largest overlap is below ``life.running_in_overlap`` times
the composite initial R_q, or ``life.running_in_passes`` passes. The damage these first cycles
do is not counted (it is low-cycle plastic fatigue, outside the Dang Van / S–N model); nor is
the depth taken off counted as wear (it shows in the heights and R_q).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from micropit_hpc.cycle import PositionCycle
from micropit_hpc.life import contact_surfaces
from micropit_hpc.scene import LifeSpec
from micropit_hpc.spectral import to_material_frame
from micropit_hpc.state import LifeState

__all__ = ["RunningIn", "hardness_shares", "plastic_overlap", "run_in"]


@dataclass(frozen=True)
class RunningIn:
    """What the running-in did: the passes made, the largest overlap [m] and the plastic share
    of the contact area (points at p_lim among those in contact, all steps) of the first and
    of the last pass, and the mean and largest depth [m] taken off each body."""

    passes: int
    overlap_first: float
    overlap_last: float
    plastic_first: float
    plastic_last: float
    depth_mean: tuple[float, float]
    depth_max: tuple[float, float]

    def line(self) -> str:
        """One log line."""
        return (f"plastic running-in: {self.passes} passes, largest overlap "
                f"{self.overlap_first * 1e9:.4g} → {self.overlap_last * 1e9:.4g} nm, yielded "
                f"share of the contact {self.plastic_first:.3f} → {self.plastic_last:.3f}, "
                f"depth taken off {self.depth_mean[0] * 1e6:.3g} / "
                f"{self.depth_mean[1] * 1e6:.3g} µm mean, {self.depth_max[0] * 1e6:.3g} / "
                f"{self.depth_max[1] * 1e6:.3g} µm largest (body 1 / 2)")


def hardness_shares(h1: float, h2: float) -> tuple[float, float]:
    """(s_1, s_2) = (H_2, H_1)/(H_1 + H_2): each body's share of a plastic overlap (the softer
    body yields more; equal hardness: half each)."""
    return h2 / (h1 + h2), h1 / (h1 + h2)


def plastic_overlap(cycle: PositionCycle, surfaces, pits=None, warm: dict | None = None
                    ) -> tuple[tuple[np.ndarray, np.ndarray], float, float]:
    """One contact-only load cycle on ``surfaces``: each body's largest plastic overlap per
    column over the steps in its material frame (module docstring), the largest overlap of
    any step [m] and the plastic share of the contact area. Collective over the cycle's
    group like :meth:`PositionCycle.contact_fields`; the same on every rank."""
    fields = cycle.contact_fields(surfaces, pits, warm)
    at_lim = (1.0 - 1e-9) * cycle.p_lim
    dx = cycle.grid.dx
    maps = (np.zeros(cycle.grid.shape), np.zeros(cycle.grid.shape))
    worst, n_plastic, n_contact = 0.0, 0, 0
    for f in fields:
        yielded = f.pressure >= at_lim
        n_plastic += int(np.count_nonzero(yielded))
        n_contact += int(np.count_nonzero(f.pressure > 0.0))
        if not yielded.any():
            continue
        over = np.where(yielded, np.maximum(-f.clearance, 0.0), 0.0)
        worst = max(worst, float(over.max()))
        for i, m in enumerate(maps):
            np.maximum(m, to_material_frame(over, cycle.slip(i + 1, f.t), dx), out=m)
    return maps, worst, (n_plastic / n_contact if n_contact else 0.0)


def run_in(cycle: PositionCycle, state: LifeState, life: LifeSpec,
           on_pass: Callable[[int], None] | None = None) -> RunningIn:
    """Run the surfaces of ``state`` in plastically (module docstring; in place: the heights
    drop). Collective over the cycle's group; every rank ends with the same surfaces.
    ``on_pass(k)``: called after the k-th pass (progress reports; changes nothing)."""
    scene = cycle.scene
    shares = hardness_shares(scene.body1.hardness, scene.body2.hardness)
    before = [b.heights.copy() for b in state.bodies]
    stop = life.running_in_overlap * math.hypot(*(b.rq0 for b in state.bodies))
    warm: dict = {}
    overlaps, plastic = [], []
    for _ in range(life.running_in_passes):
        surfaces, pits = contact_surfaces(state, cycle.grid, life.pit_contact)
        maps, worst, share = plastic_overlap(cycle, surfaces, pits, warm)
        overlaps.append(worst)
        plastic.append(share)
        if on_pass is not None:
            on_pass(len(overlaps))
        if worst <= stop:
            break
        for b, s, m in zip(state.bodies, shares, maps, strict=True):
            b.heights -= s * m
    taken = [h - b.heights for b, h in zip(state.bodies, before, strict=True)]
    return RunningIn(passes=len(overlaps), overlap_first=overlaps[0],
                     overlap_last=overlaps[-1], plastic_first=plastic[0],
                     plastic_last=plastic[-1],
                     depth_mean=(float(taken[0].mean()), float(taken[1].mean())),
                     depth_max=(float(taken[0].max()), float(taken[1].max())))
