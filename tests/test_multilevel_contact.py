"""The coarse-to-fine start in the mixed model's dry solves (issue 31): the same solutions as
the single-level solves, with the start taken."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import E_PRIME, SOLVER, mixed_model, random_pair

from micropit_hpc.lubrication import dry, mixed, rheology
from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.spectral import rfft_plan


def _solve(h_mean, monkeypatch, coarsest):
    """The mixed solution on a 128² pair with the dry solves' coarse start down to
    ``coarsest`` points (0: none), and the coarse iterations of its dry solves."""
    g, (z1, z2) = random_pair(128)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    coarse = []

    def counted(*args, **kwargs):
        sol = solve_dry_contact(*args, **kwargs)
        coarse.append(sol.coarse_iterations)
        return sol

    monkeypatch.setattr(dry, "COARSEST", coarsest)
    monkeypatch.setattr(mixed, "solve_dry_contact", counted)
    return g, (z1, z2), mixed_model(g, h_mean=h_mean).solve(r, r, 1.0e9, 5e-5), sum(coarse)


def test_vanishing_film_with_the_coarse_start_gives_the_dry_solution(monkeypatch):
    """h̄ → 0 on 128² (φ = 1): the mixed model's dry solves start coarse to fine and end on the
    single-level dry solution of the same roughness (the bound of test_mixed's limit)."""
    g, (z1, z2), sol, coarse = _solve(1e-12, monkeypatch, 64)
    ref = solve_dry_contact(-(z1 + z2), ElasticHalfSpaces(g, E_PRIME), 1.0e9, p_lim=4.2e9,
                            coarsest=0, **SOLVER)
    assert sol.phi == 1.0 and coarse > 0
    assert np.abs(sol.pressure - ref.pressure).max() < 1e-6 * ref.pressure.max()
    assert np.abs(sol.clearance - ref.gap).max() < 1e-6 * z1.std()


def test_intermediate_film_with_the_coarse_start_balances_the_flow_as_before(monkeypatch):
    """An intermediate film on 128²: with and without the coarse start the flow balance
    holds to the film tolerance's bound of test_mixed, and the two solutions agree."""
    h = 0.35e-6
    _, _, multi, coarse = _solve(h, monkeypatch, 64)
    _, _, single, none = _solve(h, monkeypatch, 0)
    assert coarse > 0 and none == 0
    for sol in (multi, single):
        assert 0.0 < sol.phi < 1.0
        c_rho = rheology.density_correction(sol.phi * 1.0e9)
        assert sol.film_mean == pytest.approx(c_rho * h, rel=2e-4)
        assert sol.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    # the same trial loads (the film values differ by the dry solves' tolerance only), so the
    # same root, and pressures within the bound of the dry solves of test_mixed
    assert multi.phi == pytest.approx(single.phi, rel=1e-6)
    assert np.abs(multi.pressure - single.pressure).max() < 1e-6 * single.pressure.max()
