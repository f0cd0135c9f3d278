"""Rough surfaces (docs/model.md §3): the Topography container, synthetic fields, file readers."""

from micropit_hpc.surfaces.readers import HEIGHT_UNITS, NAN_POLICIES, read_topography
from micropit_hpc.surfaces.synthetic import (
    ACF_KINDS,
    gaussian_surface,
    self_affine_surface,
    white_noise,
)
from micropit_hpc.surfaces.topography import (
    DETREND_KINDS,
    PERIODISE_METHODS,
    Topography,
    TopographyError,
)

__all__ = ["ACF_KINDS", "DETREND_KINDS", "HEIGHT_UNITS", "NAN_POLICIES", "PERIODISE_METHODS",
           "Topography", "TopographyError", "gaussian_surface", "read_topography",
           "self_affine_surface", "white_noise"]
