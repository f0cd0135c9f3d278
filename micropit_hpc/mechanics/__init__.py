"""Subsurface stresses (docs/model.md §4.2): the micro field of the rough-contact tractions on a
periodic window (:mod:`.halfspace`, App. A.1) and the macro field of the smooth Hertz contact
(:mod:`.hertz_field`: line contact in closed form, App. A.2; elliptical contact by padded FFT).
All stress blocks are float64 arrays of shape (6, ...) in Voigt order (xx, yy, zz, yz, xz, xy),
tension positive, z positive into the body."""

from micropit_hpc.mechanics.halfspace import VOIGT, HalfSpaceStress, depth_layers
from micropit_hpc.mechanics.hertz_field import (
    EllipticalContactField,
    elliptical_contact_stress,
    line_contact_stress,
)

__all__ = ["VOIGT", "EllipticalContactField", "HalfSpaceStress", "depth_layers",
           "elliptical_contact_stress", "line_contact_stress"]
