"""Macro contact conditions at each position of a study: the smooth contact a cycle starts from.

Scene -> one :class:`ContactConditions` per position (docs/model.md §2): geometry and load (gear
kinematics and load sharing, or the disc rig's settings), Hertz contact, surface speeds, central
film thickness and specific film thickness Λ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from micropit_hpc import film as filmlib
from micropit_hpc.errors import MicropitError
from micropit_hpc.gear import GearMesh
from micropit_hpc.hertz import elliptical_contact, line_contact, reduced_modulus
from micropit_hpc.scene import Scene


@dataclass(frozen=True)
class ContactConditions:
    """The smooth contact at one position, SI units.

    ``load`` is per unit length [N/m] for a line contact and the total load [N] for an
    elliptical one; ``b`` is the Hertz semi-width in the rolling direction and ``a`` the
    semi-axis across it (infinite for a line contact). Gear positions also carry ρ1, the roll
    angle of gear 1 and the tooth-centre radial position; for a disc rig these are NaN.
    """

    position: int
    geometry: str
    region: str
    R: float
    Ry: float
    load: float
    load_share: float
    p0: float
    b: float
    a: float
    u1: float
    u2: float
    hc: float
    thermal_factor: float
    Lambda: float
    rho1: float = math.nan
    roll_angle: float = math.nan
    radial_position: float = math.nan

    @property
    def u_mean(self) -> float:
        """Entrainment speed ū = (u1 + u2)/2."""
        return 0.5 * (self.u1 + self.u2)

    @property
    def u_s(self) -> float:
        """Sliding speed u_s = u1 - u2."""
        return self.u1 - self.u2

    @property
    def S(self) -> float:
        """Slide-roll ratio S = (u1 - u2)/ū (docs/model.md §1)."""
        return self.u_s / self.u_mean


@dataclass(frozen=True)
class ContactStudy:
    """Conditions at every position of a scene, with the moduli used and, for a gear pair, its
    path of contact."""

    scene: Scene
    E_prime: float
    E_star: float
    conditions: tuple[ContactConditions, ...]
    mesh: GearMesh | None = None


def moduli(scene: Scene) -> tuple[float, float]:
    """(E', E*): E' of the materials for the film; E* for Hertz, E'/2 unless overridden."""
    b1, b2 = scene.body1, scene.body2
    E_prime = reduced_modulus(b1.E, b1.nu, b2.E, b2.nu)
    E_star = scene.hertz_E_star if scene.hertz_E_star is not None else E_prime / 2.0
    return E_prime, E_star


def lambda_roughness(scene: Scene) -> float:
    """The R_q that Λ divides by (``film.lambda_roughness``)."""
    which = scene.film.lambda_roughness
    if which == "body1":
        return scene.body1.Rq
    if which == "body2":
        return scene.body2.Rq
    return filmlib.composite_rq(scene.body1.Rq, scene.body2.Rq)


def _film(scene: Scene, E_prime: float, R, Ry, load, u_mean, S):
    """Central film h_c (with the thermal factor) and φ_T, vectorised over positions."""
    spec, lub = scene.film, scene.lubricant
    shape = np.shape(np.asarray(R) * np.asarray(u_mean))
    if spec.hc is not None:
        return np.full(shape, spec.hc), np.ones(shape)
    if spec.model == "DH61":
        hc = filmlib.dowson_higginson_1961(R, u_mean, load, E_prime, lub.eta0, lub.alpha_pv)
    elif spec.model == "DH66":
        hc = filmlib.dowson_higginson_1966(R, u_mean, load, E_prime, lub.eta0, lub.alpha_pv)
    else:
        hc = filmlib.hamrock_dowson_1977(R, Ry, u_mean, load, E_prime, lub.eta0, lub.alpha_pv)
    if spec.thermal == "wilson_sheu":
        phi = filmlib.thermal_factor_wilson_sheu(S, u_mean, lub.eta0, lub.beta, lub.conductivity)
    else:
        phi = np.ones(shape)
    return np.broadcast_to(hc * phi, shape), np.broadcast_to(phi, shape)


def gear_positions(scene: Scene, mesh: GearMesh) -> np.ndarray:
    """ρ1 of every position of a gear scene; those within ``gear.pitch_snap_deg`` of roll angle
    from the pitch point C are put at C (S = 0)."""
    pos = scene.positions
    if pos.kind == "count":
        rho1 = mesh.evenly_spaced(pos.count)
    else:
        rho1 = np.array([mesh.locate(pos.kind, v) for v in pos.values])
    snap = scene.gear.pitch_snap               # the paper's "pitch point" printed as 27.77°
    if snap > 0.0:
        near = np.abs(mesh.roll_angle(rho1) - mesh.roll_angle(mesh.C)) <= snap
        rho1 = np.where(near, mesh.C, rho1)
    return rho1


def gear_conditions(scene: Scene, mesh: GearMesh, rho1) -> tuple[ContactConditions, ...]:
    """Conditions at points ρ1 of the path of contact of a gear scene (docs/model.md §2.1,
    §2.2, §2.4).

    w = X(ρ1) T1/(r_b1 b_w); R = ρ1 ρ2/(ρ1 + ρ2); u_i = ω_i ρ_i; line-contact Hertz; film from
    the scene's film model. With ``gear.slide_roll_imposed`` the speeds become ū(1 ± S/2) with
    |S| imposed and the mesh's sign, 0 at the pitch point (the paper's Table 5; its printed
    pitch position is put at the pitch point by ``gear.pitch_snap_deg``).
    """
    gear = scene.gear
    geo = gear.geometry
    E_prime, E_star = moduli(scene)
    rho1 = np.atleast_1d(np.asarray(rho1, dtype=float))
    X = mesh.load_share(rho1, gear.load_sharing, gear.accuracy_grade)
    w = X * gear.torque / (geo.base_radius1 * geo.facewidth)
    R = mesh.reduced_radius(rho1)
    b, p0 = line_contact(w, R, E_star)
    u1, u2 = mesh.surface_speeds(rho1, gear.speed)
    u_mean = 0.5 * (u1 + u2)
    S = (u1 - u2) / u_mean
    if gear.slide_roll_imposed is not None:       # the paper's Table 5: |S| fixed, ū kept
        S = np.sign(S) * gear.slide_roll_imposed    # 0 stays 0 at the pitch point
        u1, u2 = u_mean * (1.0 + 0.5 * S), u_mean * (1.0 - 0.5 * S)
    hc, phi = _film(scene, E_prime, R, math.inf, w, u_mean, S)
    Lam = filmlib.specific_film_thickness(hc, lambda_roughness(scene))
    single = mesh.single_pair(rho1)
    phi1 = mesh.roll_angle(rho1)
    y = mesh.radial_position(rho1)
    return tuple(
        ContactConditions(position=i + 1, geometry="line",
                          region="single" if single[i] else "double", R=float(R[i]),
                          Ry=math.inf, load=float(w[i]), load_share=float(X[i]),
                          p0=float(p0[i]), b=float(b[i]), a=math.inf, u1=float(u1[i]),
                          u2=float(u2[i]), hc=float(hc[i]), thermal_factor=float(phi[i]),
                          Lambda=float(Lam[i]), rho1=float(rho1[i]),
                          roll_angle=float(phi1[i]), radial_position=float(y[i]))
        for i in range(rho1.size))


def disc_conditions(scene: Scene) -> tuple[ContactConditions, ...]:
    """Conditions of a disc rig, one per slide-roll ratio (docs/model.md §2.3):
    u1 = ū(1 + S/2), u2 = ū(1 - S/2); line or elliptical Hertz from the radii."""
    disc = scene.disc
    E_prime, E_star = moduli(scene)
    S = np.asarray(disc.slide_roll, dtype=float)
    u_mean = disc.u_mean
    u1, u2 = u_mean * (1 + S / 2), u_mean * (1 - S / 2)
    Rx, Ry = disc.Rx, disc.Ry
    if disc.is_line:
        w = disc.load if disc.p0 is None else math.pi * Rx * disc.p0**2 / E_star
        b, p0 = (float(v) for v in line_contact(w, Rx, E_star))
        a, load = math.inf, w
    else:
        h = elliptical_contact(Rx, Ry, E_star, load=disc.load, p0=disc.p0)
        b, a, p0, load = h.ax, h.ay, h.p0, h.load
    hc, phi = _film(scene, E_prime, np.full_like(S, Rx), Ry, load, np.full_like(S, u_mean), S)
    Lam = filmlib.specific_film_thickness(hc, lambda_roughness(scene))
    return tuple(
        ContactConditions(position=i + 1, geometry="line" if disc.is_line else "elliptical",
                          region="single", R=Rx, Ry=Ry, load=float(load), load_share=1.0,
                          p0=float(p0), b=float(b), a=float(a), u1=float(u1[i]),
                          u2=float(u2[i]), hc=float(hc[i]), thermal_factor=float(phi[i]),
                          Lambda=float(Lam[i]))
        for i in range(S.size))


def contact_study(scene: Scene) -> ContactStudy:
    """The contact conditions at every position of a scene.

    Raises :class:`MicropitError` if a quantity comes out infinite or NaN (inputs that are each
    in range but together outside what floating point or the formulas can represent).
    """
    E_prime, E_star = moduli(scene)
    mesh = None
    with np.errstate(all="ignore"):
        if scene.gear is not None:
            mesh = GearMesh.from_geometry(scene.gear.geometry)
            cond = gear_conditions(scene, mesh, gear_positions(scene, mesh))
        else:
            cond = disc_conditions(scene)
    for c in cond:
        for name in ("R", "load", "p0", "b", "u1", "u2", "hc", "Lambda"):
            value = getattr(c, name)
            if not math.isfinite(value) and not (name == "Lambda" and value == math.inf):
                raise MicropitError(
                    f"{scene.source}: position {c.position}: {name} = {value} is not finite; "
                    "the scene's numbers together are outside what the contact formulas can "
                    "represent (check loads, sizes and speeds for a unit slip)")
    return ContactStudy(scene=scene, E_prime=E_prime, E_star=E_star, conditions=cond, mesh=mesh)
