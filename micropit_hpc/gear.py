"""External involute spur gear pair: path of contact, kinematics, load sharing, flank location.

docs/model.md §2.1. Gear 1 (the pinion, body 1) drives. A point of the path of contact is given by
ρ1, its distance along the line of action from T1 (the tangency point of the line of action with
the base circle of gear 1); its radius of curvature on gear 1 is ρ1 and on gear 2 ρ2 = g - ρ1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

LOAD_SHARING = ("linear", "iso_unmodified", "none")


class MeshingError(ValueError):
    """The gear pair cannot mesh; ``fields`` names the GearGeometry fields involved."""

    def __init__(self, message: str, fields: tuple[str, ...]):
        super().__init__(message)
        self.fields = fields


def involute(angle):
    """inv α = tan α - α."""
    return np.tan(angle) - angle


def operating_pressure_angle(z1: int, z2: int, x1: float, x2: float,
                             pressure_angle: float) -> float:
    """Zero-backlash working pressure angle: inv α_w = inv α + 2 tan α (x1 + x2)/(z1 + z2)
    (ISO 21771:2007 eq. 41)."""
    target = (float(involute(pressure_angle))
              + 2.0 * math.tan(pressure_angle) * (x1 + x2) / (z1 + z2))
    if target <= 0.0:
        raise MeshingError("the profile shifts give no positive working pressure angle",
                           ("x1", "x2"))
    return brentq(lambda a: float(involute(a)) - target, 1e-9, math.pi / 2 - 1e-9, xtol=1e-15)


def zero_backlash_centre_distance(module: float, pressure_angle: float, z1: int, z2: int,
                                  x1: float, x2: float) -> float:
    """a = m (z1 + z2) cos α / (2 cos α_w) with the zero-backlash α_w (ISO 21771:2007 eq. 42)."""
    aw = operating_pressure_angle(z1, z2, x1, x2, pressure_angle)
    return module * (z1 + z2) * math.cos(pressure_angle) / (2.0 * math.cos(aw))


def tooth_thickness(module: float, pressure_angle: float, z: int, x: float, r):
    """Transverse tooth thickness (arc) at radius r ≥ r_b, vectorised over r:
    s_r = 2r ψ(r), ψ(r) = s/d + inv α - inv α_r, s = m(π/2 + 2x tan α), d = m z,
    cos α_r = r_b/r (ISO 21771:2007 eq. 27); ψ is the tooth's half-angle at r."""
    r = np.asarray(r, dtype=float)
    rb = 0.5 * module * z * math.cos(pressure_angle)
    s = module * (math.pi / 2 + 2.0 * x * math.tan(pressure_angle))
    alpha_r = np.arccos(np.minimum(1.0, rb / r))
    return 2.0 * r * (s / (module * z) + involute(pressure_angle) - involute(alpha_r))


@dataclass(frozen=True)
class GearGeometry:
    """Geometry of an external spur gear pair, SI units (lengths in m, angles in rad)."""

    module: float
    pressure_angle: float
    z1: int
    z2: int
    x1: float
    x2: float
    tip_radius1: float
    tip_radius2: float
    root_radius1: float
    root_radius2: float
    centre_distance: float
    facewidth: float

    @property
    def base_radius1(self) -> float:
        return 0.5 * self.module * self.z1 * math.cos(self.pressure_angle)

    @property
    def base_radius2(self) -> float:
        return 0.5 * self.module * self.z2 * math.cos(self.pressure_angle)


