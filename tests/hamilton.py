"""Independent closed-form reference: stresses under a sliding Hertzian circular (point) contact.

Source: G. M. Hamilton, "Explicit equations for the stresses beneath a sliding spherical
contact", Proc. Instn Mech. Engrs, Part C, 197 (1983) 53–59, doi:10.1243/PIME_PROC_1983_197_076_02
— the explicit field inside an elastic half-space loaded by the Hertz pressure
p(r) = p0 √(1 − r²/a²) on r ≤ a plus the sliding traction q(r) = μ p(r) along +x. Hamilton states
the field with lengths divided by a, in terms of the auxiliary quantities

    A = r² + z² − 1,   S = √(A² + 4 z²),   M = √((S + A)/2),   N = √((S − A)/2),
    φ = arctan(1/M),   G = M² − N² + z M − N,   H = 2 M N + M + z N,

as σ_ij = p0 · (his six equations for the normal load) + q0 · (his six equations for the
tangential load), q0 = μ p0 (with his 3P/(2πa³) = p0/a prefactor made dimensionless). The
equation numbers of the paper could not be checked here (the paper itself was not at hand): the
twelve equations were read from public transcriptions of it (a normal-load NumPy transcription,
"pymilton", and a MATLAB transcription of both parts, "HertzStrainFull"), rewritten here, and
then verified independently of any transcription by tests/test_hamilton_reference.py
(Boussinesq + Cerruti superposition to 2e-10 p0, equilibrium, Beltrami–Michell compatibility,
Johnson's axis and surface solutions, Hamilton's edge tension). The same results are discussed
by Sackfield & Hills, J. Strain Analysis 18 (1983) ("Some useful results in the tangentially
loaded Hertzian contact problem"; "A note on the Hertz contact problem: a correlation of standard
formulae").

Conventions (the project's, as in micropit_hpc.mechanics.hertz_field): stresses
tension-positive, Voigt order (xx, yy, zz, yz, xz, xy), z ≥ 0 is the depth into the body. On the
surface z = 0 inside the contact σ_zz = −p and σ_xz = −q (the traction on the body is
q e_x + p e_z: the pressure pushes into the body and the friction drags it along +x), σ_yz = 0;
outside the contact the three vanish. With this sense of the friction the trailing edge x = −a is
in tension: σ_xx(−a, 0, 0) = p0 [(1 − 2ν)/3 + μ π (4 + ν)/8] (Hamilton's maximum surface
tension), and σ_xx(+a, 0, 0) = p0 [(1 − 2ν)/3 − μ π (4 + ν)/8].

Singular points of the formulas (all removable; the stress field itself is bounded):

* the axis r = 0, where the terms carry 1/r², 1/r⁴ and 1/r⁶ factors that cancel: for
  r < ``_R_AXIS`` · a = 0.01 a the value is obtained by continuity, from Richardson
  extrapolation of the symmetric two-point averages [f(p + ρe) + f(p − ρe)]/2 (e ⟂ p in the
  plane z = const) at ρ = 0.01 a, 2ρ and 3ρ, which is exact up to O(ρ⁶): measured error
  < 1e-10 p0 on the axis against Johnson's axis solution and the Cerruti quadrature (and free of
  the O(ε a³/r³) round-off that the raw formulas have next to the axis). The switch at
  r = 0.01 a is continuous to ~1e-10 p0, but finite differences of the returned field taken
  inside that zone amplify this by 1/h (1/h²);
* the edge circle r = a, z = 0, where S = M = N = 0 and the 1/S and 1/(G² + H²) terms are 0/0:
  each of them carries a factor that vanishes faster than its denominator, so it is given its
  limit 0 there. The returned value is the limit of the field (for instance the σ_xx(−a, 0, 0)
  above); on the surface the stresses are continuous across r = a (with the √|r − a| behaviour
  of the Hertz field);
* M and N are evaluated without cancellation (the larger one from S ± |A|, the other from
  M N = z), so points just outside the contact at small depth are accurate; z = 0 itself needs
  no special treatment (φ = π/2 inside the contact, where M = 0).

Accuracy, against the Boussinesq/Cerruti quadrature: ≤ 2e-10 p0 for z = 0.3…0.8 a near the
contact (tests), ~1e-15 p0 at off-axis points out to r = 30 a (checked once while writing), and
~5e-11 p0 on the axis at z = 10 a (the axis continuation).
"""

