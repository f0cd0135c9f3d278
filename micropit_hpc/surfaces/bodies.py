"""The surface of each body of a scene on the simulation window (docs/model.md §3).

A body's ``[bodyN.surface] kind`` picks its maker from :data:`SURFACE_MAKERS` (synthetic fields
from ``window.seed``, or a measured map read, detrended, made periodic, resampled to the window
and checked against the body's R_q); a problem with the surface is a
:class:`~micropit_hpc.errors.SceneError` naming the body's table.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from micropit_hpc.errors import SceneError
from micropit_hpc.scene import Body, Scene
from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces.readers import read_topography
from micropit_hpc.surfaces.synthetic import gaussian_surface, self_affine_surface
from micropit_hpc.surfaces.topography import Topography, TopographyError

__all__ = ["SURFACE_MAKERS", "body_surface"]


def _surface_errors(maker):
    """A surface maker whose :class:`TopographyError` becomes a :class:`SceneError` naming the
    body's ``[bodyN.surface]`` table."""
    @functools.wraps(maker)
    def made(scene: Scene, body: int, grid: Grid, spawn: tuple[int, ...]) -> Topography:
        try:
            return maker(scene, body, grid, spawn)
        except TopographyError as e:
            raise SceneError(scene.source, f"body{body}.surface: {e}") from None
    return made


def _body(scene: Scene, body: int) -> Body:
    return scene.body1 if body == 1 else scene.body2


@_surface_errors
def _smooth_surface(scene: Scene, body: int, grid: Grid, spawn) -> Topography:
    return Topography(np.zeros(grid.shape), grid.dx, grid.dy, "smooth")


@_surface_errors
def _gaussian_surface(scene: Scene, body: int, grid: Grid, spawn) -> Topography:
    b = _body(scene, body)
    spec = b.surface
    return gaussian_surface(grid, b.Rq, spec.corr_x, spec.corr_y, scene.window.seed, spec.acf,
                            spawn)


@_surface_errors
def _self_affine_surface(scene: Scene, body: int, grid: Grid, spawn) -> Topography:
    b = _body(scene, body)
    spec = b.surface
    long_c = spec.long_cutoff if spec.long_cutoff is not None else max(grid.lx, grid.ly)
    short_c = spec.short_cutoff if spec.short_cutoff is not None else 4 * max(grid.dx, grid.dy)
    return self_affine_surface(grid, b.Rq, spec.hurst, long_c, short_c, scene.window.seed,
                               spawn)


@_surface_errors
def _read_map(scene: Scene, body: int, grid: Grid, spawn) -> tuple[Topography, Topography]:
    """The measured map as read and detrended (and periodised), and sampled on the window."""
    spec = _body(scene, body).surface
    topo = read_topography(spec.file, dataset=spec.dataset, spacing=spec.spacing,
                           height_unit=spec.height_unit, nan_policy=spec.nan_policy)
    mapped = topo.detrended(spec.detrend).periodised(spec.periodise, keep_rq=True)
    return mapped, mapped.resampled(grid)


def _measured_surface(scene: Scene, body: int, grid: Grid, spawn) -> Topography:
    """A measured map on the window, scaled to the body's R_q (``rescale``) or checked
    against it."""
    b = _body(scene, body)
    mapped, topo = _read_map(scene, body, grid, spawn)
    if b.surface.rescale:
        return topo.scaled_to_rq(b.Rq)
    if abs(topo.rq - b.Rq) > 0.05 * b.Rq:
        raise SceneError(scene.source, f"the measured map has R_q = {topo.rq * 1e6:.4g} µm on "
                                       f"the window ({mapped.rq * 1e6:.4g} µm as read and "
                                       f"detrended; the window is cut from it and sampled at "
                                       f"{grid.dx * 1e6:.3g} µm), more than 5 % from the "
                                       f"body's R_q; set body{body}.Rq_um to it or "
                                       f"body{body}.surface.rescale = true",
                         key=f"body{body}.Rq_um",
                         value=scene.document.get(f"body{body}", {}).get("Rq_um", b.Rq * 1e6))
    return topo


#: The maker of each surface kind (``[bodyN.surface] kind``, :data:`~micropit_hpc.scene.
#: SURFACE_KINDS`): (scene, body, grid, random-stream spawn key) → topography on the grid.
SURFACE_MAKERS: dict[str, Callable[[Scene, int, Grid, tuple[int, ...]], Topography]] = {
    "smooth": _smooth_surface,
    "gaussian": _gaussian_surface,
    "self_affine": _self_affine_surface,
    "file": _measured_surface,
}


def body_surface(scene: Scene, body: int, grid: Grid, patch: int = 0) -> Topography:
    """Topography of body 1 or 2 on the window grid (docs/model.md §3), from its [bodyN.surface]
    (:data:`SURFACE_MAKERS`; a body with R_q = 0 is smooth whatever its kind).

    ``patch`` numbers the independent synthetic patches of a study (``study.patches``): patch 0
    draws the random streams (seed, body), patch p > 0 the streams (seed, body, p).
    """
    b = _body(scene, body)
    kind = "smooth" if b.Rq == 0.0 else b.surface.kind
    return SURFACE_MAKERS[kind](scene, body, grid, (body,) if patch == 0 else (body, patch))
