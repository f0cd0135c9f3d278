"""The model's range: which results of a block lie outside it, as flags and one warning line.

A result outside the range the model was built for must never reach a user silently
(docs/life.md, "The model's range"). Each block record (:class:`~micropit_hpc.life.BlockRecord`)
carries the numbers; this module holds the limits and turns the numbers into flags (in
summary.csv and results.h5) and into one warning line per block for the run log:

* ``saturated``: A_p ≥ 90 % on a body: the window is pitted through, and A_p no longer tells
  one condition from another (nor wear from none).
* ``low_cycle``: more than 10 % of the block's damage, or of its new pits, came from N below
  ``fatigue.n_min``, where the S–N line is extrapolated beyond its data (down to one-cycle
  failure at τ = B/√3, below the shear yield).
* ``plastic``: more than half of the contact area is at the pressure cap p_lim: the contact is
  dominated by plasticity, and the elastic stresses under it are outside the model's range.
* ``deep_layer``: the deepest stress layer's damage rate exceeds 1e-3 of its column's
  largest: the layers do not reach below the damage (raise ``stress.depth_b``).
* ``pits_below_layers``: a column has lost more material to pits than the stress layers reach
  (z_max): its damage below was never evaluated.
* ``wear_unresolved``: the implicit wear spent its budget of contact-only load cycles in a
  sub-block (``life.wear_max_iter`` × :data:`~micropit_hpc.life.WEAR_BUDGET`) and integrated
  the rest of it with the cell-relaxed update (a wear far faster than the block resolves), or
  it accepted a step of the smallest length whose fixed point was not solved to
  ``life.wear_tol`` (the block's ``wear_residual`` above it).
* ``pit_load``: more than a quarter of the contact load fell on pitted columns in the
  block's solves (:attr:`~micropit_hpc.state.BlockRecord.pit_load`). With
  ``life.pit_contact = "unloaded"`` the contact is solved on the surface around the pits, so
  an asperity that pitted keeps holding the counterface off the surface beside it; the load
  it takes is then handed to the other columns as a film's uniform pressure, which wears at
  k_lub instead of f_w k_lub and loads no asperity. Where that load is a large share, the
  wear and the later damage follow that rule (a choice of this model, not the paper's) and the
  grid: the pitted columns at the tips carry more of it on finer grids (docs/performance.md
  §14).
* ``window``: a synthetic surface's correlation lengths do not fit the window (L_x ≥ 4 β_x and
  L_y ≥ 2 β_y); one ridge spans the window and its R_q is not the surface's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

__all__ = ["LIMITS", "RangeWarnings", "block_flags", "block_warning", "item_list",
           "window_problems"]

#: The limits of the model's range (module docstring).
LIMITS = {"saturated_Ap_pct": 90.0, "low_cycle_share": 0.10, "plastic_share": 0.5,
          "deep_damage_ratio": 1e-3, "window_x_corr": 4.0, "window_y_corr": 2.0,
          "pit_load_share": 0.25}


def window_problems(scene, grid) -> list[str]:
    """What keeps the window from holding each synthetic Gaussian surface of ``scene`` on
    ``grid``: L_x ≥ 4 β_x and L_y ≥ 2 β_y (β the 10 % correlation lengths), one text per
    problem; empty when it holds. Self-affine and measured surfaces are not checked here
    (a measured map is its own window; a self-affine field's longest wavelength is cut to
    the window by construction; ridges of infinite length across, β_y = inf, are constant
    along y and so periodic in any window)."""
    out = []
    for i, body in ((1, scene.body1), (2, scene.body2)):
        s = body.surface
        if s.kind != "gaussian" or body.Rq == 0.0:
            continue
        for axis, length, corr, factor in (("x", grid.lx, s.corr_x, LIMITS["window_x_corr"]),
                                           ("y", grid.ly, s.corr_y, LIMITS["window_y_corr"])):
            if math.isfinite(corr) and length < factor * corr * (1 - 1e-9):
                out.append(f"body{i}.surface.corr_{axis}_um = {corr * 1e6:g} µm needs a window "
                           f"of at least {factor:g} × that along {axis} "
                           f"({factor * corr * 1e6:g} µm), the window is "
                           f"{length * 1e6:.4g} µm")
    return out


def block_flags(rec, z_max: float, window_ok: bool = True,
                wear_tol: float = math.inf) -> list[str]:
    """The flags (module docstring) of one block record; empty inside the model's range.
    ``wear_tol``: the scene's ``life.wear_tol`` (the implicit wear's residual over R_q)."""
    lim = LIMITS
    flags = []
    if max(rec.Ap) >= lim["saturated_Ap_pct"]:
        flags.append("saturated")
    if max(*rec.low_cycle_damage, *rec.low_cycle_pits) > lim["low_cycle_share"]:
        flags.append("low_cycle")
    if rec.plastic_share > lim["plastic_share"]:
        flags.append("plastic")
    if max(rec.deep_damage) > lim["deep_damage_ratio"]:
        flags.append("deep_layer")
    if max(rec.pit_depth_max) > z_max * (1 + 1e-9):
        flags.append("pits_below_layers")
    if not window_ok:
        flags.append("window")
    if rec.wear_fallback > 0.0 or rec.wear_residual > wear_tol:
        flags.append("wear_unresolved")
    if rec.pit_load > lim["pit_load_share"]:
        flags.append("pit_load")
    return flags


def _items(ids: Sequence[int]) -> str:
    ids = sorted(ids)
    return ("item " if len(ids) == 1 else "items ") + ", ".join(str(i) for i in ids[:8]) + (
        f" … ({len(ids)} in all)" if len(ids) > 8 else "")


def block_warning(block: int, records: Mapping[int, object], z_max: float,
                  window_ok: bool = True, wear_tol: float = math.inf) -> str | None:
    """One warning line for the run log on the last records of a block (item id → record), or
    None when every item is inside the model's range (``wear_tol`` as :func:`block_flags`)."""
    lim = LIMITS
    found: dict[str, list[int]] = {}
    for iid, rec in records.items():
        for f in block_flags(rec, z_max, window_ok, wear_tol):
            found.setdefault(f, []).append(iid)
    if not found:
        return None

    def worst(ids, value):
        iid = max(ids, key=lambda i: value(records[i]))
        return value(records[iid]), iid

    parts = []
    for flag, ids in found.items():
        if flag == "saturated":
            v, i = worst(ids, lambda r: max(r.Ap))
            parts.append(f"A_p saturated (≥ {lim['saturated_Ap_pct']:g} %) on {_items(ids)}, "
                         f"up to {v:.3g} % (item {i})")
        elif flag == "low_cycle":
            v, i = worst(ids, lambda r: max(*r.low_cycle_damage, *r.low_cycle_pits))
            parts.append(f"damage or pits from N < fatigue.n_min above "
                         f"{100 * lim['low_cycle_share']:g} % on {_items(ids)}, up to "
                         f"{100 * v:.3g} % (item {i}): the S–N line is extrapolated there")
        elif flag == "plastic":
            v, i = worst(ids, lambda r: r.plastic_share)
            parts.append(f"plasticity-dominated contact (more than half the contact area at "
                         f"p_lim) on {_items(ids)}, up to {100 * v:.3g} % (item {i})")
        elif flag == "deep_layer":
            v, i = worst(ids, lambda r: max(r.deep_damage))
            parts.append(f"the deepest layer's damage rate is {v:.3g} of its column's largest "
                         f"(item {i}; above {lim['deep_damage_ratio']:g} on {_items(ids)}): "
                         "raise stress.depth_b")
        elif flag == "pits_below_layers":
            v, i = worst(ids, lambda r: max(r.pit_depth_max))
            parts.append(f"pits deeper than the stress layers ({z_max * 1e6:.3g} µm) on "
                         f"{_items(ids)}, up to {v * 1e6:.3g} µm (item {i})")
        elif flag == "wear_unresolved":
            spent = [j for j in ids if records[j].wear_fallback > 0.0]
            loose = [j for j in ids if records[j].wear_residual > wear_tol]
            if spent:
                v, i = worst(spent, lambda r: r.wear_fallback)
                parts.append(f"the implicit wear spent its budget of contact-only cycles on "
                             f"{_items(spent)} and integrated up to {100 * v:.3g} % of the "
                             f"block (item {i}) with the cell-relaxed update, whose depth "
                             "follows the cell size: lower life.block_M or wear.k_lub_s")
            if loose:
                v, i = worst(loose, lambda r: r.wear_residual)
                parts.append(f"the implicit wear accepted steps of its smallest length whose "
                             f"fixed point it did not solve on {_items(loose)}, residual up to "
                             f"{v:.3g} R_q (item {i}) against life.wear_tol = {wear_tol:g}: "
                             "raise life.wear_max_iter or lower life.min_sub_block_M")
        elif flag == "pit_load":
            v, i = worst(ids, lambda r: r.pit_load)
            parts.append(f"more than {100 * lim['pit_load_share']:g} % of the contact load fell "
                         f"on pitted columns on {_items(ids)}, up to {100 * v:.3g} % (item {i}), "
                         "and was handed to the film (life.pit_contact = \"unloaded\"): the "
                         "wear and later damage there follow that rule and the grid")
        elif flag == "window":
            parts.append("the window does not hold the surfaces' correlation lengths "
                         "(see the set-up warning)")
    return (f"warning: block {block}: outside the model's range: " + "; ".join(parts)
            + " (docs/life.md, \"The model's range\")")


