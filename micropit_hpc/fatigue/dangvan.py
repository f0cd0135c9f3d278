"""Dang Van multiaxial fatigue: the mesoscopic shear of a stress path (docs/model.md §4.3).

For each material point, over the m samples of its stress history σ(t) (Dang Van, Cailletaud,
Flavenot, Le Douaron & Lieurade 1989; in rolling contact [B11] Morales-Espejel & Brizmer 2011,
[D06] Desimone, Bernasconi & Beretta 2006):

* deviator s(t) = σ(t) − σ_H(t) I, σ_H = tr σ / 3;
* s_m = the centre of the smallest hypersphere enclosing the path {s(t)} in the space of
  deviators with the Frobenius norm (the 6-vector with √2 on the shear components);
  ŝ(t) = s(t) − s_m;
* mesoscopic shear τ̂(t) = (ŝ_I − ŝ_III)/2 (Tresca of ŝ), and
  τ_DV = max_t [τ̂(t) + α_DV σ_H(t)], α_DV = 3(1/√3 − ½) ≈ 0.232.

Deviators are handled as 5-vectors in an orthonormal basis of the trace-free symmetric tensors,

    v = ((σxx − σyy)/√2, (σxx + σyy − 2σzz)/√6, √2 σyz, √2 σxz, √2 σxy),

so |v|² = s:s and the hydrostatic part drops out without being formed.

The enclosing ball is found per point by the Frank–Wolfe algorithm with away steps on the dual
problem (Yildirim, SIAM J. Optim. 19 (2008) 1368, Algorithm 2; the plain Frank–Wolfe iteration is
Bădoiu & Clarkson's): weights λ on the simplex, centre c = Σ λ_k p_k, dual value
ρ = Σ λ_k |p_k − c|² ≤ R*² ≤ R(c)² = max_k |p_k − c|². Both steps use the exact line search, the
iteration converges linearly, and it stops when R(c)² − ρ ≤ tol · R(c)²; since the squared
distance to the farthest point is 1-strongly convex in c, the centre is then within √tol · R of
the exact one. All points advance together in NumPy arrays with the point axis last; a point's
result depends only on its own path (converged points are compacted away), so it is the same
bitwise in any batch or decomposition.

Two implementations of :func:`dang_van` (``kernel=``): the NumPy path above, which is the
reference, and a compiled one (:mod:`._dangvan_numba`, Numba, one point at a time in machine
code: the same algorithm, the same results to round-off, several times faster). ``"auto"``
(:data:`DEFAULT_KERNEL`) takes the compiled one where Numba can be imported and the NumPy path
otherwise; Numba is optional (docs/install.md, docs/performance.md "Compiled Dang Van").
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["ALPHA_DV", "CHUNK", "DEFAULT_KERNEL", "DangVan", "DangVanStream", "dang_van",
           "deviator_vectors", "enclosing_ball", "mesoscopic_shear", "numba_kernel"]

#: α_DV = 3(1/√3 − ½): the Dang Van hydrostatic sensitivity (docs/model.md §4.3).
ALPHA_DV = 3.0 * (1.0 / math.sqrt(3.0) - 0.5)

_R2, _R6 = math.sqrt(2.0), math.sqrt(6.0)

#: :func:`mesoscopic_shear` takes the eigenvalues where |cos 3θ| > 1 − LODE_EDGE: there the
#: Lode-angle formula would lose more than about 1e-12 of the shear (its error is roughly
#: 1e-16/√(1 − |cos 3θ|) relative). A constant: the compiled kernel reads it when it is compiled.
LODE_EDGE = 1e-6

#: The kernel :func:`dang_van` uses when none is given: "auto" (compiled where Numba can be
#: imported, else NumPy), "numba" or "numpy". A module-level switch for whole runs.
DEFAULT_KERNEL = "auto"

#: Points per batch of the NumPy path (bounds its temporaries; :func:`dang_van`'s ``chunk``).
CHUNK = 32768

_KERNELS = ("auto", "numba", "numpy")
_numba_module = None            # the imported kernel module, False once the import failed


def numba_kernel():
    """The compiled kernel (``_dangvan_numba.dang_van_points``), or None where Numba cannot be
    imported. The outcome of the first import is kept."""
    global _numba_module
    if _numba_module is None:
        try:
            from micropit_hpc.fatigue import _dangvan_numba
        except ModuleNotFoundError:             # no Numba: the NumPy path, silently
            _numba_module = False
        except Exception as err:                # a broken Numba, no writable cache, ...
            warnings.warn(f"dang_van: the compiled kernel is not available ({err!r}); "
                          "using the NumPy path", RuntimeWarning, stacklevel=3)
            _numba_module = False
        else:
            _numba_module = _dangvan_numba
    return _numba_module.dang_van_points if _numba_module else None


def deviator_vectors(sigma: np.ndarray) -> np.ndarray:
    """Deviators of Voigt stresses as orthonormal 5-vectors (module docstring).

    ``sigma`` has the 6 Voigt components (xx, yy, zz, yz, xz, xy) on axis 0; the result has the
    5 components on axis 0 and the remaining axes unchanged, with |v|² = s:s.
    """
    sxx, syy, szz, syz, sxz, sxy = sigma
    return np.stack(((sxx - syy) / _R2, (sxx + syy - 2.0 * szz) / _R6,
                     _R2 * syz, _R2 * sxz, _R2 * sxy))


def _sq_dist(p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """|p_k − c|² for p (d, m, n) and c (d, n); sums over the leading axis in a fixed order."""
    diff = p[0] - c[0]
    r = diff * diff
    for i in range(1, p.shape[0]):
        diff = p[i] - c[i]
        r += diff * diff
    return r


def _support_correction(p, c, lam):
    """One active-set step on the support of each set (called every few Frank–Wolfe steps).

    Let S be the support (λ_k > 0) of a set; of a larger support only the d + 2 points of
    largest weight are used (they are always affinely dependent, first case below).

    * S affinely dependent (more than d + 1 points, or all in a lower-dimensional flat, as the
      surface layer's paths with σ_yz = 0): a vector μ with Σ μ_k p_k = 0, Σ μ_k = 0 exists
      (the last right-singular vector of [p − c; 1] over S). Moving λ along μ until a weight
      reaches zero keeps c and removes that point; the sign of μ is chosen so that the dual
      value ρ = Σ λ_k |p_k − c|² does not fall (Carathéodory's theorem).
    * S affinely independent: the point c' of its affine hull equidistant from S,
      c' = p_0 + Σ β_j D_j with D_i·D_j β_j = ½|D_i|², D_j = p_j − p_0, maximises the concave
      dual on the face spanned by S. Where its weights λ' are all ≥ 0 the step goes there;
      otherwise along λ → λ' until the first weight reaches zero, which leaves S.

    The dual value never falls. Returns the new (c, lam) and a mask of the sets from which a
    point left (worth another step at once).
    """
    d, m, n = p.shape
    k = min(d + 2, m)
    count = (lam > 0.0).sum(axis=0)
    order = np.argsort(-lam, axis=0, kind="stable")[:k]                # (k, n)
    c, lam = c.copy(), lam.copy()
    blocked = np.zeros(n, bool)
    for s in range(2, k + 1):
        sel = np.flatnonzero(count >= s if s == d + 2 else count == s)
        if sel.size == 0:
            continue
        o = order[:s, sel]                                               # (s, q)
        pts = np.take_along_axis(p[:, :, sel], np.broadcast_to(o, (d, *o.shape)), axis=1)
        w = np.take_along_axis(lam[:, sel], o, axis=0)                   # (s, q)
        cs = c[:, sel]
        dependent = np.ones(sel.size, bool)
        # ---- independent supports: go to (or towards) the face's exact centre ------------
        if s <= d + 1:
            D = pts[:, 1:] - pts[:, :1]                                  # (d, s-1, q)
            M = np.einsum("aiu,aju->uij", D, D)
            rhs = 0.5 * np.einsum("aiu,aiu->ui", D, D)
            with np.errstate(all="ignore"):
                try:
                    beta = np.linalg.solve(M, rhs[:, :, None])[:, :, 0]  # (q, s-1)
                except np.linalg.LinAlgError:        # an exactly singular M somewhere
                    beta = np.full((sel.size, s - 1), np.nan)
                new_w = np.concatenate([(1.0 - beta.sum(axis=1))[None], beta.T])  # (s, q)
                # accept where the centre is equidistant from the support (a nearly
                # dependent support fails this and goes to the Carathéodory step)
                cc = pts[:, 0] + np.einsum("aiu,iu->au", D, beta.T)
                r_sup = _sq_dist(pts, cc)
                ok = (np.abs(r_sup - r_sup[0]) <= 1e-9 * r_sup[0]).all(axis=0)
                ok &= np.isfinite(new_w).all(axis=0) & (np.abs(new_w).max(axis=0) < 1e8)
                dec = new_w < w
                ratio = np.where(dec, w / np.where(dec, w - new_w, 1.0), np.inf)
            first = np.argmin(ratio, axis=0)
            cols = np.arange(sel.size)
            t = np.minimum(ratio[first, cols], 1.0)
            ok &= t > 0.0
            wi = w + t * (new_w - w)
            hit = ok & (t < 1.0)
            wi[first[hit], cols[hit]] = 0.0
            w = np.where(ok, np.maximum(wi, 0.0), w)
            blocked[sel[hit]] = True
            dependent = ~ok
        # ---- affinely dependent supports: drop a point, keep the centre -----------------
        if dependent.any():
            j = np.flatnonzero(dependent)
            pj, cj = pts[:, :, j], cs[:, j]
            scale = np.sqrt(_sq_dist(pj, cj).max(axis=0))
            scale = np.where(scale > 0.0, scale, 1.0)
            A = np.concatenate([(pj - cj[:, None, :]) / scale, np.ones((1, s, j.size))])
            mu = np.linalg.svd(A.transpose(2, 0, 1))[2][:, -1, :].T      # (s, qj)
            mu *= np.where((mu * _sq_dist(pj, cj)).sum(axis=0) < 0.0, -1.0, 1.0)
            wj = w[:, j]
            neg = mu < 0.0
            ratio = np.where(neg, wj / np.where(neg, -mu, 1.0), np.inf)
            first = np.argmin(ratio, axis=0)
            cols = np.arange(j.size)
            wj = np.maximum(wj + ratio[first, cols] * mu, 0.0)
            wj[first, cols] = 0.0
            w[:, j] = wj
            blocked[sel[j]] = True
        lam[o, np.broadcast_to(sel, o.shape)] = w
        lam[:, sel] /= lam[:, sel].sum(axis=0)
        c[:, sel] = np.einsum("aku,ku->au", p[:, :, sel], lam[:, sel])
    return c, lam, blocked


#: The relative duality gap (R² − ρ)/R² below which a set that has not met ``tol`` after
#: ``max_iter`` iterations is accepted: the round-off floor of the gap on degenerate sets.
ROUNDOFF_GAP = 1e-9


def _qp_balls(p: np.ndarray, lam: np.ndarray):
    """The smallest enclosing balls of the sets ``p`` (d, m, k) by the dual quadratic program
    max_λ Σ λ_i |p_i|² − |Σ λ_i p_i|² on the simplex, solved by SciPy's SLSQP, each set scaled
    to unit size, from the weights ``lam`` (m, k) and from uniform weights (SLSQP can stall at
    the iteration's weights where two points of the path nearly coincide: the start and end of
    a closed path, on a 1024² gear cycle), the better kept: the fallback of
    :func:`enclosing_ball` for the rare set its iteration leaves open. Returns the centres
    (d, k), R(c)² and the dual value ρ of the solver's weights (k,): R(c)² − ρ ≥ 0 bounds how
    far R(c) is from the smallest radius (weak duality), so that the caller can judge the gap.
    """
    from scipy.optimize import minimize

    d, m, k = p.shape
    centres, R2, rho = np.empty((d, k)), np.full(k, np.inf), np.zeros(k)
    constraint = ({"type": "eq", "fun": lambda w: w.sum() - 1.0,
                   "jac": lambda w: np.ones_like(w)},)
    for j in range(k):
        x = p[:, :, j]
        if not np.isfinite(x).all():      # no ball: left to the caller's error
            continue
        size = float(np.sqrt((x * x).sum(axis=0).max())) or 1.0
        y = x / size
        G = y.T @ y
        s = np.diag(G).copy()
        for start in (lam[:, j], np.full(m, 1.0 / m)):
            res = minimize(lambda w, G=G, s=s: w @ G @ w - s @ w, start,
                           jac=lambda w, G=G, s=s: 2.0 * G @ w - s, method="SLSQP",
                           bounds=[(0.0, 1.0)] * m, constraints=constraint,
                           options={"ftol": 1e-16, "maxiter": 1000})
            w = np.clip(res.x, 0.0, None)
            if not np.all(np.isfinite(w)) or w.sum() <= 0.0:
                continue
            w /= w.sum()
            c = x @ w
            r = ((x - c[:, None]) ** 2).sum(axis=0)
            dual = w @ r           # stationary at the optimum: accurate to second order
            # the primal side: the point equidistant from the support (least squares on its
            # affine hull), where that encloses the set more tightly than the centroid c
            sup = x[:, w > 1e-7 * w.max()]
            D = sup[:, 1:] - sup[:, :1]
            beta = np.linalg.lstsq(D.T @ D, 0.5 * (D * D).sum(axis=0), rcond=None)[0]
            cc = sup[:, 0] + D @ beta
            rc = ((x - cc[:, None]) ** 2).sum(axis=0).max()
            primal, centre = (rc, cc) if rc < r.max() else (r.max(), c)
            if primal - dual < R2[j] - rho[j]:
                centres[:, j], R2[j], rho[j] = centre, primal, dual
    return centres, R2, rho


def enclosing_ball(points: np.ndarray, tol: float = 1e-12, max_iter: int = 2000,
                   correct_every: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest ball enclosing each of n point sets.

    ``points`` has shape (d, m, n): n sets of m points in d dimensions. Returns the centres
    (d, n), the radii (n,) and the iterations each set took (n,).

    Frank–Wolfe with away steps on the dual (Yildirim 2008, Algorithm 2) finds the support;
    every ``correct_every`` iterations a fully-corrective step (:func:`_support_correction`)
    jumps to the exact centre of the current support, so a set whose support has been found
    converges to round-off in one step (plain Frank–Wolfe zig-zags for thousands of iterations
    on real stress paths). A set stops when R(c)² − ρ ≤ tol·R(c)² (module docstring). Sets
    still open after ``max_iter`` iterations are accepted if their gap is within
    :data:`ROUNDOFF_GAP` of R(c)² (round-off stalls the gap of some degenerate sets above
    ``tol``), or once the dual quadratic program solved by SciPy (:func:`_qp_balls`) brings it
    there, and raise RuntimeError otherwise.
    """
    p = np.ascontiguousarray(points, dtype=float)
    d, m, n = p.shape
    if m < 1:
        raise ValueError("enclosing_ball: each set needs at least one point")
    ref = p.mean(axis=1)        # work about each set's mean: no cancellation on sets whose
    p = p - ref[:, None, :]     # spread is tiny against their distance from the origin
    idx = np.arange(n)
    # initial pair (Yildirim): beta farthest from p_0, gamma farthest from beta
    beta = np.argmax(_sq_dist(p, p[:, 0, :]), axis=0)
    gamma = np.argmax(_sq_dist(p, p[:, beta, idx]), axis=0)
    lam = np.zeros((m, n))
    lam[beta, idx] += 0.5
    lam[gamma, idx] += 0.5
    c = 0.5 * (p[:, beta, idx] + p[:, gamma, idx])

    centre = np.empty((d, n))
    radius2 = np.empty(n)
    iters = np.zeros(n, dtype=np.int64)
    active = idx.copy()        # original ids of the sets still iterating
    for it in range(max_iter + 1):
        r = _sq_dist(p, c)
        far = np.argmax(r, axis=0)
        cols = np.arange(active.size)
        R2 = r[far, cols]
        rho = (lam * r).sum(axis=0)
        done = R2 - rho <= tol * R2
        if done.any():
            centre[:, active[done]] = c[:, done]
            radius2[active[done]] = R2[done]
            iters[active[done]] = it
            keep = ~done
            if not keep.any():
                break
            p, c, lam, r, far, R2, rho = (p[:, :, keep], c[:, keep], lam[:, keep], r[:, keep],
                                          far[keep], R2[keep], rho[keep])
            active = active[keep]
            cols = np.arange(active.size)
        if it == max_iter:
            # a set whose gap stalls within ROUNDOFF_GAP of R² is at its optimum to what
            # double precision can certify (met on a symmetric path with repeated points,
            # one in 5 M material points of a 512² cycle): accepted. The rest (one in some
            # 30 M of a 1024² cycle) is solved again by the QP fallback, and accepted where
            # that meets the same test; anything else is not
            stalled = R2 - rho <= ROUNDOFF_GAP * R2
            if not stalled.all():
                rest = np.flatnonzero(~stalled)
                c_q, R2_q, rho_q = _qp_balls(p[:, :, rest], lam[:, rest])
                better = R2_q - rho_q < R2[rest] - rho[rest]
                c[:, rest[better]] = c_q[:, better]
                R2[rest[better]], rho[rest[better]] = R2_q[better], rho_q[better]
                stalled = R2 - rho <= ROUNDOFF_GAP * R2
            centre[:, active[stalled]] = c[:, stalled]
            radius2[active[stalled]] = R2[stalled]
            iters[active[stalled]] = it
            if not stalled.all():
                worst = float(np.max(np.where(stalled, 0.0, (R2 - rho) / R2)))
                raise RuntimeError(f"enclosing_ball: {int((~stalled).sum())} point sets not "
                                   f"converged to tol = {tol:g} after {max_iter} iterations "
                                   f"(largest relative gap {worst:.3g})")
            break
        # away vertex: the nearest point among those with positive weight
        away = np.argmin(np.where(lam > 0.0, r, np.inf), axis=0)
        r_a = r[away, cols]
        lam_a = lam[away, cols]
        gain_fw, gain_away = R2 - rho, rho - r_a
        fw = gain_fw >= gain_away
        # Frank-Wolfe step towards the farthest point: gamma = (R² − ρ)/(2R²) in (0, ½]
        g_fw = gain_fw / (2.0 * R2)
        # away step from the nearest support point: gamma ≤ λ_a/(1 − λ_a) keeps λ_a ≥ 0
        g_max = np.where(lam_a < 1.0, lam_a / np.where(lam_a < 1.0, 1.0 - lam_a, 1.0), 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            g_aw = np.where(r_a > 0.0, gain_away / (2.0 * r_a), np.inf)
        g_aw = np.minimum(g_aw, g_max)
        drop = ~fw & (g_aw == g_max)               # the away vertex leaves the support
        g = np.where(fw, g_fw, g_aw)
        scale = np.where(fw, 1.0 - g, 1.0 + g)
        lam *= scale
        target = np.where(fw, far, away)
        lam[target, cols] += np.where(fw, g, -g)
        lam[away[drop], cols[drop]] = 0.0
        pt = p[:, target, cols]
        c = scale * c + np.where(fw, g, -g) * pt
        if correct_every and it % correct_every == correct_every - 1:
            sub = cols
            for _ in range(d + 2):          # minor cycles (Wolfe 1976) while a point leaves
                c_s, lam_s, blocked = _support_correction(p[:, :, sub], c[:, sub], lam[:, sub])
                c[:, sub], lam[:, sub] = c_s, lam_s
                sub = sub[blocked]
                if sub.size == 0:
                    break
    return centre + ref, np.sqrt(radius2), iters


def mesoscopic_shear(v: np.ndarray) -> np.ndarray:
    """Tresca shear (ŝ_I − ŝ_III)/2 of trace-free tensors given as 5-vectors (axis 0).

    With J2 = ½ ŝ:ŝ = ½|v|², J3 = det ŝ and cos 3θ = (3√3/2) J3/J2^{3/2} (θ ∈ [0, π/3], the
    Lode angle), the principal values are 2√(J2/3) cos(θ − 2πk/3), so
    (ŝ_I − ŝ_III)/2 = √J2 sin(θ + π/3).

    Near θ = 0 or π/3 (two principal values nearly equal, |cos 3θ| > 1 − :data:`LODE_EDGE`)
    the angle from cos 3θ keeps only about half the digits (1 − cos 3θ cancels), so there
    the shear is taken from the eigenvalues themselves (``eigvalsh``): absolute error about
    ε|ŝ| everywhere.
    """
    a, b = v[0] / _R2, v[1] / _R6
    sxx, syy, szz = a + b, b - a, -2.0 * b
    syz, sxz, sxy = v[2] / _R2, v[3] / _R2, v[4] / _R2
    j2 = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3] + v[4] * v[4])
    j3 = (sxx * syy * szz + 2.0 * sxy * syz * sxz - sxx * syz * syz - syy * sxz * sxz
          - szz * sxy * sxy)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos3 = np.where(j2 > 0.0, 1.5 * math.sqrt(3.0) * j3 / (j2 * np.sqrt(j2)), 0.0)
    theta = np.arccos(np.clip(cos3, -1.0, 1.0)) / 3.0
    tau = np.asarray(np.sqrt(j2) * np.sin(theta + math.pi / 3.0))
    near = np.abs(cos3) > 1.0 - LODE_EDGE
    if near.any():
        shape = tau.shape
        tau, near = tau.reshape(-1).copy(), near.reshape(-1)
        t = [np.broadcast_to(x, shape).reshape(-1)[near]
             for x in (sxx, sxy, sxz, syy, syz, szz)]
        mat = np.stack([np.stack(t[0:3]), np.stack([t[1], t[3], t[4]]),
                        np.stack([t[2], t[4], t[5]])]).transpose(2, 0, 1)     # (k, 3, 3)
        ev = np.linalg.eigvalsh(mat)
        tau[near] = 0.5 * (ev[:, 2] - ev[:, 0])
        tau = tau.reshape(shape)
    return tau


@dataclass(frozen=True)
class DangVan:
    """Dang Van result per material point (shapes: the point axes of the input).

    ``tau_dv``: max_t [τ̂ + α σ_H] [Pa]; ``series``: τ̂(t) + α σ_H(t) (time first), present only
    when asked for (rainflow counting); ``radius``: the enclosing radius R* (Frobenius, [Pa]);
    ``iterations``: the most enclosing-ball iterations any point needed.
    """

    tau_dv: np.ndarray
    radius: np.ndarray
    iterations: int
    series: np.ndarray | None = None


def dang_van(history: np.ndarray, alpha: float = ALPHA_DV, tol: float = 1e-12,
             chunk: int = CHUNK, keep_series: bool = False,
             kernel: str | None = None) -> DangVan:
    """τ_DV of every material point of a stress history (docs/model.md §4.3, [B11] eq. 8–10).

    ``history`` has shape (m, 6, *points): m time samples of the Voigt stresses (xx, yy, zz, yz,
    xz, xy; tension positive) at every point. Points are processed in chunks of ``chunk`` to
    bound the temporaries (NumPy path); a point's result does not depend on the chunking.

    ``kernel``: "numpy" (the reference), "numba" (compiled; ImportError without Numba) or
    "auto" (compiled where Numba can be imported); None takes :data:`DEFAULT_KERNEL`. The two
    agree to round-off (module docstring).
    """
    kernel = DEFAULT_KERNEL if kernel is None else kernel
    if kernel not in _KERNELS:
        raise ValueError(f"dang_van: kernel must be one of {_KERNELS}, got {kernel!r}")
    h = np.asarray(history, dtype=float)
    if h.ndim < 2 or h.shape[1] != 6:
        raise ValueError(f"dang_van: history must have shape (m, 6, ...), got {h.shape}")
    m, pts = h.shape[0], h.shape[2:]
    flat = h.reshape(m, 6, -1)
    n = flat.shape[2]
    compiled = numba_kernel() if kernel != "numpy" else None
    if kernel == "numba" and compiled is None:
        raise ImportError("dang_van: kernel='numba' needs Numba (python3-numba; "
                          "docs/install.md)")
    if compiled is not None:
        return _dang_van_compiled(compiled, flat, pts, alpha, tol, keep_series)
    tau = np.empty(n)
    rad = np.empty(n)
    series = np.empty((m, n)) if keep_series else None
    most = 0
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        sig = flat[:, :, lo:hi].transpose(1, 0, 2)            # (6, m, k)
        v = deviator_vectors(sig)                              # (5, m, k)
        centre, radius, iters = enclosing_ball(v, tol=tol)
        shear = mesoscopic_shear(v - centre[:, None, :])       # (m, k)
        y = shear + alpha * (sig[0] + sig[1] + sig[2]) / 3.0
        tau[lo:hi] = y.max(axis=0)
        rad[lo:hi] = radius
        if series is not None:
            series[:, lo:hi] = y
        most = max(most, int(iters.max(initial=0)))
    return DangVan(tau_dv=tau.reshape(pts), radius=rad.reshape(pts), iterations=most,
                   series=None if series is None else series.reshape((m, *pts)))


def _dang_van_compiled(compiled, flat, pts, alpha, tol, keep_series, max_iter=2000) -> DangVan:
    """dang_van on the compiled kernel ``compiled`` (enclosing_ball's defaults: max_iter,
    correct_every=1): the whole history as one piece of a :class:`DangVanStream`, which reads
    it in place (a strided slice too: +9 % in the kernel, where its copy cost +14 %) and
    redoes the points the kernel leaves unconverged on the reference path."""
    m, _, n = flat.shape
    stream = DangVanStream(m, n, alpha, tol, keep_series=keep_series, kernel="numba",
                           max_iter=max_iter, compiled=compiled)
    stream.feed(flat)
    dv = stream.result()
    return DangVan(tau_dv=dv.tau_dv.reshape(pts), radius=dv.radius.reshape(pts),
                   iterations=dv.iterations,
                   series=dv.series.reshape((m, *pts)) if keep_series else None)


class DangVanStream:
    """:func:`dang_van` of a history whose points arrive in consecutive pieces (the streamed
    stresses, docs/performance.md "Streamed stresses"): :meth:`feed` each piece (m, 6, k) of
    the points in order, then :meth:`result` gives the numbers of one
    ``dang_van(history, alpha, tol, chunk=batch, keep_series, kernel)`` call on the whole
    (m, 6, n) history, bit for bit.

    The compiled kernel works point by point: each piece goes through it in place, as it comes,
    and only the points it leaves unconverged (about one in millions) are kept, to be redone on
    the NumPy path together at the end, as one call on the whole history does. The NumPy path
    is fed the whole history's batches of ``batch`` consecutive points (its ``chunk``): a batch
    that straddles two pieces is completed in a small carry buffer. (Until 2026-11-29 the
    compiled path was fed those batches too: at 64² and 128² nearly every batch straddled two
    layer chunks, and copying it into the carry took a fifth of the stage.) ``max_iter``: the
    compiled kernel's enclosing-ball iterations (as :func:`enclosing_ball`'s); ``compiled``:
    the compiled kernel to use (None: :func:`numba_kernel`'s, where ``kernel`` allows it)."""

    def __init__(self, m: int, n: int, alpha: float = ALPHA_DV, tol: float = 1e-12,
                 batch: int = CHUNK, keep_series: bool = False, kernel: str | None = None,
                 max_iter: int = 2000, compiled=None):
        kernel = DEFAULT_KERNEL if kernel is None else kernel
        if kernel not in _KERNELS:
            raise ValueError(f"DangVanStream: kernel must be one of {_KERNELS}, got {kernel!r}")
        self.m, self.n, self.alpha, self.tol = int(m), int(n), float(alpha), float(tol)
        self.batch, self.keep_series = int(batch), bool(keep_series)
        self.max_iter = int(max_iter)
        self._compiled = (None if kernel == "numpy" else
                          compiled if compiled is not None else numba_kernel())
        if kernel == "numba" and self._compiled is None:
            raise ImportError("DangVanStream: kernel='numba' needs Numba (python3-numba; "
                              "docs/install.md)")
        self.tau, self.radius = np.empty(self.n), np.empty(self.n)
        self.series = np.empty((self.m, self.n)) if self.keep_series else None
        self.most = 0
        self._lo = 0                # points fed so far
        self._kept = 0              # NumPy path: points of the open batch in the carry
        self._carry = None
        self._stuck: list[tuple[np.ndarray, np.ndarray]] = []    # (indices, their history)

    def feed(self, piece: np.ndarray) -> None:
        """The history (m, 6, k) of the next k points."""
        if piece.ndim != 3 or piece.shape[:2] != (self.m, 6):
            raise ValueError(f"DangVanStream.feed: a piece has shape ({self.m}, 6, k), got "
                             f"{piece.shape}")
        lo, hi = self._lo, self._lo + piece.shape[2]
        if hi > self.n:
            raise ValueError(f"DangVanStream.feed: {hi} points fed, {self.n} expected")
        if self._compiled is not None:
            self._feed_compiled(piece, lo, hi)
        else:
            self._feed_batches(piece, lo, hi)
        self._lo = hi

    def _feed_compiled(self, piece, lo, hi):
        k = hi - lo
        if not k:
            return
        iters = np.empty(k, dtype=np.int64)
        series = np.empty((self.m, k) if self.keep_series else (1, 1))
        self._compiled(piece, self.alpha, self.tol, self.max_iter, self.keep_series,
                       self.tau[lo:hi], self.radius[lo:hi], series, iters)
        if self.keep_series:
            self.series[:, lo:hi] = series
        stuck = np.flatnonzero(iters < 0)
        if stuck.size:
            self._stuck.append((lo + stuck, piece[:, :, stuck].copy()))
        self.most = max(self.most, int(iters.max(initial=0)))

    def _feed_batches(self, piece, lo, hi):
        batch, start = self.batch, lo
        if self._carry is None:
            self._carry = np.empty((self.m, 6, min(batch, self.n)))
        first = lo - self._kept                  # where the open batch starts
        while first < hi:
            end = min(first + batch, self.n)
            if end > hi:                          # finish it with the next piece
                self._carry[:, :, lo - first:hi - first] = piece[:, :, lo - start:]
                self._kept = hi - first
                return
            if first < start:
                self._carry[:, :, lo - first:end - first] = piece[:, :, :end - start]
                part = self._carry[:, :, :end - first]
            else:
                part = piece[:, :, first - start:end - start]
            self._store(first, end, dang_van(part, alpha=self.alpha, tol=self.tol, chunk=batch,
                                             keep_series=self.keep_series, kernel="numpy"))
            first = lo = end
            self._kept = 0

    def _store(self, lo, hi, dv: DangVan):
        self.tau[lo:hi], self.radius[lo:hi] = dv.tau_dv, dv.radius
        if self.keep_series:
            self.series[:, lo:hi] = dv.series
        self.most = max(self.most, dv.iterations)

    def result(self) -> DangVan:
        """τ_DV, radius, iterations (and the series) of every point, once all are fed."""
        if self._lo != self.n:
            raise ValueError(f"DangVanStream.result: {self._lo} of {self.n} points fed")
        if self._stuck:          # the reference path for the few the kernel left, as one call
            idx = np.concatenate([i for i, _ in self._stuck])
            ref = dang_van(np.concatenate([h for _, h in self._stuck], axis=2),
                           alpha=self.alpha, tol=self.tol, keep_series=self.keep_series,
                           kernel="numpy")
            self.tau[idx], self.radius[idx] = ref.tau_dv, ref.radius
            if self.keep_series:
                self.series[:, idx] = ref.series
            # the reference's iterations count for them (the kernel marked them negative)
            self.most = max(self.most, ref.iterations)
            self._stuck = []
        return DangVan(tau_dv=self.tau, radius=self.radius, iterations=self.most,
                       series=self.series)
