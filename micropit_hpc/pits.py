"""Micropits: detachment of failed material, and the damage column that moves with the surface
(docs/model.md §4.5–§4.6).

Damage D(z_k, x, y) is kept on the stress layers z_k, measured below the local surface of the
body (the half-space model puts every column's surface at z = 0). When material leaves the
surface — by wear, or by a micropit — the column moves up: the material at depth z_k afterwards
is what was at z_k + δ, so D'(z_k) = D(z_k + δ), interpolated linearly between layers.

**Zero-damage refill.** Material that comes up from below the deepest layer z_max was never
evaluated and enters with zero damage: the deepest layer stands for the material down to its
bottom (:func:`layer_bottoms`), and D falls linearly from its value there to zero at that
bottom. (Filling it with the deepest layer's damage, as an earlier release did, made failed
material re-enter at every wear shift: pits dug hundreds of µm under 66 µm of stress layers.)
The layers must reach deep enough for this to be harmless: the life loop reports the damage
rate of the deepest layer against its column's maximum and warns above 1e-3
(docs/life.md, "Damage bookkeeping").

Where D ≥ 1 on some layer (Miner), the material from the surface down to the deepest failed
layer k*, that layer included, detaches ([B11] §2.4): the column's height drops by the bottom of
layer k* (half-way to the next layer), but never by more than z_max in one event; the damage of
the removed layers is discarded, and the point is marked pitted. A_p is the pitted fraction of
the surface.
"""

from __future__ import annotations

import numpy as np

__all__ = ["detach", "layer_bottoms", "shift_columns"]


def layer_bottoms(z: np.ndarray) -> np.ndarray:
    """Lower boundary of each layer: half-way to the next one; the deepest layer extends as far
    below its depth as half its spacing to the layer above."""
    z = np.asarray(z, dtype=float)
    if z.size < 2:
        raise ValueError("need at least two layers to define layer thicknesses")
    return np.append(0.5 * (z[:-1] + z[1:]), z[-1] + 0.5 * (z[-1] - z[-2]))


def shift_columns(damage: np.ndarray, z: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """D'(z_k, x, y) = D(z_k + depth(x, y)): the columns after ``depth`` [m] (≥ 0) of material
    left the surface. ``damage`` has shape (N_z, n_x, n_y). Exact where depth = 0. Below the
    deepest layer z_max the damage falls linearly to zero at that layer's bottom and is zero
    further down (zero-damage refill, module docstring)."""
    z = np.asarray(z, dtype=float)
    depth = np.asarray(depth, dtype=float)
    if np.any(depth < 0):
        raise ValueError("a removed depth must be non-negative")
    zq = z[:, None, None] + depth[None]
    j = np.clip(np.searchsorted(z, zq.ravel(), side="right").reshape(zq.shape) - 1, 0,
                z.size - 2)
    w = np.minimum((zq - z[j]) / (z[j + 1] - z[j]), 1.0)
    lo = np.take_along_axis(damage, j, axis=0)
    hi = np.take_along_axis(damage, j + 1, axis=0)
    out = (1.0 - w) * lo + w * hi
    below = zq > z[-1]
    if below.any():
        bottom = layer_bottoms(z)[-1]
        fade = np.clip((bottom - zq) / (bottom - z[-1]), 0.0, 1.0)
        out = np.where(below, fade * damage[-1][None], out)
    return out


def detach(damage: np.ndarray, z: np.ndarray,
           failure: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pits where D ≥ ``failure``: returns (new damage, removed depth [m] per column, mask of the
    columns that pitted now). The removed depth is the bottom of the deepest failed layer, at
    most z_max = z[-1]. Columns without failure are returned unchanged, bitwise."""
    failed = damage >= failure
    new = failed.any(axis=0)
    if not new.any():
        return damage, np.zeros(damage.shape[1:]), new
    nz = damage.shape[0]
    deepest = nz - 1 - np.argmax(failed[::-1], axis=0)          # deepest failed layer
    depth = np.where(new, np.minimum(layer_bottoms(z)[deepest], z[-1]), 0.0)
    keep = np.arange(nz)[:, None, None] > deepest[None]           # layers below k*
    cleared = np.where(new[None] & ~keep, 0.0, damage)
    out = damage.copy()
    out[:, new] = shift_columns(cleared[:, new][:, :, None], z, depth[new][:, None])[:, :, 0]
    return out, depth, new