def item_list(ids: Sequence[int], show: int = 12) -> str:
    """'item 3', 'items 0, 1, 4' or 'items 0, 1, … and 40 more (42 items)'."""
    ids = list(ids)
    if len(ids) == 1:
        return f"item {ids[0]}"
    head = ", ".join(map(str, ids[:show]))
    more = f", … and {len(ids) - show} more ({len(ids)} items)" if len(ids) > show else ""
    return f"items {head}{more}"


class RangeWarnings:
    """The run log's warnings after each block (a :class:`~micropit_hpc.runner.Handler`):
    once per item and limit, a block whose adaptive split stopped at its smallest sub-block
    (:func:`~micropit_hpc.life.smallest_sub_block`) before its wear or pit limit was met (in
    the paper's integration, which does not split, a block that went past them); and the
    block's one line on the model's range (:func:`block_warning`). ``log`` prints on rank 0."""

    def __init__(self, life, log):
        from micropit_hpc.life import smallest_sub_block  # (life is the heavier module)
        self.log, self.life, self.study = log, life, None
        self.floor = smallest_sub_block(life)
        why_wear = ("for a stable wear update" if life.wear_integration == "explicit" else
                    "to follow the running-in in finer steps")
        # (record field, limit, what one sub-block did, unit scale, key, why finer steps)
        self.limits = (
            ("wear_step", life.max_wear_fraction, "one sub-block's wear changed the surface "
             "by up to {} × R_q", 1.0, "life.max_wear_fraction", why_wear),
            ("pit_step", life.max_pit_step, "one sub-block newly pitted up to {} % of the "
             "window", 100.0, "life.max_pit_step", "to follow the cascade of pits in finer "
             "steps"))
        self.warned: dict[str, set[int]] = {f[0]: set() for f in self.limits}

    def start(self, study, blocks: int, start: int) -> None:
        self.study = study

    def progress(self, *args) -> None:
        pass

    def block(self, k: int, blocks: int, records) -> None:
        for name, limit, did, scale, key, why in self.limits:
            over = {iid: getattr(recs[-1], name) for iid, recs in records.items()
                    if recs and iid not in self.warned[name]
                    and getattr(recs[-1], name) > limit * (1 + 1e-9)}
            if over:
                self.warned[name].update(over)
                worst = max(over, key=over.get)
                if self.life.integration == "paper":     # no split: whole blocks of ΔN
                    advice = ("the paper's literal scheme does not split its blocks "
                              "(life.integration = \"paper\"): its result depends on "
                              "life.block_M (docs/life.md, \"Two time integrations\")")
                else:
                    which = ("life.min_sub_block_M" if self.floor == self.life.min_sub_block
                             else "ΔN/life.max_splits")
                    advice = (f"the split stopped at its smallest sub-block, {which} = "
                              f"{self.floor / 1e6:g} M. Lower it {why} (docs/life.md)")
                self.log(f"warning: block {k}, {item_list(sorted(over))}: "
                         f"{did.format(f'{scale * over[worst]:.3g}')} (item {worst}), above "
                         f"{key} = {limit:g}; {advice}")
        st = self.study
        line = block_warning(k, {iid: r[-1] for iid, r in records.items() if r}, st.z_max,
                             not st.window_problems, self.life.wear_tol)
        if line:
            self.log(line)

    def finish(self, outcome) -> None:
        pass
