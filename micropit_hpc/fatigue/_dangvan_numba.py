"""Compiled Dang Van kernel (Numba): :func:`micropit_hpc.fatigue.dangvan.dang_van` point by point.

Importing this module needs Numba (Debian's ``python3-numba``); :mod:`.dangvan` imports it
lazily and falls back to its NumPy path where it is missing. The kernel is a line-by-line port
of the NumPy reference for one material point at a time (:func:`.dangvan.enclosing_ball`,
Frank–Wolfe with away steps and the active-set correction :func:`.dangvan._support_correction`,
then :func:`.dangvan.mesoscopic_shear`): the same initial pair, steps, line searches, supports,
acceptance thresholds and stopping test, with the arithmetic written in the same order. The
results therefore agree with the reference to round-off, including on the rare point that stops
on the tolerance R(c)² − ρ ≤ tol·R(c)² before its support is exact (a different algorithm could
stop elsewhere inside the √tol·R ball of admissible centres). Two small dense routines replace
LAPACK: the (s−1)² solve of the face's centre (LU with partial pivoting, as ``gesv``; an exactly
zero pivot sends the point to the Carathéodory step, as the reference's ``LinAlgError`` does)
and the null vector of the (d+1) × s matrix [p − c; 1] (one-sided Jacobi SVD instead of
``gesdd``; where that null space has more than one dimension the two may drop different points,
and both still converge to the unique ball).

``parallel=False``: the simulator already puts one MPI rank on every core, and each rank calls
this on its own slab; threads inside a rank would oversubscribe the cores (and the per-point work
is small and uneven). ``cache=True``: the machine code is kept in ``__pycache__`` (or
``NUMBA_CACHE_DIR``), so only the first run on a machine pays the compilation (docs/performance.md,
"Compiled Dang Van").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from micropit_hpc.fatigue.dangvan import LODE_EDGE, ROUNDOFF_GAP

_R2, _R6 = math.sqrt(2.0), math.sqrt(6.0)
_D = 5                  # dimension of the deviator space
_K = _D + 2             # largest support the correction looks at


@njit(cache=True)
def _sq_dist_col(p, k, c):
    """|p[:, k] − c|², summed over the components in order."""
    diff = p[0, k] - c[0]
    r = diff * diff
    for i in range(1, p.shape[0]):
        diff = p[i, k] - c[i]
        r += diff * diff
    return r


@njit(cache=True)
def _lu_solve(M, b, n):
    """Solves M[:n, :n] x = b[:n] in place (x in b); partial pivoting, first largest pivot.
    Returns False on an exactly zero pivot (singular)."""
    for k in range(n):
        piv = k
        big = abs(M[k, k])
        for i in range(k + 1, n):
            if abs(M[i, k]) > big:
                big = abs(M[i, k])
                piv = i
        if M[piv, k] == 0.0:
            return False
        if piv != k:
            for j in range(n):
                M[k, j], M[piv, j] = M[piv, j], M[k, j]
            b[k], b[piv] = b[piv], b[k]
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            M[i, k] = f
            for j in range(k + 1, n):
                M[i, j] -= f * M[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for j in range(k + 1, n):
            acc -= M[k, j] * b[j]
        b[k] = acc / M[k, k]
    return True


@njit(cache=True)
def _null_vector(A, rows, s, V, mu):
    """mu = the right singular vector of A[:rows, :s] of least singular value (one-sided
    Jacobi; A is overwritten by A V)."""
    for i in range(s):
        for j in range(s):
            V[i, j] = 0.0
        V[i, i] = 1.0
    eps = 2.220446049250313e-16
    for _sweep in range(100):
        rotated = False
        for i in range(s - 1):
            for j in range(i + 1, s):
                a = 0.0
                b = 0.0
                g = 0.0
                for r in range(rows):
                    a += A[r, i] * A[r, i]
                    b += A[r, j] * A[r, j]
                    g += A[r, i] * A[r, j]
                if g == 0.0 or abs(g) <= eps * math.sqrt(a * b):
                    continue
                rotated = True
                zeta = (b - a) / (2.0 * g)
                if abs(zeta) > 1e150:
                    t = 0.5 / zeta
                else:
                    t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                    if zeta < 0.0:
                        t = -t
                cs = 1.0 / math.sqrt(1.0 + t * t)
                sn = cs * t
                for r in range(rows):
                    x, y = A[r, i], A[r, j]
                    A[r, i] = cs * x - sn * y
                    A[r, j] = sn * x + cs * y
                for r in range(s):
                    x, y = V[r, i], V[r, j]
                    V[r, i] = cs * x - sn * y
                    V[r, j] = sn * x + cs * y
        if not rotated:
            break
    best = 0
    best_norm = np.inf
    for j in range(s):
        nrm = 0.0
        for r in range(rows):
            nrm += A[r, j] * A[r, j]
        if nrm < best_norm:
            best_norm = nrm
            best = j
    for i in range(s):
        mu[i] = V[i, best]


@njit(cache=True)
def _support_correction(p, c, lam, pos, w_order, pts, w, new_w, D, M, rhs, cc, ratio, A, V, mu):
    """One active-set step on the support of one set (dangvan._support_correction, one column).
    Updates c and lam in place; returns True where a point left the support."""
    d, m = p.shape
    k = min(d + 2, m)
    count = 0
    for t in range(m):
        if lam[t] > 0.0:
            pos[count] = t
            count += 1
    if count < 2:
        return False
    s = min(count, k)               # the reference's rule: count == s, or count >= d + 2
    # the s largest weights, ties by index (a stable argsort of −λ); only positive weights
    # can be among them (s ≤ count), so the candidates are those, in index order
    for i in range(s):
        best = -1
        for u in range(count):
            t = pos[u]
            if t < 0:
                continue
            if best < 0 or lam[t] > lam[pos[best]]:
                best = u
        w_order[i] = pos[best]
        pos[best] = -1
    for i in range(s):
        o = w_order[i]
        w[i] = lam[o]
        for a in range(d):
            pts[a, i] = p[a, o]
    blocked = False
    dependent = True
    if s <= d + 1:
        n = s - 1
        for i in range(n):
            for a in range(d):
                D[a, i] = pts[a, i + 1] - pts[a, 0]
        for i in range(n):
            for j in range(n):
                acc = D[0, i] * D[0, j]
                for a in range(1, d):
                    acc += D[a, i] * D[a, j]
                M[i, j] = acc
            rhs[i] = 0.5 * M[i, i]
        if not _lu_solve(M, rhs, n):
            for i in range(n):
                rhs[i] = np.nan
        total = 0.0
        for i in range(n):
            total += rhs[i]
        new_w[0] = 1.0 - total
        for i in range(n):
            new_w[i + 1] = rhs[i]
        for a in range(d):
            acc = 0.0
            for i in range(n):
                acc += D[a, i] * rhs[i]
            cc[a] = pts[a, 0] + acc
        r0 = _sq_dist_col(pts, 0, cc)
        ok = True
        big = 0.0
        for i in range(s):
            ri = _sq_dist_col(pts, i, cc)
            if not abs(ri - r0) <= 1e-9 * r0:
                ok = False
            if not np.isfinite(new_w[i]):
                ok = False
            big = max(big, abs(new_w[i]))
        if not big < 1e8:
            ok = False
        first = 0
        for i in range(s):
            if new_w[i] < w[i]:
                ratio[i] = w[i] / (w[i] - new_w[i])
            else:
                ratio[i] = np.inf
            if ratio[i] < ratio[first]:
                first = i
        t = min(ratio[first], 1.0)
        if not t > 0.0:
            ok = False
        if ok:
            for i in range(s):
                w[i] = max(w[i] + t * (new_w[i] - w[i]), 0.0)
            if t < 1.0:
                w[first] = 0.0
                blocked = True
        dependent = not ok
    if dependent:
        scale = 0.0
        for i in range(s):
            ratio[i] = _sq_dist_col(pts, i, c)      # |p_i − c|², kept for the sign below
            scale = max(scale, ratio[i])
        scale = math.sqrt(scale)
        if not scale > 0.0:
            scale = 1.0
        for i in range(s):
            for a in range(d):
                A[a, i] = (pts[a, i] - c[a]) / scale
            A[d, i] = 1.0
        _null_vector(A, d + 1, s, V, mu)
        acc = 0.0
        for i in range(s):
            acc += mu[i] * ratio[i]
        if acc < 0.0:
            for i in range(s):
                mu[i] = -mu[i]
        first = 0
        for i in range(s):
            ratio[i] = w[i] / -mu[i] if mu[i] < 0.0 else np.inf
            if ratio[i] < ratio[first]:
                first = i
        step = ratio[first]
        for i in range(s):
            w[i] = max(w[i] + step * mu[i], 0.0)
        w[first] = 0.0
        blocked = True
    for i in range(s):
        lam[w_order[i]] = w[i]
    total = 0.0
    for t in range(m):
        total += lam[t]
    for t in range(m):
        lam[t] /= total
    for a in range(d):
        acc = 0.0
        for t in range(m):
            acc += p[a, t] * lam[t]
        c[a] = acc
    return blocked


@njit(cache=True)
def _mesoscopic_shear(v0, v1, v2, v3, v4):
    """dangvan.mesoscopic_shear of one 5-vector."""
    a, b = v0 / _R2, v1 / _R6
    sxx, syy, szz = a + b, b - a, -2.0 * b
    syz, sxz, sxy = v2 / _R2, v3 / _R2, v4 / _R2
    j2 = 0.5 * (v0 * v0 + v1 * v1 + v2 * v2 + v3 * v3 + v4 * v4)
    j3 = (sxx * syy * szz + 2.0 * sxy * syz * sxz - sxx * syz * syz - syy * sxz * sxz
          - szz * sxy * sxy)
    if j2 > 0.0:
        cos3 = 1.5 * math.sqrt(3.0) * j3 / (j2 * math.sqrt(j2))
    else:
        cos3 = 0.0
    if abs(cos3) > 1.0 - LODE_EDGE:      # two principal values nearly equal: eigenvalues
        return _tresca_jacobi(sxx, syy, szz, syz, sxz, sxy)
    cos3 = min(max(cos3, -1.0), 1.0)
    theta = math.acos(cos3) / 3.0
    return math.sqrt(j2) * math.sin(theta + math.pi / 3.0)


@njit(cache=True)
def _tresca_jacobi(sxx, syy, szz, syz, sxz, sxy):
    """(s_I − s_III)/2 of a symmetric 3 × 3 tensor by cyclic Jacobi rotations (eigenvalues to
    about ε|s|, where the Lode-angle formula loses half the digits)."""
    a = np.empty((3, 3))
    a[0, 0], a[1, 1], a[2, 2] = sxx, syy, szz
    a[1, 2] = a[2, 1] = syz
    a[0, 2] = a[2, 0] = sxz
    a[0, 1] = a[1, 0] = sxy
    for _sweep in range(50):
        off = a[0, 1] * a[0, 1] + a[0, 2] * a[0, 2] + a[1, 2] * a[1, 2]
        diag = a[0, 0] * a[0, 0] + a[1, 1] * a[1, 1] + a[2, 2] * a[2, 2]
        if off <= 1e-36 * diag:
            break
        for pq in range(3):
            p = 0 if pq < 2 else 1
            q = 1 if pq == 0 else 2
            if a[p, q] == 0.0:
                continue
            th = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
            t = 1.0 / (abs(th) + math.sqrt(th * th + 1.0))
            if th < 0.0:
                t = -t
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):
                akp, akq = a[k, p], a[k, q]
                a[k, p] = c * akp - s * akq
                a[k, q] = s * akp + c * akq
            for k in range(3):
                apk, aqk = a[p, k], a[q, k]
                a[p, k] = c * apk - s * aqk
                a[q, k] = s * apk + c * aqk
    hi = max(a[0, 0], a[1, 1], a[2, 2])
    lo = min(a[0, 0], a[1, 1], a[2, 2])
    return 0.5 * (hi - lo)


@njit(cache=True)
def dang_van_points(flat, alpha, tol, max_iter, keep_series, tau, rad, series, iters):
    """τ_DV of every point of ``flat`` (m, 6, n), as dangvan.dang_van with
    enclosing_ball(tol, max_iter, correct_every=1). Writes tau (n,), rad (n,), iters (n,) and,
    with keep_series, series (m, n); a point not converged after max_iter gets iters = −1."""
    m, _, n = flat.shape
    d = _D
    p = np.empty((d, m))
    ref = np.empty(d)
    c = np.empty(d)
    lam = np.empty(m)
    pos = np.empty(m, np.int64)
    r = np.empty(m)
    w_order = np.empty(_K, np.int64)
    pts = np.empty((d, _K))
    w = np.empty(_K)
    new_w = np.empty(_K)
    D = np.empty((d, _K))
    M = np.empty((_K, _K))
    rhs = np.empty(_K)
    cc = np.empty(d)
    ratio = np.empty(_K)
    A = np.empty((d + 1, _K))
    V = np.empty((_K, _K))
    mu = np.empty(_K)
    # points gathered at a time: each of the 6 m rows of the history is read 256 points
    # (2 KiB) at a stretch; 0.86× the time per point of 32 (docs/performance.md §8)
    block = 256
    vb = np.empty((block, d, m))
    trace = np.empty((block, m))
    yb = np.empty((block, m))
    for j0 in range(0, n, block):
        nb = min(block, n - j0)
        for t in range(m):
            for q in range(nb):
                sxx = flat[t, 0, j0 + q]
                syy = flat[t, 1, j0 + q]
                szz = flat[t, 2, j0 + q]
                vb[q, 0, t] = (sxx - syy) / _R2
                vb[q, 1, t] = (sxx + syy - 2.0 * szz) / _R6
                trace[q, t] = sxx + syy + szz
            for q in range(nb):
                vb[q, 2, t] = _R2 * flat[t, 3, j0 + q]
            for q in range(nb):
                vb[q, 3, t] = _R2 * flat[t, 4, j0 + q]
            for q in range(nb):
                vb[q, 4, t] = _R2 * flat[t, 5, j0 + q]
        for q in range(nb):
            it_done, R2 = _ball(vb[q], p, ref, c, lam, pos, r, tol, max_iter, w_order, pts, w,
                                new_w, D, M, rhs, cc, ratio, A, V, mu)
            j = j0 + q
            iters[j] = it_done
            rad[j] = math.sqrt(R2)
            if keep_series:
                hmax = -np.inf
                for t in range(m):
                    yt = _y(vb, q, t, c, trace, alpha)
                    yb[q, t] = yt
                    if hmax == hmax and not yt <= hmax:      # as np.max: a NaN stays
                        hmax = yt
            else:
                hmax = _max_y(vb, q, c, trace, alpha, yb[q])
            tau[j] = hmax
        if keep_series:
            for t in range(m):
                for q in range(nb):
                    series[t, j0 + q] = yb[q, t]


@njit(cache=True)
def _y(vb, q, t, c, trace, alpha):
    """τ̂(t) + α σ_H(t) of point q of the block (dangvan.dang_van's y)."""
    sh = _mesoscopic_shear(vb[q, 0, t] - c[0], vb[q, 1, t] - c[1], vb[q, 2, t] - c[2],
                           vb[q, 3, t] - c[3], vb[q, 4, t] - c[4])
    return sh + alpha * trace[q, t] / 3.0


@njit(cache=True)
def _max_y(vb, q, c, trace, alpha, ub):
    """max_t y(t), evaluating y only where it can be the largest: τ̂ ≤ √J2 (the Tresca shear of
    a deviator is at most √J2), so ub(t) = √J2·(1 + 1e-12) + α σ_H ≥ y(t), and the steps are
    taken in falling ub until the next ub is below the largest y found. The same value as
    the max over all steps; ``ub`` is work space (m,)."""
    m = ub.shape[0]
    for t in range(m):
        j2 = 0.0
        for a in range(5):
            diff = vb[q, a, t] - c[a]
            j2 += diff * diff
        ub[t] = math.sqrt(0.5 * j2) * (1.0 + 1e-12) + alpha * trace[q, t] / 3.0
        if not ub[t] == ub[t]:          # NaN: every step, as np.max would see them
            best = -np.inf
            for u in range(m):
                yt = _y(vb, q, u, c, trace, alpha)
                if best == best and not yt <= best:
                    best = yt
            return best
    best = -np.inf
    for _ in range(m):
        k = 0
        for t in range(1, m):
            if ub[t] > ub[k]:
                k = t
        if ub[k] < best or ub[k] == -np.inf:
            break
        ub[k] = -np.inf
        yt = _y(vb, q, k, c, trace, alpha)
        if not yt <= best:
            best = yt
    return best


@njit(cache=True)
def _ball(v, p, ref, c, lam, pos, r, tol, max_iter, w_order, pts, w, new_w, D, M, rhs, cc, ratio,
          A, V, mu):
    """enclosing_ball of one set v (d, m): leaves the centre in c, returns (iterations, R²);
    iterations = −1 where max_iter did not suffice. p, ref, lam, r and the rest: work space."""
    d, m = v.shape
    for a in range(d):
        acc = 0.0
        for t in range(m):
            acc += v[a, t]
        ref[a] = acc / m
        for t in range(m):
            p[a, t] = v[a, t] - ref[a]
    # initial pair (Yildirim): beta farthest from p_0, gamma farthest from beta
    for a in range(d):
        c[a] = p[a, 0]
    beta = 0
    best = _sq_dist_col(p, 0, c)
    for t in range(1, m):
        rt = _sq_dist_col(p, t, c)
        if rt > best:
            best, beta = rt, t
    for a in range(d):
        c[a] = p[a, beta]
    gamma = 0
    best = _sq_dist_col(p, 0, c)
    for t in range(1, m):
        rt = _sq_dist_col(p, t, c)
        if rt > best:
            best, gamma = rt, t
    for t in range(m):
        lam[t] = 0.0
    lam[beta] += 0.5
    lam[gamma] += 0.5
    for a in range(d):
        c[a] = 0.5 * (p[a, beta] + p[a, gamma])
    R2 = 0.0
    it_done = -1
    for it in range(max_iter + 1):
        far = 0
        for t in range(m):
            r[t] = _sq_dist_col(p, t, c)
            if r[t] > r[far]:
                far = t
        R2 = r[far]
        rho = 0.0
        for t in range(m):
            rho += lam[t] * r[t]
        if R2 - rho <= tol * R2:
            it_done = it
            break
        if it == max_iter:      # accepted where the gap stalls at round-off, as the NumPy path
            if R2 - rho <= ROUNDOFF_GAP * R2:
                it_done = it
            break
        # away vertex: the nearest point among those with positive weight
        away = -1
        for t in range(m):
            if lam[t] > 0.0 and (away < 0 or r[t] < r[away]):
                away = t
        if away < 0:
            away = 0
        r_a = r[away] if lam[away] > 0.0 else np.inf
        lam_a = lam[away]
        gain_fw, gain_away = R2 - rho, rho - r_a
        fw = gain_fw >= gain_away
        if fw:
            g = gain_fw / (2.0 * R2)
            scale = 1.0 - g
            for t in range(m):
                lam[t] *= scale
            lam[far] += g
            for a in range(d):
                c[a] = scale * c[a] + g * p[a, far]
        else:
            g_max = lam_a / (1.0 - lam_a) if lam_a < 1.0 else 0.0
            g_aw = gain_away / (2.0 * r_a) if r_a > 0.0 else np.inf
            g = min(g_aw, g_max)
            scale = 1.0 + g
            for t in range(m):
                lam[t] *= scale
            lam[away] += -g
            if g == g_max:
                lam[away] = 0.0
            for a in range(d):
                c[a] = scale * c[a] + -g * p[a, away]
        for _minor in range(d + 2):      # minor cycles (Wolfe 1976) while a point leaves
            if not _support_correction(p, c, lam, pos, w_order, pts, w, new_w, D, M, rhs, cc,
                                       ratio, A, V, mu):
                break
    for a in range(d):
        c[a] = c[a] + ref[a]
    return it_done, R2