@dataclass(frozen=True)
class GearMesh:
    """The path of contact of a gear pair (docs/model.md §2.1), all points as ρ1 [m].

    A: start of active profile (ρ1 = g - ρ_a2); B = E - p_b: lowest point of single contact;
    C = r_b1 tan α_w: pitch point; D = A + p_b: highest point of single contact; E = ρ_a1: tip of
    gear 1. Transverse contact ratio ε_α = (E - A)/p_b.
    """

    geometry: GearGeometry
    alpha_w: float
    g: float
    pb: float
    A: float
    B: float
    C: float
    D: float
    E: float

    @classmethod
    def from_geometry(cls, geo: GearGeometry) -> GearMesh:
        """Build the path of contact, or raise :class:`MeshingError` if the pair cannot mesh."""
        rb1, rb2, a = geo.base_radius1, geo.base_radius2, geo.centre_distance
        if rb1 + rb2 >= a:
            raise MeshingError(
                f"the centre distance {a * 1e3:.4g} mm is not larger than the sum of the base "
                f"radii {(rb1 + rb2) * 1e3:.4g} mm: the gears cannot mesh", ("centre_distance",))
        a0 = zero_backlash_centre_distance(geo.module, geo.pressure_angle, geo.z1, geo.z2,
                                           geo.x1, geo.x2)
        if a < a0 * (1.0 - 1e-9):
            raise MeshingError(
                f"the centre distance {a * 1e3:.6g} mm is smaller than the zero-backlash centre "
                f"distance {a0 * 1e3:.6g} mm of these profile shifts: the teeth would overlap "
                "(centre distance too small)", ("centre_distance", "x1", "x2"))
        for i, (ra, rb) in enumerate(((geo.tip_radius1, rb1), (geo.tip_radius2, rb2)), 1):
            if ra <= rb:
                raise MeshingError(
                    f"the tip diameter {2 * ra * 1e3:.4g} mm of gear {i} is not larger than its "
                    f"base diameter {2 * rb * 1e3:.4g} mm: the tooth has no involute flank",
                    (f"tip_radius{i}",))
        for i, (z, x, ra) in enumerate(((geo.z1, geo.x1, geo.tip_radius1),
                                        (geo.z2, geo.x2, geo.tip_radius2)), 1):
            sa = float(tooth_thickness(geo.module, geo.pressure_angle, z, x, ra))
            if sa < 0.0:
                raise MeshingError(
                    f"the teeth of gear {i} come to a point below their tip (thickness "
                    f"{sa * 1e3:.4g} mm at the tip diameter): reduce the profile shift or the "
                    "tip diameter", (f"tip_radius{i}", f"x{i}"))
        for i, j, ra, rf in ((1, 2, geo.tip_radius1, geo.root_radius2),
                             (2, 1, geo.tip_radius2, geo.root_radius1)):
            if ra + rf > a:
                raise MeshingError(
                    f"the tip of gear {i} hits the root of gear {j}: tip radius + root radius = "
                    f"{(ra + rf) * 1e3:.4g} mm exceeds the centre distance {a * 1e3:.4g} mm "
                    "(centre distance too small)",
                    ("centre_distance", f"tip_radius{i}", f"root_radius{j}"))
        alpha_w = math.acos((rb1 + rb2) / a)
        g = a * math.sin(alpha_w)
        rho_a1 = math.sqrt(geo.tip_radius1**2 - rb1**2)
        rho_a2 = math.sqrt(geo.tip_radius2**2 - rb2**2)
        A, E = g - rho_a2, rho_a1
        if A < 0.0:
            raise MeshingError(
                f"the tip of gear 2 reaches {-A * 1e3:.4g} mm beyond the base circle of gear 1 "
                "along the line of action (involute interference): reduce the tip diameter of "
                "gear 2 or increase the centre distance", ("tip_radius2", "centre_distance"))
        if E > g:
            raise MeshingError(
                f"the tip of gear 1 reaches {(E - g) * 1e3:.4g} mm beyond the base circle of "
                "gear 2 along the line of action (involute interference): reduce the tip "
                "diameter of gear 1 or increase the centre distance",
                ("tip_radius1", "centre_distance"))
        pb = math.pi * geo.module * math.cos(geo.pressure_angle)
        eps = (E - A) / pb
        if eps < 1.0:
            raise MeshingError(
                f"the transverse contact ratio is {eps:.4f} < 1: the teeth lose contact before "
                "the next pair engages (tip diameters too small or centre distance too large)",
                ("tip_radius1", "tip_radius2", "centre_distance"))
        if eps >= 2.0:
            raise MeshingError(
                f"the transverse contact ratio is {eps:.4f} >= 2: high-contact-ratio gears "
                "(three pairs in mesh) are not supported by the load-sharing models",
                ("tip_radius1", "tip_radius2", "centre_distance"))
        return cls(geometry=geo, alpha_w=alpha_w, g=g, pb=pb, A=A, B=E - pb,
                   C=rb1 * math.tan(alpha_w), D=A + pb, E=E)

    @property
    def contact_ratio(self) -> float:
        """Transverse contact ratio ε_α = (E - A)/p_b."""
        return (self.E - self.A) / self.pb

    @property
    def rb1(self) -> float:
        return self.geometry.base_radius1

    # --- locating points --------------------------------------------------------------------
    def roll_angle(self, rho1):
        """Roll angle of gear 1, φ1 = ρ1 / r_b1 [rad]."""
        return np.asarray(rho1, dtype=float) / self.rb1

    def rho1_from_roll_angle(self, phi1):
        return np.asarray(phi1, dtype=float) * self.rb1

    def radial_position(self, rho1):
        """Tooth-centre radial coordinate of the contact point on gear 1 (docs/model.md §2.1):

        y = r cos ψ(r), r = √(r_b1² + ρ1²), ψ(r) = s/d + inv α - inv α_r, cos α_r = r_b1/r,
        s = m (π/2 + 2 x1 tan α) the reference tooth thickness, d = m z1.
        This is how the paper locates points (Tables 3, 5, 7).
        """
        geo = self.geometry
        r = np.hypot(self.rb1, np.asarray(rho1, dtype=float))
        psi = tooth_thickness(geo.module, geo.pressure_angle, geo.z1, geo.x1, r) / (2.0 * r)
        return r * np.cos(psi)

    def rho1_from_radial_position(self, y: float) -> float:
        """Inverse of :meth:`radial_position` on the active flank [A, E] (y rises with ρ1)."""
        lo, hi = self.radial_range()
        tol = 1e-9 * (hi - lo)
        if not lo - tol <= y <= hi + tol:
            raise ValueError(f"radial position {y * 1e3:.6g} mm outside [{lo * 1e3:.6g}, "
                             f"{hi * 1e3:.6g}] mm")
        if y <= lo:
            return self.A
        if y >= hi:
            return self.E
        return brentq(lambda q: float(self.radial_position(q)) - y, self.A, self.E, xtol=1e-15)

    def radial_range(self) -> tuple[float, float]:
        return float(self.radial_position(self.A)), float(self.radial_position(self.E))

    def rho1_from_modules_below_tip(self, k: float) -> float:
        """The point whose tooth-centre radial coordinate lies k modules below the tip radius of
        gear 1: y(ρ1) = r_a1 - k m (the paper's Table 7 convention)."""
        return self.rho1_from_radial_position(self.geometry.tip_radius1 - k * self.geometry.module)

    def position_range(self, kind: str) -> tuple[float, float]:
        """The A-E range of a position given as ``roll_angle`` [rad], ``radial_position`` [m]
        or ``modules_below_tip`` [-]."""
        if kind == "roll_angle":
            return float(self.roll_angle(self.A)), float(self.roll_angle(self.E))
        lo, hi = self.radial_range()
        if kind == "radial_position":
            return lo, hi
        if kind == "modules_below_tip":
            ra, m = self.geometry.tip_radius1, self.geometry.module
            return (ra - hi) / m, (ra - lo) / m
        raise ValueError(f"unknown position kind {kind!r}")

    def locate(self, kind: str, value: float) -> float:
        """ρ1 of a position given as in :meth:`position_range` (values a rounding error outside
        the range are taken as its end point)."""
        lo, hi = self.position_range(kind)
        tol = 1e-9 * (hi - lo)
        if not lo - tol <= value <= hi + tol:
            raise ValueError(f"{kind} {value:g} outside [{lo:g}, {hi:g}]")
        value = min(max(value, lo), hi)
        if kind == "roll_angle":
            return float(np.clip(self.rho1_from_roll_angle(value), self.A, self.E))
        if kind == "radial_position":
            return self.rho1_from_radial_position(value)
        return self.rho1_from_modules_below_tip(value)

    def evenly_spaced(self, n: int):
        """n points at the centres of n equal intervals of A-E (never the unloaded end points;
        for two identical gears and odd n the middle one is the pitch point)."""
        return self.A + (np.arange(n) + 0.5) * (self.E - self.A) / n

    # --- contact quantities ---------------------------------------------------------------
    def rho2(self, rho1):
        return self.g - np.asarray(rho1, dtype=float)

    def reduced_radius(self, rho1):
        """R = ρ1 ρ2 / (ρ1 + ρ2) with ρ1 + ρ2 = g."""
        rho1 = np.asarray(rho1, dtype=float)
        return rho1 * (self.g - rho1) / self.g

    def surface_speeds(self, rho1, omega1: float):
        """u_i = ω_i ρ_i with ω2 = ω1 z1/z2 (docs/model.md §2.1)."""
        geo = self.geometry
        u1 = omega1 * np.asarray(rho1, dtype=float)
        u2 = omega1 * geo.z1 / geo.z2 * self.rho2(rho1)
        return u1, u2

    def single_pair(self, rho1):
        """True in the single-pair zone B ≤ ρ1 ≤ D."""
        rho1 = np.asarray(rho1, dtype=float)
        tol = 1e-9 * self.pb
        return (rho1 >= self.B - tol) & (rho1 <= self.D + tol)

    def load_share(self, rho1, model: str = "linear", accuracy_grade: int = 7):
        """Load-sharing factor X(ρ1) of the pair in contact at ρ1 (docs/model.md §2.1).

        ``linear``: 0 → 1 over A-B, 1 over B-D, 1 → 0 over D-E (tip relief designed for smooth
        meshing); the two pairs in the double-pair zones share the load exactly (sum 1).
        ``iso_unmodified``: ISO/TS 6336-22 Method B for unmodified profiles,
        X = (Q-2)/15 + t/3 on the ramps (t = 0 at A and E, 1 at B and D), 1 over B-D, with Q the
        ISO 1328 accuracy grade. These ramps bound each pair's share (pitch deviations); the two
        shares sum to 1 for Q = 7 and exceed it above. Grades finer than 7 are taken as 7
        [our choice]: below it the ramps would lose load (shares summing to less than 1).
        ``none``: X = 1 everywhere.
        """
        rho1 = np.asarray(rho1, dtype=float)
        if model == "none":
            return np.ones_like(rho1)
        t = np.where(rho1 < self.B, (rho1 - self.A) / (self.B - self.A),
                     np.where(rho1 > self.D, (self.E - rho1) / (self.E - self.D), 1.0))
        t = np.clip(t, 0.0, 1.0)
        if model == "linear":
            return t
        if model == "iso_unmodified":
            return np.where(t < 1.0, (max(accuracy_grade, 7) - 2) / 15.0 + t / 3.0, 1.0)
        raise ValueError(f"unknown load-sharing model {model!r}; one of {LOAD_SHARING}")