from __future__ import annotations

import numpy as np

__all__ = ["hamilton_stresses"]

_R_AXIS = 1e-2   # below this radius (in units of a) the value is taken by continuity
# Richardson weights extrapolating A(ρ) = f + c₁ρ² + c₂ρ⁴ + O(ρ⁶) from ρ, 2ρ, 3ρ to ρ = 0
# (Lagrange in ρ² at the nodes 1, 4, 9, evaluated at 0)
_RICHARDSON = (1.5, -0.6, 0.1)


def _safe(d):
    """The denominator d with its zeros replaced by 1 (the numerators vanish there)."""
    return np.where(d > 0.0, d, 1.0)


def _dimensionless(x, y, z, nu):
    """Hamilton's normal (per p0) and tangential (per q0) stresses, a = 1, points off the axis.

    Returns two arrays (6, n) in Voigt order (xx, yy, zz, yz, xz, xy)."""
    x2, y2, z2 = x * x, y * y, z * z
    r2 = x2 + y2
    A = r2 + z2 - 1.0
    S = np.sqrt(A * A + 4.0 * z2)
    # M N = z and M² − N² = A: the larger of M, N from S ± |A|, the other from the product.
    big = np.sqrt(0.5 * (S + np.abs(A)))
    small = z / _safe(big)
    M = np.where(A >= 0.0, big, small)
    N = np.where(A >= 0.0, small, big)
    phi = np.arctan2(1.0, M)
    G = M * M - N * N + z * M - N
    H = 2.0 * M * N + M + z * N
    iS = 1.0 / _safe(S)
    GH = z * H / _safe(G * G + H * H)
    ir2 = 1.0 / r2
    ir4 = ir2 * ir2
    k = 1.0 - 2.0 * nu

    # --- normal load (Hamilton 1983, the six normal-load equations), per p0 ----------------
    common = (1.0 - nu) * N * z2 - k / 3.0 * (N * S + 2.0 * A * N + 1.0) - nu * M * z
    n_xx = (1.0 + nu) * z * phi + ir2 * ((y2 - x2) * ir2 * common - N * (x2 + 2.0 * nu * y2)
                                          - M * x2 * z * iS)
    n_yy = (1.0 + nu) * z * phi + ir2 * ((x2 - y2) * ir2 * common - N * (y2 + 2.0 * nu * x2)
                                          - M * y2 * z * iS)
    n_zz = -N + z * M * iS
    n_xy = x * y * ir4 * (k * (-N * r2 + 2.0 / 3.0 * N * (S + 2.0 * A) - z * (z * N + M)
                               + 2.0 / 3.0)
                          + z * (-M * r2 * iS - z * N + M))
    n_yz = -z * y * (N * iS - GH)
    n_xz = -z * x * (N * iS - GH)

    # --- tangential load along +x (Hamilton 1983, the six tangential-load equations), per q0
    cx = 1.5 - 2.0 * x2 * ir2            # (3/2 − 2x²/r²)
    hx = 0.5 - 2.0 * x2 * ir2            # (1/2 − 2x²/r²)
    hy = 0.5 - 2.0 * y2 * ir2            # (1/2 − 2y²/r²)
    w = -k * (S / 6.0 + A / 3.0)         # −(1 − 2ν)(S/6 + A/3)
    t_xx = (-x * (1.0 + nu / 4.0) * phi
            + x * M * ir4 * (cx * (nu * (S - 2.0 * A) + z2) + x2 * z2 * iS
                             + 1.75 * nu * r2 - 2.0 * nu * x2 + r2)
            + x * z * N * ir4 * (cx * (w - 0.5 * (z2 + 3.0)) + x2 * iS - 0.25 * nu * r2
                                 - 1.75 * r2)
            + 4.0 / 3.0 * k * x * z * ir4 * cx)
    t_yy = (-0.75 * nu * x * phi
            + x * M * ir4 * (hy * (nu * (S - 2.0 * A + r2) + z2) + y2 * z2 * iS + 0.75 * nu * r2)
            + x * z * N * ir4 * (hy * (w - 0.5 * z2 - 1.5) + y2 * iS - 0.75 * nu * r2
                                 - 0.25 * r2)
            + 4.0 / 3.0 * k * x * z * ir4 * hy)
    t_zz = 0.5 * x * z * N * ir2 * (1.0 - (r2 + z2 + 1.0) * iS)
    t_xy = (0.5 * y * (0.5 * nu - 1.0) * phi
            + y * M * ir4 * (x2 * z2 * iS + nu * ((S - 2.0 * A) * hx - 2.0 * x2 + 0.25 * r2)
                             + 0.5 * r2 + z2 * hx)
            + y * z * N * ir4 * (hx * (w - 0.5 * z2 - 1.5 - 0.5 * r2) + 0.25 * nu * r2 + x2 * iS
                                 - 0.5 * y2 - 1.5 * x2)
            + 4.0 / 3.0 * k * y * z * ir4 * hx)
    t_yz = 0.5 * x * y * z * ir4 * (M * (0.5 + (0.5 * z2 - 1.5 - 0.5 * r2) * iS)
                                    + 0.5 * z * N * (-3.0 + (5.0 + z2 + r2) * iS))
    t_xz = (1.5 * z * phi + z * M * ir2 * (1.0 + x2 * ir2 - x2 * iS)
            + N * ir2 * (-0.75 * (S + 2.0 * A) + z2 - 0.75 - 0.25 * r2 + 0.5 * z2 * hx))

    normal = np.stack([n_xx, n_yy, n_zz, n_yz, n_xz, n_xy])
    tangential = np.stack([t_xx, t_yy, t_zz, t_yz, t_xz, t_xy])
    return normal, tangential


