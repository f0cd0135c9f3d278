"""Figures the commands write themselves (matplotlib, Agg backend, imported lazily)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from micropit_hpc.errors import MicropitError


def _pyplot():
    try:
        import matplotlib
    except ImportError:  # pragma: no cover
        raise MicropitError("plots need matplotlib (apt-get install python3-matplotlib)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def von_mises(sigma: np.ndarray) -> np.ndarray:
    """σ_vM = √(½[(σxx−σyy)² + (σyy−σzz)² + (σzz−σxx)²] + 3(σyz² + σxz² + σxy²)) over the
    leading Voigt axis (xx, yy, zz, yz, xz, xy)."""
    xx, yy, zz, yz, xz, xy = sigma
    return np.sqrt(0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2)
                   + 3.0 * (yz**2 + xz**2 + xy**2))


def snapshot_figure(path: str | Path, cycle, fields, stresses: dict[int, np.ndarray]) -> Path:
    """Maps like the paper's Fig. 10: pressure, clearance, solid-contact map and, per body,
    von Mises stress at its most stressed layer."""
    plt = _pyplot()
    g = cycle.grid
    ext = [g.y[0] * 1e6, g.y[-1] * 1e6, g.x[-1] * 1e6, g.x[0] * 1e6]
    panels = [
        ("pressure [GPa]", fields.pressure / 1e9, "viridis"),
        ("clearance [µm]", fields.clearance * 1e6, "coolwarm"),
        ("solid contact", fields.solid.astype(float), "Greys"),
    ]
    for i, s in sorted(stresses.items()):
        vm = von_mises(s)
        k = int(np.argmax(vm.reshape(vm.shape[0], -1).max(axis=1)))
        panels.append((f"von Mises, body {i}, z = {cycle.z[k] * 1e6:.3g} µm [GPa]", vm[k] / 1e9,
                       "magma"))
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.4),
                             constrained_layout=True)
    for ax, (title, data, cmap) in zip(axes, panels, strict=True):
        im = ax.imshow(data, extent=ext, cmap=cmap, aspect="auto")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("y [µm]")
        ax.set_ylabel("x (rolling) [µm]")
        fig.colorbar(im, ax=ax, shrink=0.8)
    c = cycle.cond
    fig.suptitle(f"{cycle.scene.name}: position {cycle.position}, step {fields.step + 1}/"
                 f"{cycle.steps}, x_c = {fields.x_c * 1e6:.1f} µm, p̄ = {fields.p_mean / 1e9:.3g} "
                 f"GPa, S = {c.S:.3g}, Λ = {c.Lambda:.3g}, {fields.level}, φ = {fields.phi:.3g}",
                 fontsize=10)
    path = Path(path)
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path
