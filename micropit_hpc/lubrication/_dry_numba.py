"""Compiled stages of the Polonsky–Keer iteration (Numba): :mod:`.dry`'s ``NumpyStages``, fused.

Each function is one pass over this rank's points that does what one stage of
:func:`micropit_hpc.lubrication.dry._polonsky_keer` does with several NumPy calls, and returns
the local sums the stage needs (the solver reduces them over the group). The arithmetic per
point is the reference's (a multiply-add may be fused, ``contract``); the sums are added in
another order (vector lanes, ``reassoc``, where NumPy adds pairwise), so the two agree to
round-off and both converge to the same tolerance (tests/test_kernels.py). ``parallel=False``:
every core already runs an MPI rank. ``cache=True``: compiled once per machine
(``__pycache__`` or ``NUMBA_CACHE_DIR``).

Arrays are this rank's (rows, ny) float64 fields, C-contiguous, passed flattened.
"""

from __future__ import annotations

from numba import njit

#: LLVM may reassociate the sums (vector lanes) and fuse multiply-adds; no assumption about NaN
#: or infinity is allowed, so a NaN still fails every comparison as in the reference.
FAST = {"reassoc", "contract", "nsz"}


@njit(cache=True, fastmath=FAST)
def gap(g0, u, c, p, g):
    """g = g0 + c u; returns (Σ g, count) over the contact points p > 0."""
    s = 0.0
    n = 0
    for i in range(g.size):
        v = g0[i] + c * u[i]
        g[i] = v
        m = p[i] > 0.0
        s += v if m else 0.0
        n += m
    return s, n


@njit(cache=True, fastmath=FAST)
def centre(g, p, mean):
    """g −= mean everywhere; returns Σ g² over the contact points (the squared residual G)."""
    s = 0.0
    for i in range(g.size):
        v = g[i] - mean
        g[i] = v
        s += v * v if p[i] > 0.0 else 0.0
    return s


@njit(cache=True, fastmath=FAST)
def direction(g, p, t, beta, out, shift):
    """t = (g − shift + β t) on the contact points, 0 elsewhere (β = 0: steepest descent),
    written to ``t`` and to ``out`` (the transform's input buffer)."""
    for i in range(t.size):
        v = g[i] - shift + beta * t[i] if p[i] > 0.0 else 0.0
        t[i] = v
        out[i] = v


@njit(cache=True, fastmath=FAST)
def masked(g, p, out):
    """out = g on the contact points, 0 elsewhere (the preconditioner's input)."""
    for i in range(g.size):
        out[i] = g[i] if p[i] > 0.0 else 0.0


@njit(cache=True, fastmath=FAST)
def preconditioned_sums(z, g, p):
    """(Σ z, Σ g z) over the contact points: the preconditioned residual's mean and its
    product with the residual."""
    sz = 0.0
    gz = 0.0
    for i in range(z.size):
        if p[i] > 0.0:
            sz += z[i]
            gz += g[i] * z[i]
    return sz, gz


@njit(cache=True, fastmath=FAST)
def project(r, t, g, p):
    """(Σ r over the contact, Σ r t, Σ t, Σ g t) (t is 0 off the contact)."""
    rc = 0.0
    rt = 0.0
    st = 0.0
    gt = 0.0
    for i in range(t.size):
        ri = r[i]
        ti = t[i]
        rc += ri if p[i] > 0.0 else 0.0
        rt += ri * ti
        st += ti
        gt += g[i] * ti
    return rc, rt, st, gt


@njit(cache=True, fastmath=FAST)
def update(p, t, g, c, tau, allowed, restricted, out):
    """p = max(c p − τ t, 0); a point at 0 whose gap overlaps (g < 0), and that is allowed when
    ``restricted``, enters with p = −τ g. Written to ``p`` and ``out`` (the transform's input
    buffer); returns (points entered, Σ p)."""
    n = 0
    s = 0.0
    for i in range(p.size):
        q = c * p[i] - tau * t[i]
        q = 0.0 if q < 0.0 else q
        e = q == 0.0 and g[i] < 0.0 and (allowed[i] or not restricted)
        q = q - tau * g[i] if e else q
        n += e
        p[i] = q
        out[i] = q
        s += q
    return n, s
