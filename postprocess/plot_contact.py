#!/usr/bin/env python3
"""Plot the contact conditions along the path of contact of a gear scene (like the paper's
Fig. 8a): load per unit facewidth and Hertz pressure p0 against the roll angle of gear 1, with
the slide-roll ratio S on a second axis, the double-pair zones shaded, the points A-E marked and
the scene's positions as dots. For a disc scene: p0, Λ against S.

    python postprocess/plot_contact.py SCENE --out contact.png
"""

from __future__ import annotations

import argparse
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from micropit_hpc.conditions import contact_study, gear_conditions
from micropit_hpc.errors import MicropitError
from micropit_hpc.scene import load_scene


def plot_gear(study, out: str) -> None:
    mesh = study.mesh
    path = gear_conditions(study.scene, mesh, mesh.evenly_spaced(600))
    deg = [math.degrees(c.roll_angle) for c in path]
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.plot(deg, [c.load / 1e3 for c in path], "k-", label="load w [kN/m]")
    ax2 = ax.twinx()
    ax2.plot(deg, [c.p0 / 1e9 for c in path], "C0-", label="p0 [GPa]")
    ax2.plot(deg, [c.S for c in path], "C3--", label="S")
    ax2.axhline(0.0, color="0.7", lw=0.5)
    pts = study.conditions
    ax2.plot([math.degrees(c.roll_angle) for c in pts], [c.p0 / 1e9 for c in pts], "C0o", ms=4)
    ax2.plot([math.degrees(c.roll_angle) for c in pts], [c.S for c in pts], "C3o", ms=4)
    for lo, hi in ((mesh.A, mesh.B), (mesh.D, mesh.E)):
        ax.axvspan(math.degrees(lo / mesh.rb1), math.degrees(hi / mesh.rb1), color="0.92")
    top = max(c.load for c in path) / 1e3
    for name in "ABCDE":
        x = math.degrees(getattr(mesh, name) / mesh.rb1)
        ax.axvline(x, color="0.6", lw=0.6)
        ax.text(x, 1.01, name, ha="center", va="bottom", transform=ax.get_xaxis_transform())
    ax.set_ylim(0, 1.12 * top)
    ax.set_xlabel("roll angle of gear 1 [deg]  (shaded: two pairs in contact)")
    ax.set_ylabel("load per unit facewidth [kN/m]")
    ax2.set_ylabel("p0 [GPa], slide-roll ratio S [-]")
    lines = ax.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    ax.legend(lines, [h.get_label() for h in lines], loc="lower center", ncol=3)
    ax.set_title(f"{study.scene.name}: contact conditions along the path "
                 f"(ε_α = {mesh.contact_ratio:.3f})", pad=18)
    fig.savefig(out, dpi=130)


def plot_disc(study, out: str) -> None:
    S = np.array([c.S for c in study.conditions])
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    ax.plot(S, [c.Lambda for c in study.conditions], "C0o-", label="Λ")
    ax.plot(S, [c.p0 / 1e9 for c in study.conditions], "C3s-", label="p0 [GPa]")
    ax.set_xlabel("slide-roll ratio S")
    ax.legend()
    ax.set_title(f"{study.scene.name}: disc-rig contacts")
    fig.savefig(out, dpi=130)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="scene file")
    parser.add_argument("--out", default="contact.png", help="PNG file to write")
    args = parser.parse_args(argv)
    try:
        study = contact_study(load_scene(args.scene))
    except MicropitError as e:
        print(f"plot_contact: error: {e}", file=sys.stderr)
        return 2
    (plot_gear if study.mesh is not None else plot_disc)(study, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