def _combined(x, y, z, mu, nu):
    n, t = _dimensionless(x, y, z, nu)
    return n + mu * t


def hamilton_stresses(x, y, z, a, p0, mu, nu) -> np.ndarray:
    """Stresses (6, *shape) under the sliding Hertz circle (Hamilton 1983; module docstring).

    x, y, z: coordinates (broadcast together), z ≥ 0 the depth into the body; a: contact
    radius; p0: peak Hertz pressure; mu: friction coefficient (traction μp on the body along +x;
    a negative μ reverses it); nu: Poisson's ratio. Voigt order (xx, yy, zz, yz, xz, xy),
    tension positive, σ_zz(z = 0) = −p and σ_xz(z = 0) = −μp inside the contact. Values on the
    axis r = 0 and on the edge circle r = a, z = 0 are the continuous limits (module docstring).
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    if a <= 0:
        raise ValueError(f"contact radius a = {a} must be positive")
    if not np.all(np.isfinite(z)) or np.any(z < 0):
        raise ValueError("z must be finite and non-negative (depth into the body)")
    shape = x.shape
    X, Y, Z = (v.ravel() / a for v in (x, y, z))
    R = np.hypot(X, Y)
    out = np.empty((6, X.size))
    far = R >= _R_AXIS
    if np.any(far):
        out[:, far] = _combined(X[far], Y[far], Z[far], mu, nu)
    near = ~far
    if np.any(near):
        xn, yn, zn, rn = X[near], Y[near], Z[near], R[near]
        # unit vector ⟂ (x, y) in the plane; any direction on the axis itself
        on_axis = rn == 0.0
        rs = np.where(on_axis, 1.0, rn)
        ex = np.where(on_axis, 1.0, -yn / rs)
        ey = np.where(on_axis, 0.0, xn / rs)

        acc = 0.0
        for m, weight in zip((1.0, 2.0, 3.0), _RICHARDSON, strict=True):
            rho = m * _R_AXIS
            plus = _combined(xn + rho * ex, yn + rho * ey, zn, mu, nu)
            minus = _combined(xn - rho * ex, yn - rho * ey, zn, mu, nu)
            acc = acc + 0.5 * weight * (plus + minus)
        out[:, near] = acc
    return p0 * out.reshape((6, *shape))
