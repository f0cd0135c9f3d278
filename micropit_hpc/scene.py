"""Scene files: TOML in engineering units -> typed, validated dataclasses in SI units.

A scene describes one study: a spur gear pair (``[gear]`` + ``[positions]``) or a disc rig
(``[disc]``), the two bodies, the lubricant and the film model.

The dataclasses are the schema. Every key is declared once, as a field of the frozen dataclass
that holds its SI value (:class:`WindowSpec`, :class:`LifeSpec`, …), or of a small table class
(:class:`GearTable`, :class:`DiscTable`, …) where the file's table is not the object the rest of
the code uses: :func:`~micropit_hpc.schema.setting` gives the key's name in the file, type, unit,
SI factor, default in file units, allowed range and meaning, and makes the field's dataclass
default that default in SI. :data:`SECTIONS` is derived from the classes
(:func:`~micropit_hpc.schema.section_of`); the reading, ``micropit scene --help-keys`` and
docs/scenes.md come from it. Objects computed from a table (:class:`GearSpec` with its
:class:`GearGeometry`, :class:`PositionSpec`, :class:`DiscSpec`) declare no keys, nor do the
fields that are not keys (``Lubricant.derived``, ``Body.surface``, ``Scene.source``, …). Bad
input raises :class:`SceneError` naming the file, the key, the value and what is allowed.
"""

# setting(...) returns the dataclasses.field of a key (a default and metadata), not a shared value

from __future__ import annotations

import math
import re
import stat
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from micropit_hpc.errors import SceneError, format_value
from micropit_hpc.fatigue.sn import LOW_CYCLE
from micropit_hpc.film import FILM_MODELS, THERMAL_MODELS
from micropit_hpc.gear import (
    LOAD_SHARING,
    GearGeometry,
    GearMesh,
    MeshingError,
    zero_backlash_centre_distance,
)
from micropit_hpc.lubrication import LEVELS
from micropit_hpc.schema import (
    Section,
    check_unknown,
    keys_reference,
    read_section,
    section_of,
    setting,
)
from micropit_hpc.wear import RATE_INTEGRATIONS

DEG = math.pi / 180.0
MM = 1e-3
UM = 1e-6
GPA = 1e9
RPM = 2.0 * math.pi / 60.0

# --------------------------------------------------------------------------------------------
# the settings: each scene key is declared once, as a field of the dataclass that holds it
# --------------------------------------------------------------------------------------------
TOP_LEVEL = ("study", "gear", "disc", "body1", "body2", "lubricant", "film", "hertz", "positions",
             "window", "lubrication", "stress", "fatigue", "wear", "life")

SURFACE_KINDS = ("gaussian", "self_affine", "file", "smooth")
LUBRICATION_MODELS = ("auto", *LEVELS)
COUNTING = ("sliding", "rainflow")
#: Time integration of the life (micropit_hpc.life): the adaptive split or the paper's blocks.
INTEGRATIONS = ("adaptive", "paper")

#: The process length of the Dang Van criterion [m] when the scene does not give
#: ``fatigue.process_length_um``, by ``life.integration`` [choice, beyond the paper]: 5 µm, a
#: hardened steel's critical distance averaged over 2–3 of it, in the converged default (with it
#: the wear–fatigue competition converges with the grid; docs/life.md, "A process length for the
#: criterion"); 0, the paper's pointwise criterion, in its literal numerics.
PROCESS_LENGTH_DEFAULT = {"adaptive": 5.0 * UM, "paper": 0.0}


#: How the wear of a sub-block is integrated: implicit (micropit_hpc.implicit_wear), or one of
#: the integrations of a single rate (micropit_hpc.wear).
WEAR_INTEGRATIONS = ("implicit", *RATE_INTEGRATIONS)


@dataclass(frozen=True)
class StudyTable:
    """The ``[study]`` table (its name, description and dimensions go to :class:`Scene`)."""

    name: str | None = setting(
        "name", "str", "Name of the study, shown in reports and results. Default: the "
        "file name without .toml.", default=None)
    description: str = setting(
        "description", "str", "Free text: where the numbers come from.",
        default="")
    roughness_scale: tuple[float, ...] = setting(
        "roughness_scale", "floats", "Factors on both bodies' roughness "
        "(R_q and heights), one set of work items each; Λ scales as 1/factor (the paper's "
        "Table 9).", default=[1.0], lo=0, hi=100, lo_open=True)
    patches: int = setting(
        "patches", "int", "Independent synthetic roughness patches (seeds) per "
        "position; patch p > 1 draws its own streams from `window.seed`.", default=1, lo=1,
        hi=100000)


@dataclass(frozen=True)
class GearTable:
    """The ``[gear]`` table; :func:`_read_gear` builds the :class:`GearSpec` from it."""

    module: float = setting(
        "module_mm", "float", "Normal module m.", "mm", MM, lo=0.01, hi=1000)
    pressure_angle: float = setting(
        "pressure_angle_deg", "float", "Reference pressure angle α.", "deg",
        DEG, lo=0, hi=45, lo_open=True, hi_open=True)
    centre_distance: float | None = setting(
        "centre_distance_mm", "float",
        "Operating centre distance a. Default: the zero-backlash centre distance of the profile "
        "shifts (ISO 21771).", "mm", MM, default=None, lo=0, hi=1e5, lo_open=True)
    facewidth: float = setting(
        "facewidth_mm", "float", "Common facewidth b_w carrying the load.", "mm",
        MM, lo=0.001, hi=1e5)
    torque: float = setting(
        "torque_Nm", "float", "Torque on gear 1 (the driver); the normal load per "
        "unit facewidth is w = X T1 / (r_b1 b_w).", "N·m", 1.0, lo=0, hi=1e9, lo_open=True)
    speed: float = setting(
        "speed_rpm", "float", "Rotational speed of gear 1.", "rpm", RPM, lo=0,
        hi=1e6, lo_open=True)
    load_sharing: str = setting(
        "load_sharing", "str", "Load-sharing model X along the path: `linear` "
        "(tip relief for smooth meshing: 0→1 over A–B, 1 over B–D, 1→0 over D–E), "
        "`iso_unmodified` (ISO/TS 6336-22 Method B ramps (Q−2)/15 + t/3 for unmodified "
        "profiles), `none` (X = 1).", default="linear", choices=LOAD_SHARING)
    accuracy_grade: int = setting(
        "accuracy_grade", "int", "ISO 1328 accuracy grade Q, used only by "
        "`load_sharing = \"iso_unmodified\"`; grades finer than 7 are taken as 7 (below it the "
        "ISO ramps would lose load).", default=7, lo=0, hi=12)
    slide_roll_imposed: float | None = setting(
        "slide_roll_imposed", "float", "|S| imposed at every position, "
        "with the sign of the mesh's own S (0 at the pitch point; see `pitch_snap_deg` for a "
        "pitch point given by a rounded roll angle); ū, the load and the film are kept, "
        "u1 = ū(1 + S/2), u2 = ū(1 − S/2). The paper's "
        "Table 5 (S = ±0.044) separates the effect of the pressure from that of the "
        "sliding. Default: the kinematic S of the mesh.", default=None, lo=0, hi=2, hi_open=True)
    pitch_snap: float = setting(
        "pitch_snap_deg", "float", "Positions whose roll angle of gear 1 lies "
        "within this of the pitch point C are evaluated at C exactly (S = 0). The paper's "
        "Table 3 prints roll angles to 0.01° and calls its position 6 (27.77°) the pitch "
        "point, where the exact C is 27.774°: S = −0.0003 there, and since the asperity "
        "stresses exceed the S–N line's one-cycle strength that alone pits part of the "
        "flank (docs/validation/findings.md). Default 0: positions as given.", "deg", DEG,
        default=0.0, lo=0, hi=1)
    material_factor_ww: float = setting(
        "material_factor_WW", "float", "Material factor W_W of "
        "ISO/TS 6336-22 Method B in λ_GFP = 1.4 W_W λ_GFT (1.0 for case-carburised steel, the "
        "test gears' material; other values from the standard's table for the flanks' "
        "material and heat treatment).", default=1.0, lo=0, hi=5, lo_open=True)


@dataclass(frozen=True)
class GearWheelTable:
    """The ``[gear.pinion]`` and ``[gear.wheel]`` tables (into :class:`GearGeometry`)."""

    teeth: int = setting(
        "teeth", "int", "Number of teeth z.", lo=5, hi=100000)
    profile_shift: float = setting(
        "profile_shift", "float", "Profile shift coefficient x.",
        default=0.0, lo=-1.5, hi=1.5)
    tip_diameter: float | None = setting(
        "tip_diameter_mm", "float", "Tip diameter d_a. Default: the "
        "standard d + 2m(1 + x).", "mm", MM, default=None, lo=0, hi=1e6, lo_open=True)
    root_diameter: float | None = setting(
        "root_diameter_mm", "float", "Root diameter d_f, used only to "
        "check tip-root clearance. Default: d − 2m(1.25 − x).", "mm", MM, default=None, lo=0,
        hi=1e6, lo_open=True)


@dataclass(frozen=True)
class PositionsTable:
    """The ``[positions]`` table (exactly one key given); gives the :class:`PositionSpec`."""

    roll_angle: tuple[float, ...] | None = setting(
        "roll_angle_deg", "floats", "Roll angles of gear 1, φ1 = ρ1/r_b1.", "deg",
        DEG, default=None)
    radial_position: tuple[float, ...] | None = setting(
        "radial_pos_mm", "floats", "Tooth-centre radial positions on gear 1, "
        "y = r cos ψ(r) (how the paper locates points).", "mm", MM, default=None)
    modules_below_tip: tuple[float, ...] | None = setting(
        "modules_below_tip", "floats", "Tooth-centre radial positions as "
        "k modules below the tip radius, y = r_a1 − k m (the paper's Table 7).", "modules", 1.0,
        default=None, lo=0)
    count: int | None = setting(
        "n", "int", "n points at the centres of n equal intervals from A to E.",
        default=None, lo=1, hi=100000)


@dataclass(frozen=True)
class DiscTable:
    """The ``[disc]`` table; :func:`_read_disc` builds the :class:`DiscSpec` from it."""

    p0: float | None = setting(
        "p0_GPa", "float", "Maximum Hertz pressure (give this, `load_N` or "
        "`load_N_per_m`).", "GPa", GPA, default=None, lo=0, hi=100, lo_open=True)
    load: float | None = setting(
        "load_N", "float", "Normal load of an elliptical contact.", "N", 1.0,
        default=None, lo=0, hi=1e9, lo_open=True)
    load_per_length: float | None = setting(
        "load_N_per_m", "float", "Normal load per unit length of a line "
        "contact.", "N/m", 1.0, default=None, lo=0, hi=1e12, lo_open=True)
    u_mean: float = setting(
        "u_mean_m_s", "float", "Entrainment speed ū = (u1 + u2)/2.", "m/s", 1.0, lo=0,
        hi=1e3, lo_open=True)
    slide_roll: tuple[float, ...] | None = setting(
        "slide_roll", "floats", "Slide-roll ratios S = (u1 − u2)/ū, one contact "
        "each; |S| = 2 is pure sliding.", default=None, lo=-2, hi=2)
    radius1_x: float = setting(
        "radius1_x_mm", "float", "Radius of curvature of body 1 in the rolling "
        "direction.", "mm", MM, lo=0, hi=1e7, lo_open=True)
    radius2_x: float = setting(
        "radius2_x_mm", "float", "Radius of curvature of body 2 in the rolling "
        "direction.", "mm", MM, lo=0, hi=1e7, lo_open=True)
    radius1_y: float | None = setting(
        "radius1_y_mm", "float", "Radius of curvature of body 1 across the "
        "rolling direction (crown). Default: straight.", "mm", MM, default=None, lo=0,
        hi=1e7, lo_open=True)
    radius2_y: float | None = setting(
        "radius2_y_mm", "float", "Radius of curvature of body 2 across the "
        "rolling direction. Default: straight.", "mm", MM, default=None, lo=0, hi=1e7,
        lo_open=True)


@dataclass(frozen=True)
class HertzTable:
    """The ``[hertz]`` table (its override goes to ``Scene.hertz_E_star``)."""

    E_star: float | None = setting(
        "E_star_GPa", "float", "Contact modulus E* used in the Hertz formulas only "
        "(the film keeps the materials' E'). Default: E'/2 from the bodies. The paper's Tables "
        "3 and 7 use 210 (Young's modulus in place of E*); see docs/model.md §2.5.", "GPa", GPA,
        default=None, lo=0, hi=1e4, lo_open=True)


@dataclass(frozen=True)
class SurfaceSpec:
    """How a body's topography is made (SI). ``file`` is resolved against the scene's folder."""

    kind: str = setting(
        "kind", "str", "`gaussian` (Gaussian random field, exponential or Gaussian "
        "ACF), `self_affine` (fractal PSD between cut-offs), `file` (a measured map), "
        "`smooth` (no roughness).", default="gaussian", choices=SURFACE_KINDS)
    corr_x: float = setting(
        "corr_x_um", "float", "Correlation length β_x along rolling (lag where the "
        "ACF falls to 0.1), for `gaussian`.", "µm", UM, default=30.0, lo=0, hi=1e6,
        lo_open=True)
    corr_y: float = setting(
        "corr_y_um", "float", "Correlation length β_y across rolling. Ground gears "
        "and discs have their lay across the rolling direction: β_y > β_x. The default, 3 × "
        "the default β_x, fits the default window (2 b_ref; it must span 2 β_y, so windows "
        "from 180 µm); a longer β_y (ground flanks reach 300 µm) needs a wider "
        "window.length_y_um.", "µm", UM, default=90.0, lo=0, hi=1e9, lo_open=True)
    acf: str = setting(
        "acf", "str", "Autocorrelation function of a `gaussian` surface.",
        default="exponential", choices=("exponential", "gaussian"))
    hurst: float = setting(
        "hurst", "float", "Hurst exponent H of a `self_affine` surface.",
        default=0.8, lo=0, hi=1, lo_open=True, hi_open=True)
    long_cutoff: float | None = setting(
        "long_cutoff_um", "float", "Long-wavelength roll-off of a "
        "`self_affine` surface. Default: the window length.", "µm", UM, default=None, lo=0,
        hi=1e6, lo_open=True)
    short_cutoff: float | None = setting(
        "short_cutoff_um", "float", "Short-wavelength cut-off of a "
        "`self_affine` surface. Default: 4 grid spacings.", "µm", UM, default=None, lo=0,
        hi=1e6, lo_open=True)
    file: str | None = setting(
        "file", "str", "Measured height map (`.npy`, `.npz`, text matrix, HDF5, or "
        "any format of the optional SurfaceTopography package such as `.x3p`); relative "
        "to the scene file.", default=None)
    dataset: str | None = setting(
        "dataset", "str", "HDF5 dataset (or instrument channel) to read.",
        default=None)
    spacing: tuple[float, ...] | None = setting(
        "spacing_um", "floats", "Grid spacing [Δx, Δy] of a map that does not "
        "store it (`.npy`, text, instrument files without sizes). A file's own spacing "
        "(`.npz`, HDF5, `.x3p`, …) is used unless this is given; the run log says which "
        "was used and what it overrode.", "µm", UM, default=None, lo=0, lo_open=True)
    height_unit: str = setting(
        "height_unit", "str", "Unit of the heights stored in the file.",
        default="m", choices=("m", "mm", "um", "nm"))
    detrend: str = setting(
        "detrend", "str", "Detrending of a measured map (`quadratic` also "
        "removes the flank's curvature).", default="plane",
        choices=("none", "mean", "plane", "quadratic"))
    nan_policy: str = setting(
        "nan_policy", "str", "Missing points (NaN) in a measured map: refuse, "
        "fill with the mean, or interpolate from the neighbours.", default="error",
        choices=("error", "fill_mean", "interpolate"))
    periodise: str = setting(
        "periodise", "str", "How a measured map is made to tile without a "
        "step: `tukey` taper of the edges (the deviations are then scaled back to the "
        "map's R_q, which the taper alone lowers by ~14 %), `mirror` (even reflection), "
        "`none`.",
        default="tukey", choices=("none", "tukey", "mirror"))
    rescale: bool = setting(
        "rescale", "bool", "Scale a measured map to the body's `Rq_um` (by "
        "default its R_q must agree with `Rq_um` within 5 %).", default=False)


@dataclass(frozen=True, kw_only=True)
class Body:
    """Material and roughness of one body (SI). Keyword-only: the fields follow the keys' order
    (``Ra`` before ``hardness``), and ``Rq`` has no default."""

    E: float = setting(
        "E_GPa", "float", "Young's modulus.", "GPa", GPA, default=210.0, lo=0,
        hi=1e4, lo_open=True)
    nu: float = setting(
        "nu", "float", "Poisson's ratio.", default=0.3, lo=-1, hi=0.5, lo_open=True,
        hi_open=True)
    Rq: float = setting(
        "Rq_um", "float", "RMS roughness R_q of the surface.", "µm", UM, lo=0, hi=1e4)
    Ra: float | None = setting(
        "Ra_um", "float", "Arithmetic mean roughness R_a of the flank, for the "
        "ISO/TS 6336-22 Method B λ_GF of `micropit contact`. Default: √(2/π) R_q, the "
        "R_a of a Gaussian height distribution (`micropit run` uses the R_a of the "
        "simulated surfaces).", "µm", UM, default=None, lo=0, hi=1e4)
    hardness: float = setting(
        "hardness_GPa", "float", "Hardness H: the pressure cap p_lim = "
        "lubrication.p_lim_hardness × the smaller H of the two bodies, and Archard wear.",
        "GPa", GPA, default=7.0, lo=0, hi=1e3, lo_open=True)
    surface: SurfaceSpec = field(default_factory=SurfaceSpec)


@dataclass(frozen=True)
class Lubricant:
    """Lubricant at the contact inlet (SI); η0 and α may come from the grade."""

    eta0: float | None = setting(
        "eta0_mPas", "float", "Dynamic viscosity η0 at ambient pressure.", "mPa·s",
        1e-3, default=None, lo=0, hi=1e9, lo_open=True)
    alpha_pv: float | None = setting(
        "alpha_pv_1_per_GPa", "float", "Barus pressure-viscosity coefficient α "
        "(the EHL film formulas scale with a power of α: zero is not allowed).", "1/GPa", 1e-9,
        default=None, lo=0, hi=1e3, lo_open=True)
    beta: float | None = setting(
        "beta_1_per_K", "float", "Temperature-viscosity coefficient β, for "
        "`thermal = \"wilson_sheu\"`.", "1/K", 1.0, default=None, lo=0, hi=10, lo_open=True)
    conductivity: float | None = setting(
        "conductivity_W_per_mK", "float", "Thermal conductivity k_f of the oil, "
        "for `thermal = \"wilson_sheu\"`.", "W/(m·K)", 1.0, default=None, lo=0, hi=1e3,
        lo_open=True)
    tau0: float | None = setting(
        "eyring_stress_MPa", "float", "Eyring stress τ0 of the non-Newtonian film, "
        "needed by the `mixed` lubrication model.", "MPa", 1e6, default=None, lo=0, hi=1e4,
        lo_open=True)
    iso_vg: int | None = setting(
        "iso_vg", "int", "ISO 3448 viscosity grade (ν at 40 °C in mm²/s: 2, 3, 5, "
        "7, 10, 15, 22, 32, 46, 68, 100, 150, 220, 320, 460, 680, 1000, 1500, 2200, 3200). "
        "With `nu100_cSt` and `temperature_C` it gives η0 (ASTM D341 Walther) and α (Wooster "
        "1957) when `eta0_mPas` / `alpha_pv_1_per_GPa` are not given (micropit_hpc/oil.py).",
        default=None, lo=2, hi=3200)
    nu40: float | None = setting(
        "nu40_cSt", "float", "Kinematic viscosity at 40 °C (instead of `iso_vg`, "
        "e.g. from the oil's datasheet).", "mm²/s", 1e-6, default=None, lo=2, hi=1e5)
    nu100: float | None = setting(
        "nu100_cSt", "float", "Kinematic viscosity at 100 °C (the oil's datasheet), "
        "needed with `iso_vg` or `nu40_cSt`.", "mm²/s", 1e-6, default=None, lo=1, hi=1e4)
    temperature_C: float | None = setting(
        "temperature_C", "float", "Oil temperature at the contact inlet, "
        "for the viscosity by grade.", "°C", 1.0, default=None, lo=-40, hi=250)
    rho15: float = setting(
        "density_15C_kg_m3", "float", "Density at 15 °C, for η0 = ν ρ by grade "
        "(ρ falls 0.07 %/K).", "kg/m³", 1.0, default=880.0, lo=600, hi=2000)
    load_stage: int | None = setting(
        "micropitting_load_stage", "int", "Failure load stage SKS of the oil in "
        "the FVA 54 micropitting test GF-C/8.3/90 (or /60, `micropitting_test_temperature_C`), "
        "from the oil's datasheet: gives λ_GFT and the ISO/TS 6336-22 Method B permissible "
        "λ_GFP (micropit_hpc/iso6336_22.py).", default=None, lo=5, hi=10)
    test_temperature_C: float = setting(
        "micropitting_test_temperature_C", "float", "Oil temperature "
        "of that test (90 for GF-C/8.3/90, 60 for GF-C/8.3/60).", "°C", 1.0, default=90.0,
        lo=20, hi=150)
    lambda_gft: float | None = setting(
        "lambda_GFT", "float", "The specific film thickness λ_GFT of the test "
        "gears at the failure load stage, when known directly (a KISSsoft or datasheet value); "
        "wins over `micropitting_load_stage`.", default=None, lo=0, hi=100, lo_open=True)
    #: how η0 and α were obtained from the grade (None when both were given)
    derived: str | None = None


@dataclass(frozen=True)
class FilmSpec:
    """Film model of the smooth contact; ``model`` is resolved (never ``auto``) in a scene."""

    model: str = setting(
        "model", "str", "`DH61` (line, Dowson–Higginson 1961, ISO/TS 6336-22), `DH66` "
        "(line), `HD77c` (elliptical, Hamrock–Dowson central); `auto` picks DH61 for line and "
        "HD77c for elliptical contacts.", default="auto", choices=("auto", *FILM_MODELS))
    thermal: str = setting(
        "thermal", "str", "Inlet shear-heating factor φ_T: `none` (isothermal, "
        "reproduces the paper) or `wilson_sheu`.", default="none", choices=THERMAL_MODELS)
    hc: float | None = setting(
        "hc_um", "float", "Central film thickness given directly (e.g. measured); "
        "replaces the formula and the thermal factor.", "µm", UM, default=None, lo=0,
        hi=1e4, lo_open=True)
    lambda_roughness: str = setting(
        "lambda_roughness", "str", "Roughness in Λ = h_c/R_q: `composite` "
        "√(R_q1² + R_q2²), or one body's R_q (`body2`: the counterface only, as the paper's MPR "
        "tests define Λ).", default="composite", choices=("composite", "body1", "body2"))


@dataclass(frozen=True)
class GearSpec:
    """A gear pair and how it runs: torque on and speed of gear 1 [N m, rad/s].

    Built from :class:`GearTable` (which declares the keys and their defaults) and the
    :class:`GearGeometry` computed from it.
    """

    geometry: GearGeometry
    torque: float
    speed: float
    load_sharing: str
    accuracy_grade: int
    slide_roll_imposed: float | None = GearTable.slide_roll_imposed
    pitch_snap: float = GearTable.pitch_snap
    material_factor_ww: float = GearTable.material_factor_ww


@dataclass(frozen=True)
class PositionSpec:
    """Positions along the path: ``kind`` is roll_angle [rad], radial_position [m],
    modules_below_tip [-] (with ``values``) or count (with ``count``)."""

    kind: str
    values: tuple[float, ...] = ()
    count: int = 0


@dataclass(frozen=True)
class DiscSpec:
    """A disc rig (SI). Radii across rolling are infinite for straight generators."""

    u_mean: float
    slide_roll: tuple[float, ...]
    radius1_x: float
    radius2_x: float
    radius1_y: float
    radius2_y: float
    p0: float | None
    load: float | None

    @property
    def Rx(self) -> float:
        return 1.0 / (1.0 / self.radius1_x + 1.0 / self.radius2_x)

    @property
    def Ry(self) -> float:
        curvature = 1.0 / self.radius1_y + 1.0 / self.radius2_y
        return math.inf if curvature == 0.0 else 1.0 / curvature

    @property
    def is_line(self) -> bool:
        return math.isinf(self.Ry)


@dataclass(frozen=True)
class WindowSpec:
    """The computational window (SI); ``None`` lengths default to 2 b_ref."""

    nx: int = setting(
        "n", "int", "Grid points along rolling (5-smooth sizes such as 64, 128, 256 are "
        "fastest; any size works).", default=128, lo=8, hi=8192)
    ny: int | None = setting(
        "ny", "int", "Grid points across rolling. Default: `n`.", default=None, lo=2,
        hi=8192)
    lx: float | None = setting(
        "length_x_um", "float", "Window length along rolling. Default: 2 b_ref, twice "
        "the Hertz semi-width at the pitch point (a gear) or of the contact (a disc rig).",
        "µm", UM, default=None, lo=0, hi=1e6, lo_open=True)
    ly: float | None = setting(
        "length_y_um", "float", "Window length across rolling. Default: `length_x_um`.",
        "µm", UM, default=None, lo=0, hi=1e6, lo_open=True)
    steps: int = setting(
        "steps", "int", "Time steps per load cycle m, a floor: the cycle takes more where "
        "the relative slip per step would exceed λ_c/`steps_per_peak_spacing` (and, with "
        "`fatigue.counting = \"rainflow\"`, λ_c/4), and the log says so (docs/model.md §4). "
        "40 cosine-spaced steps keep the mean pressure's step p̄_j − p̄_{j−1} within π/40 = "
        "0.08 p0 up to the contact's edges; the paper used 20 uniform steps "
        "(docs/performance.md, \"Time steps\").", default=40, lo=1, hi=100000)
    step_spacing: str = setting(
        "step_spacing", "str", "[choice] Where the m steps fall in the transit. `cosine`: "
        "x_c = −b cos θ_j with θ_j = (j + ½)π/m, even steps of the Hertz mean pressure "
        "p̄ = p0 sin θ, dense at the inlet and outlet, where p̄ rises as a square root and a "
        "point's Dang Van path peaks on the few asperities still in contact (each step "
        "weighs its share of the transit time). `uniform`: t_j = (j + ½) t_f/m, the "
        "paper's; its first and last steps stay √(2/m) p0 from the unloaded edges, so A_p "
        "converges only as m^-½ (20 steps: −11 pt at gear position 5).", default="cosine",
        choices=("cosine", "uniform"))
    steps_per_peak_spacing: float = setting(
        "steps_per_peak_spacing", "float", "[choice] Steps in which the counterface "
        "slides past a point by one peak spacing λ_c (the smaller of the two surfaces', "
        "`fatigue.peak_spacing_min_cells`): m is raised to the fewest steps whose largest step "
        "lets the surfaces slip past each other by at most λ_c/this (uniform steps: "
        "2b|S|/m ≤ λ_c/this), so that a point's Dang Van path sees each asperity pass. 24 "
        "keeps A_p within 0.6 pt of twice the steps at gear positions 3 and 5, on 64² and "
        "128² alike (16: 1.1 pt; docs/performance.md §13); the scale is the roughness', not "
        "the grid's.", default=24.0, lo=0, hi=1e6, lo_open=True)
    seed: int = setting(
        "seed", "int", "Seed of the synthetic roughness (body 1 and body 2 draw "
        "independent streams from it).", default=1, lo=0, hi=2**63 - 1)


@dataclass(frozen=True)
class LubricationSpec:
    """Settings of the contact model per time step (docs/model.md §4.1), SI."""

    model: str = setting(
        "model", "str", "`smooth` (no roughness: p = p̄), `dry` (elastic–perfectly-"
        "plastic contact of the roughness; the fluid carries nothing), `mixed` (the fast "
        "mixed-lubrication model), `auto` (`smooth` for Λ ≥ `auto_lambda` or smooth surfaces, "
        "else `mixed`).", default="auto", choices=LUBRICATION_MODELS)
    auto_lambda: float = setting(
        "auto_lambda", "float", "Λ from which `auto` treats the contact as "
        "full-film and smooth.", default=3.0, lo=0, hi=1e3, lo_open=True)
    mu_bl: float = setting(
        "mu_boundary", "float", "Friction coefficient on solid contact.", default=0.11,
        lo=0, hi=2)
    mu_ehl: float = setting(
        "mu_ehl", "float", "Friction coefficient of the fluid film.", default=0.05,
        lo=0, hi=2)
    h_min: float = setting(
        "h_min_um", "float", "Clearance at or below which a point is in solid "
        "contact (so is a point whose clearance is 0 to the dry solve's accuracy, a few pm: "
        "docs/contact.md).", "µm", UM, default=0.0, lo=0, hi=100)
    p_lim_hardness: float = setting(
        "p_lim_hardness", "float", "Pressure cap as a fraction of the "
        "smaller hardness: p_lim = this × H.", default=0.6, lo=0, hi=10, lo_open=True)
    prefactor: float | None = setting(
        "amplitude_prefactor", "float", "Prefactor c_nn of the sliding-corrected "
        "wavelength parameter ∇_nn = c_nn ∇ ((1+S_i)/2)^(0.1+0.5K). Default: calibrated to the "
        "pure-rolling case of Venner & Lubrecht (A_d/A_i = 0.739), 1.304; the printed value "
        "is 0.8.", default=None, lo=0, hi=100)
    fluid_share: str = setting(
        "fluid_share", "str", "`scaled`: the fluid flattens the roughness in "
        "proportion to the load it carries, 1 − φ (a vanishing film then tends to the dry "
        "solution); `full`: always the full-film amplitude reduction.", default="scaled",
        choices=("scaled", "full"))
    combine: str = setting(
        "combine", "str", "`contact`: the dry contact acts on the lubricated "
        "clearance; `max_amplitude`: keep per Fourier mode the larger clearance amplitude of "
        "the dry and the lubricated solutions (docs/model.md §4.1 step 4 as printed; for "
        "comparison).", default="contact", choices=("contact", "max_amplitude"))
    tol: float = setting(
        "tolerance", "float", "Relative residual at which the contact solver stops.",
        default=1e-8, lo=1e-14, hi=1e-2)
    max_iter: int = setting(
        "max_iterations", "int", "Iteration limit of one contact solve.",
        default=5000, lo=10, hi=10**7)
    film_tol: float = setting(
        "film_tolerance", "float", "Relative tolerance of the flow balance that "
        "fixes the solid load fraction φ.", default=1e-4, lo=1e-12, hi=0.1)


@dataclass(frozen=True)
class StressSpec:
    """Depth layers of the stress field (docs/model.md §4.2); ``depth`` in units of b_ref."""

    layers: int = setting(
        "layers", "int", "Depth layers N_z from the surface to `depth_b`.",
        default=15, lo=2, hi=1000)
    depth: float = setting(
        "depth_b", "float", "Deepest layer z_max as a multiple of the reference "
        "semi-width b_ref.", default=0.25, lo=0, hi=10, lo_open=True)
    spacing: str = setting(
        "spacing", "str", "Layer spacing: `quadratic` z_k = z_max (k/(N_z−1))², "
        "dense near the surface, or `uniform`.", default="quadratic",
        choices=("quadratic", "uniform"))


@dataclass(frozen=True)
class FatigueSpec:
    """Dang Van, S–N and counting settings (docs/model.md §4.3–§4.4), SI."""

    counting: str = setting(
        "counting", "str", "`sliding`: one macro cycle (the smooth Hertz path) plus "
        "n_μ = 2b|u1 − u2|/(u_i λ_c) micro-cycles of the rough path per load cycle, λ_c the "
        "counterface's mean peak spacing; `rainflow`: rainflow-count τ̂ + α σ_H of the rough "
        "path (time steps raised so that the slip per step ≤ λ_c/4).", default="sliding",
        choices=COUNTING)
    A: float = setting(
        "woehler_A_MPa", "float", "Slope A of σ_f = A ln N + B (σ_f = √3 τ_DV); negative.",
        "MPa", 1e6, default=-40.0, lo=-1e5, hi=0, hi_open=True)
    B: float = setting(
        "woehler_B_MPa", "float", "Intercept B of the S–N line.", "MPa", 1e6,
        default=1600.0, lo=0, hi=1e6, lo_open=True)
    alpha: float | None = setting(
        "alpha_dv", "float", "Dang Van hydrostatic sensitivity α_DV. Default "
        "3(1/√3 − ½) = 0.232.", default=None, lo=0, hi=10)
    macro_samples: int = setting(
        "macro_samples", "int", "Samples of the smooth macro path through "
        "the contact (x from −3b to 3b, plus the unloaded state).", default=241, lo=8,
        hi=100000)
    peak_spacing_min_cells: float = setting(
        "peak_spacing_min_cells", "float", "[choice] Wavelengths "
        "shorter than this many grid spacings are left out of the spectral moments that give "
        "λ_c = 2π√(m2/m4): they are not resolved asperities but the grid-scale texture the "
        "local wear and pit updates leave, which m4 (∝ k⁴) would otherwise count as peaks "
        "(λ_c fell from 33 to 2.6 cells after 3 M cycles of wear, docs/life.md). 2 keeps every "
        "resolved wavelength (down to Nyquist).", default=4.0, lo=2, hi=1e4)
    process_length: float | None = setting(
        "process_length_um", "float", "[choice, beyond the paper] Side ℓ of the material's "
        "process area: the stresses are averaged over the surface plane before the Dang Van "
        "criterion, by a Gaussian of the same second moment as an ℓ × ℓ square "
        "(σ = ℓ/√12 along each axis, in the discrete form whose kernel is positive on any grid; "
        "transfer → exp(−k²ℓ²/24), the mean kept), at every depth layer, as the "
        "process volume and critical-distance methods of fretting fatigue do. It gives the "
        "criterion a length of the material's, so that pits stop following the grid cell "
        "once the cell is below it (docs/life.md, \"A process length for the criterion\"). "
        "Default: 5 µm (a hardened steel's critical distance, docs/model.md §4.3) with "
        "`life.integration = \"adaptive\"`, the converged default; 0, the paper's pointwise "
        "criterion, with `\"paper\"`, its literal numerics. 0 is always allowed.", "µm", UM,
        default=None, lo=0, hi=1e4)
    n_min: float = setting(
        "n_min", "float", "The fewest cycles the S–N line's data cover: below them "
        "the line is extrapolated (it predicts failure within one cycle at τ = B/√3, below "
        "the shear yield). The run reports the share of damage and new pits from N < n_min "
        "and warns above 10 %.", "cycles", 1.0, default=1e4, lo=1, hi=1e12)
    low_cycle: str = setting(
        "low_cycle", "str", "Below n_min: `extrapolate` the line (the paper) or "
        "`cap` the life at N = n_min (a sensitivity run, docs/life.md).",
        default="extrapolate", choices=LOW_CYCLE)


@dataclass(frozen=True)
class WearSpec:
    """Archard wear (docs/model.md §4.6): coefficients k_lub [s] and the solid-contact factor."""

    k_lub: tuple[float, ...] = setting(
        "k_lub_s", "floats", "Wear coefficients k_lub, one set of work items each "
        "(the paper: 0, 1e-11, 5e-11 s).", "s", 1.0, default=[0.0], lo=0, hi=1e-3)
    f_w: float = setting(
        "solid_factor", "float", "f_w: the factor on k_lub where the contact is solid.",
        default=10.0, lo=0, hi=1e6)
    solid_ramp: float = setting(
        "solid_ramp_film", "float", "[choice] Width of the clearance over which "
        "the wear coefficient goes from f_w·k_lub (clearance ≤ lubrication.h_min_um) to k_lub, "
        "as a fraction of the smooth central film h_c: k = k_lub[1 + (f_w − 1)s], s linear "
        "in the clearance. 0 is the step of the paper, at which the wear rate jumps tenfold "
        "at the edge of each contact spot and no worn depth is consistent with its own rate "
        "(docs/life.md, \"Implicit wear\"). Friction keeps the step (μ_bl on solid contact).",
        default=0.25, lo=0, hi=100)


@dataclass(frozen=True)
class LifeSpec:
    """Blocks of the life simulation (docs/model.md §5), in cycles."""

    cycles: float = setting(
        "cycles_M", "float", "Load cycles to simulate, in millions.", "Mcycles", 1e6,
        default=3.0, lo=0, hi=1e6, lo_open=True)
    block: float = setting(
        "block_M", "float", "Block ΔN between surface updates and checkpoints, in "
        "millions (the paper: 1).", "Mcycles", 1e6, default=1.0, lo=0, hi=1e6, lo_open=True)
    max_wear_fraction: float = setting(
        "max_wear_fraction", "float", "Split a block if its wear would "
        "change the shape of a body's surface by more than this fraction of its initial R_q "
        "anywhere (the wear depth less its mean over the intact columns: a uniform removal "
        "needs no split).", default=0.1,
        lo=0, hi=100, lo_open=True)
    max_damage_step: float = setting(
        "max_damage_step", "float", "Split a block if it would raise the "
        "maximum damage of the intact material by more than this.", default=0.25, lo=0,
        hi=1e9, lo_open=True)
    max_pit_step: float = setting(
        "max_pit_step", "float", "Split a block if it would newly pit more "
        "than this share of the window's columns (resolves the cascade of pits: a pit passes "
        "its load to its neighbours).", default=0.01, lo=0, hi=1, lo_open=True)
    min_sub_block: float = setting(
        "min_sub_block_M", "float", "[choice] The smallest sub-block, in millions of cycles, "
        "the same whatever the block ΔN: the damage and pit limits halve a sub-block down to "
        "it, and the implicit wear's shape limit ends none before it. It must resolve the "
        "first pits, which form from lives below 10⁴ cycles on the paper's surfaces: at gear "
        "position 5 (k_lub = 5e-11 s, 1 M cycles) A_p was 20.3 / 15.1 / 11.4 % and the wear "
        "1.17 / 1.94 / 2.40 µm with 15625 / 3906 / 977 cycles (docs/performance.md §14). "
        "Until 2026-11-25 it was ΔN/`max_splits`, which made the result depend on ΔN.",
        "Mcycles", 1e6, default=0.001, lo=0, hi=1e6, lo_open=True)
    max_splits: int = setting(
        "max_splits", "int", "At most this many sub-blocks per block: the smallest "
        "sub-block is the larger of `min_sub_block_M` and ΔN/max_splits (with the defaults "
        "`min_sub_block_M` rules for ΔN up to 4 M). With 4 the running-in of Table 9 at "
        "k_lub = 1e-11 s is not resolved (docs/life.md, \"Resolving the running-in\").",
        default=4096, lo=1, hi=100000)
    pit_contact: str = setting(
        "pit_contact", "str", "How a micropit enters the next contact "
        "solutions [choice]. `unloaded`: the pit's floor is never reached, so its columns "
        "carry no pressure and no traction; the contact, film balance and peak spacing are "
        "solved on the surface around it (the heights, R_q and wear outputs still drop by "
        "the pit depth), and the load a pitted asperity tip took in that solve is handed "
        "to all other columns as a film's pressure; `open`: as `unloaded`, but the contact "
        "solve itself holds the pits' columns at zero pressure, so the counterface settles "
        "elastically onto the intact columns around them and the flow balance averages "
        "over the intact columns (docs/life.md, \"Where the load of a pitted asperity "
        "goes\"); `geometric`: the pitted heights enter the clearance as a step "
        "(docs/model.md §4.5 read literally; a one-cell step of microns is outside what the "
        "small-slope half-space and the linearised micro-EHL represent and sets off a "
        "cascade of failures around every pit, docs/life.md).", default="unloaded",
        choices=("unloaded", "open", "geometric"))
    wear_integration: str = setting(
        "wear_integration", "str", "How the wear of a sub-block is "
        "integrated in the `adaptive` integration [decision] (`paper` always wears "
        "explicitly). `implicit`: backward Euler, the worn depth w = n·Δh(w) with Δh from "
        "contact-only load cycles solved on the surfaces worn by w, so each spot's relief "
        "comes from the contact's own response; the sub-block length follows an accuracy "
        "control on the wear (docs/life.md, \"Implicit wear\"). Not converged, kept for "
        "comparison: `relaxed`: the solid-contact part of the Archard rate decays as "
        "the wear relieves the pressure of each contact spot (lowering a spot by δ lowers its "
        "pressure by δ/K₀, K₀ the self-compliance of a grid cell), integrated exactly over "
        "the sub-block; the film part stays explicit; `explicit`: n·Δh, docs/model.md §4.6 as "
        "written, which digs contact spots many R_q deep when the sub-block is much longer "
        "than the few thousand cycles their wear takes to relieve them (docs/life.md).",
        default="implicit", choices=WEAR_INTEGRATIONS)
    wear_tol: float = setting(
        "wear_tol", "float", "`implicit` wear: the fixed point w = n·Δh(w) is "
        "solved until max |r − ⟨r⟩|, r = n·Δh(w) − w of each body, is below this fraction of "
        "the smallest initial R_q of the rough bodies; the mean ⟨r⟩ is solved exactly (a "
        "uniform wear changes no rate; docs/life.md, \"Implicit wear\").", default=0.005, lo=0,
        hi=1, lo_open=True)
    wear_accuracy: float = setting(
        "wear_accuracy", "float", "`implicit` wear: a sub-block is cut while "
        "backward Euler's local error estimate (n/2)·|Δh(w) − Δh(0)| (less its mean) exceeds "
        "this fraction of the smallest initial R_q; the next one grows by at most 4×.",
        default=0.05, lo=0, hi=100, lo_open=True)
    wear_max_iter: int = setting(
        "wear_max_iter", "int", "`implicit` wear: the most contact-only load "
        "cycles one sub-block's solve may take (a solve that stops there is accepted and "
        "reported in the log).", default=30, lo=1, hi=10000)
    running_in: str = setting(
        "running_in", "str", "[choice] Plastic running-in of the asperity tips before the "
        "first block, beyond the paper (docs/life.md, \"Plastic running-in of the tips\"). "
        "`none`: the life starts on the surfaces as given; `plastic`: the load cycle is "
        "solved contact-only and every column of each body lowered by its share of the "
        "largest plastic overlap it met (the negative clearance where p = p_lim; the shares "
        "in inverse proportion to the hardnesses), pass after pass until the largest overlap "
        "is below `running_in_overlap` of the composite R_q or `running_in_passes` passes; "
        "the damage of these first cycles is not counted.", default="none",
        choices=("none", "plastic"))
    running_in_passes: int = setting(
        "running_in_passes", "int", "`plastic` running-in: the most passes (contact-only "
        "load cycles; docs/performance.md §15).", default=100, lo=1, hi=100000)
    running_in_overlap: float = setting(
        "running_in_overlap", "float", "`plastic` running-in: it ends once the largest "
        "plastic overlap of a pass is below this fraction of the composite initial R_q.",
        default=1e-3, lo=0, hi=1, lo_open=True)
    integration: str = setting(
        "integration", "str", "Time integration of the life [decision]. "
        "`adaptive`: blocks split until damage, pits and wear are resolved in time (the "
        "limits above); `paper`: the paper's scheme, one evaluation per block of ΔN on the "
        "block's starting surfaces, damage and wear applied over the whole block, then the "
        "pit check. In `paper` the wear–fatigue competition depends on block_M "
        "(docs/life.md, \"Two time integrations\"). It also sets the default of "
        "`fatigue.process_length_um`: 5 µm in `adaptive`, 0 (pointwise) in `paper`.",
        default="adaptive",
        choices=INTEGRATIONS)


@dataclass(frozen=True)
class Scene:
    """A validated scene, SI units. ``document`` is the TOML as read (for results files)."""

    source: str
    name: str
    description: str
    body1: Body
    body2: Body
    lubricant: Lubricant
    film: FilmSpec
    hertz_E_star: float | None
    gear: GearSpec | None = None
    positions: PositionSpec | None = None
    disc: DiscSpec | None = None
    window: WindowSpec = field(default_factory=WindowSpec)
    lubrication: LubricationSpec = field(default_factory=LubricationSpec)
    stress: StressSpec = field(default_factory=StressSpec)
    fatigue: FatigueSpec = field(default_factory=FatigueSpec)
    wear: WearSpec = field(default_factory=WearSpec)
    life: LifeSpec = field(default_factory=LifeSpec)
    roughness_scale: tuple[float, ...] = StudyTable.roughness_scale
    patches: int = StudyTable.patches
    document: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    #: plausibility warnings (values in range that look like another unit), :func:`plausibility`
    warnings: tuple[str, ...] = field(default=(), compare=False)

    @property
    def kind(self) -> str:
        return "gear" if self.gear is not None else "disc"


# --------------------------------------------------------------------------------------------
# the tables of the file, derived from the dataclasses
# --------------------------------------------------------------------------------------------
_STUDY = section_of(StudyTable, "study", """
What the study is called, and the study dimensions beyond positions and wear coefficients. The
work items of a study are positions × `wear.k_lub_s` × `roughness_scale` × `patches`.
""")

_GEAR = section_of(GearTable, "gear", """
An external involute spur gear pair (docs/model.md §2.1). Gear 1 is the pinion (body 1) and drives;
gear 2 is the wheel (body 2). Give either `[gear]` with `[positions]`, or `[disc]`.
""", children=("pinion", "wheel"))


def _wheel_section(path: str, which: str) -> Section:
    return section_of(GearWheelTable, path, f"Gear {which} of the pair.")


_PINION = _wheel_section("gear.pinion", "1 (the pinion, body 1, the driver)")
_WHEEL = _wheel_section("gear.wheel", "2 (the wheel, body 2, driven)")


def _body_section(path: str, which: str) -> Section:
    return section_of(Body, path, f"Material and roughness of body {which}.",
                      children=("surface",))


def _surface_section(path: str, which: str) -> Section:
    return section_of(SurfaceSpec, path, f"""
Topography of body {which} on the simulation window (docs/model.md §3). Synthetic surfaces are
generated from `window.seed` with R_q = `Rq_um` of the body; a measured map is read, detrended,
made periodic, resampled to the window grid and checked against `Rq_um`.
""")


_SURFACE1 = _surface_section("body1.surface", "1")
_SURFACE2 = _surface_section("body2.surface", "2")


_BODY1 = _body_section("body1", "1 (the pinion or the test roller)")
_BODY2 = _body_section("body2", "2 (the wheel or the counterface)")

_LUBRICANT = section_of(Lubricant, "lubricant", """
Lubricant at the contact inlet temperature. Required unless `[film] hc_um` gives the film.
""")

_WINDOW = section_of(WindowSpec, "window", """
The computational window of one load cycle (docs/model.md §4): a periodic patch travelling with the
entrainment speed from the inlet to the outlet of the contact in `steps` time steps. The same
window and roughness patch are used at every position of a study.
""")

_LUBRICATION = section_of(LubricationSpec, "lubrication", """
Pressure and clearance of the rough surfaces at each time step (docs/model.md §4.1).
""")

_STRESS = section_of(StressSpec, "stress", "Subsurface stress layers (docs/model.md §4.2).")

_FATIGUE = section_of(FatigueSpec, "fatigue", """
Dang Van stress, S–N line and cycle counting (docs/model.md §4.3–§4.4). A material point fails, and
the material above it detaches as a micropit, when its Miner damage reaches 1.
""")

_WEAR = section_of(WearSpec, "wear", """
Local mild wear, Archard's law with a dimensional coefficient (docs/model.md §4.6):
Δh_i = ½ (|u_s|/H_i) (1/m) Σ_t k p per load cycle, k = f_w k_lub on solid contact and k_lub on
the fluid film.
""")

_LIFE = section_of(LifeSpec, "life", """
The life simulation (docs/model.md §5): blocks of ΔN load cycles, each evaluated on the current
surfaces, with the adaptive split of a block.
""")

_FILM = section_of(FilmSpec, "film",
                   "Central film thickness of the smooth contact (docs/model.md §2.4).")

_HERTZ = section_of(HertzTable, "hertz",
                    "Overrides of the smooth Hertz contact (docs/model.md §2.2, §2.5).")

_POSITIONS = section_of(PositionsTable, "positions", """
Where along the path of contact of a gear pair to evaluate; give exactly one key. Points must lie
on the loaded path: from A to E, end points excluded when the load sharing is `linear` (they carry
no load).
""")

_DISC = section_of(DiscTable, "disc", """
A disc rig (e.g. the MPR triple-disc rig): two bodies with given radii of curvature, run at a
given entrainment speed and a list of slide-roll ratios, one contact per ratio. Body 1 is the
test roller. Without `radius*_y_mm` the contact is a line contact.
""")

SECTIONS: tuple[Section, ...] = (_STUDY, _GEAR, _PINION, _WHEEL, _POSITIONS, _DISC, _BODY1,
                                 _SURFACE1, _BODY2, _SURFACE2, _LUBRICANT, _FILM, _HERTZ,
                                 _WINDOW, _LUBRICATION, _STRESS, _FATIGUE, _WEAR, _LIFE)

_KEYS_PREAMBLE = """
Scene files are TOML. Keys carry their unit in their name (`module_mm`, `torque_Nm`, `p0_GPa`);
values are converted to SI once, when the file is read. Every key below is checked: unknown keys
(with a suggestion), wrong types, NaN or infinite numbers and values out of range are refused with
a one-line message naming the file, the key, the value and what is allowed. Example scenes are in
`scenes/`. Generated by `micropit scene --help-keys`; do not edit by hand.
"""


def keys_markdown() -> str:
    """The key reference, as in docs/scenes.md."""
    return keys_reference(SECTIONS, "Scene file keys", _KEYS_PREAMBLE)


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------
def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; raise :class:`SceneError` on any problem."""
    source = str(path)
    try:
        mode = Path(path).stat().st_mode
    except FileNotFoundError:
        raise SceneError(source, "no such scene file") from None
    except OSError as e:
        raise SceneError(source, f"cannot be read: {e.strerror}") from None
    if stat.S_ISDIR(mode):
        raise SceneError(source, "is a directory, not a scene file")
    if not stat.S_ISREG(mode):      # a FIFO or a device would block the read, or never end
        raise SceneError(source, f"is not a regular file (a {_file_kind(mode)}), not a scene "
                                 "file")
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise SceneError(source, "no such scene file") from None
    except OSError as e:
        raise SceneError(source, f"cannot be read: {e.strerror}") from None
    try:
        text = data.decode("utf-8")
        doc = tomllib.loads(text)
    except UnicodeDecodeError:
        raise SceneError(source, "is not UTF-8 text (a TOML scene file was expected)") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(source, _toml_problem(text, e)) from None
    return scene_from_dict(doc, source=source)


def _file_kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "named pipe"), (stat.S_ISCHR, "character device"),
                       (stat.S_ISBLK, "block device"), (stat.S_ISSOCK, "socket")):
        if test(mode):
            return name
    return "special file"


def _toml_problem(text: str, e: Exception) -> str:
    """The TOML parser's complaint, with the key or table named when a key or a table is given
    twice (tomllib says only "Cannot overwrite a value (at line 3, column 9)")."""
    msg = str(e)
    m = re.search(r"\(at line (\d+), column \d+\)", msg)
    if m is None:
        return f"not valid TOML: {msg}"
    line_no = int(m.group(1))
    lines = text.splitlines()
    line = lines[line_no - 1] if 0 < line_no <= len(lines) else ""
    table = ""
    for earlier in reversed(lines[:line_no - 1]):
        head = re.match(r"\s*\[+\s*([^\]]+?)\s*\]+", earlier)
        if head:
            table = head.group(1).replace('"', "").replace(" ", "")
            break
    if msg.startswith("Cannot overwrite a value") and "=" in line:
        key = line.split("=", 1)[0].strip().strip('"')
        dotted = f"{table}.{key}" if table else key
        return (f"key '{dotted}' is given twice (again at line {line_no}): give each key "
                f"once")
    if msg.startswith("Cannot declare"):
        head = re.match(r"\s*\[+\s*([^\]]+?)\s*\]+", line)
        name = head.group(1).replace('"', "").replace(" ", "") if head else line.strip()
        return (f"table [{name}] is given twice (again at line {line_no}): put its keys in "
                f"one table")
    return f"not valid TOML: {msg}"


def scene_from_dict(doc: Mapping[str, Any], source: str = "<scene>") -> Scene:
    """Validate a parsed TOML document and build the :class:`Scene`."""
    check_unknown(doc, TOP_LEVEL, "", source)
    study: StudyTable = _STUDY.read(doc.get("study"), source)
    has_gear, has_disc = "gear" in doc, "disc" in doc
    if has_gear == has_disc:
        raise SceneError(source, "give exactly one of the tables [gear] (a gear pair) and [disc] "
                                 f"(a disc rig); found {'both' if has_gear else 'neither'}")
    for name in ("body1", "body2"):
        if name not in doc:
            raise SceneError(source, f"missing table [{name}] (material and roughness of "
                                     f"{name}; at least Rq_um)")
    body1 = _read_body(doc["body1"], _BODY1, _SURFACE1, source)
    body2 = _read_body(doc["body2"], _BODY2, _SURFACE2, source)
    lub = _lubricant_by_grade(_LUBRICANT.read(doc.get("lubricant"), source), source)
    film_v: FilmSpec = _FILM.read(doc.get("film"), source)
    hertz: HertzTable = _HERTZ.read(doc.get("hertz"), source)

    gear = positions = disc = None
    if has_gear:
        gear, mesh = _read_gear(doc["gear"], source)
        positions = _read_positions(doc, gear, mesh, source)
        line = True
    else:
        if "positions" in doc:
            raise SceneError(source, "[positions] belongs to a gear scene; a disc rig has one "
                                     "contact per value of disc.slide_roll")
        disc = _read_disc(doc["disc"], source)
        line = disc.is_line

    film = _check_film(film_v, lub, line, source)
    window: WindowSpec = _WINDOW.read(doc.get("window"), source)
    lubrication: LubricationSpec = _LUBRICATION.read(doc.get("lubrication"), source)
    stress: StressSpec = _STRESS.read(doc.get("stress"), source)
    fatigue: FatigueSpec = _FATIGUE.read(doc.get("fatigue"), source)
    wear: WearSpec = _WEAR.read(doc.get("wear"), source)
    life: LifeSpec = _LIFE.read(doc.get("life"), source)
    if fatigue.process_length is None:
        fatigue = replace(fatigue, process_length=PROCESS_LENGTH_DEFAULT[life.integration])
    if life.block > life.cycles:
        raise SceneError(source, f"the block ΔN = {life.block / 1e6:g} M is longer than the "
                                 f"whole life of {life.cycles / 1e6:g} M cycles",
                         key="life.block_M", value=life.block / 1e6,
                         allowed=f"≤ life.cycles_M = {life.cycles / 1e6:g}")
    name = study.name or Path(source).stem
    return Scene(source=source, name=name, description=study.description, body1=body1,
                 body2=body2, lubricant=lub, film=film, hertz_E_star=hertz.E_star,
                 gear=gear, positions=positions, disc=disc, window=window,
                 lubrication=lubrication, stress=stress, fatigue=fatigue, wear=wear,
                 life=life, roughness_scale=study.roughness_scale,
                 patches=study.patches, document=dict(doc),
                 warnings=tuple(plausibility(doc, source)))


def _read_body(table: Mapping[str, Any], section: Section, surface: Section,
               source: str) -> Body:
    values = read_section(table, section, source)
    spec: SurfaceSpec = surface.read(table.get("surface"), source)
    for attr, key in (("file", "file"), ("dataset", "dataset")):
        if spec.kind != "file" and getattr(spec, attr) is not None:
            raise SceneError(source, f"a measured map is read only with kind = \"file\", and "
                                     f"this body's kind is \"{spec.kind}\": set "
                                     f"{surface.path}.kind = \"file\" to use the map, or "
                                     f"remove the key", key=f"{surface.path}.{key}",
                             value=getattr(spec, attr))
    if spec.kind == "file":
        if spec.file is None:
            raise SceneError(source, f"missing key '{surface.path}.file': kind = \"file\" reads "
                                     "a measured height map")
        path = Path(spec.file)
        if not path.is_absolute():
            path = Path(source).parent / path
        spec = replace(spec, file=str(path))
    if spec.spacing is not None and len(spec.spacing) != 2:
        raise SceneError(source, "give two spacings [dx, dy]", key=f"{surface.path}.spacing_um",
                         value=table["surface"]["spacing_um"])
    return Body(**values, surface=spec)


#: (key, test on the value as written, what it probably is): in range, but typical of another
#: unit. Warnings, not errors: an unusual value can be right.
_PLAUSIBLE = (
    ("lubricant.eta0_mPas", lambda v: v < 0.3, "a value in Pa·s (gear oils have 2 to 2000 "
     "mPa·s; water 0.9)"),
    ("lubricant.eta0_mPas", lambda v: v > 1e5, "a value in µPa·s"),
    ("lubricant.alpha_pv_1_per_GPa", lambda v: v < 1.0, "a value in 1/Pa or 1/MPa (oils have "
     "5 to 40 1/GPa)"),
    ("lubricant.eyring_stress_MPa", lambda v: v > 100, "a value in Pa or kPa (oils: 1 to 20 "
     "MPa)"),
    ("lubricant.temperature_C", lambda v: v > 200, "a temperature in K"),
    ("body1.Rq_um", lambda v: 0 < v < 1e-3, "a value in metres or mm (a ground flank has "
     "0.1 to 1 µm)"),
    ("body2.Rq_um", lambda v: 0 < v < 1e-3, "a value in metres or mm (a ground flank has "
     "0.1 to 1 µm)"),
    ("body1.Rq_um", lambda v: v > 50, "a value in nm"),
    ("body2.Rq_um", lambda v: v > 50, "a value in nm"),
    ("body1.Ra_um", lambda v: 0 < v < 1e-3, "a value in metres or mm"),
    ("body2.Ra_um", lambda v: 0 < v < 1e-3, "a value in metres or mm"),
    ("body1.E_GPa", lambda v: v < 1.0, "a value in TPa"),
    ("body2.E_GPa", lambda v: v < 1.0, "a value in TPa"),
    ("body1.hardness_GPa", lambda v: v > 30, "a Vickers number HV (HV 700 ≈ 6.9 GPa)"),
    ("body2.hardness_GPa", lambda v: v > 30, "a Vickers number HV (HV 700 ≈ 6.9 GPa)"),
    ("body1.surface.corr_x_um", lambda v: v < 0.01, "a value in metres or mm (ground "
     "flanks have 5 to 100 µm)"),
    ("body1.surface.corr_y_um", lambda v: v < 0.01, "a value in metres or mm"),
    ("body2.surface.corr_x_um", lambda v: v < 0.01, "a value in metres or mm (ground "
     "flanks have 5 to 100 µm)"),
    ("body2.surface.corr_y_um", lambda v: v < 0.01, "a value in metres or mm"),
    ("window.length_x_um", lambda v: v < 1.0, "a value in metres or mm"),
    ("window.length_y_um", lambda v: v < 1.0, "a value in metres or mm"),
    ("gear.module_mm", lambda v: v < 0.1, "a value in metres"),
    ("gear.facewidth_mm", lambda v: v < 0.1, "a value in metres"),
    ("film.hc_um", lambda v: v < 1e-3, "a value in metres or mm"),
    ("disc.p0_GPa", lambda v: v > 20, "a value in MPa"),
)


def plausibility(doc: Mapping[str, Any], source: str) -> list[str]:
    """Warnings for values that are allowed but look like the wrong unit (e.g. ``eta0_mPas
    = 0.044``, a value in Pa·s; ``Rq_um = 5e-7``, a value in metres): one line each, naming
    the file, the key, the value and what it probably is."""
    out = []
    for key, test, what in _PLAUSIBLE:
        v = _lookup(doc, key)
        if isinstance(v, int | float) and not isinstance(v, bool) and test(v):
            out.append(f"{source}: {key} = {format_value(v)} looks like {what}; check the "
                       f"unit in the key's name")
    return out


def _lubricant_by_grade(lub: Lubricant, source: str) -> Lubricant:
    """η0 and α from the grade (micropit_hpc/oil.py) where the scene does not give them."""
    from micropit_hpc.oil import ISO_VG, oil_at

    if lub.iso_vg is not None and lub.iso_vg not in ISO_VG:
        raise SceneError(source, "not an ISO 3448 viscosity grade", key="lubricant.iso_vg",
                         value=lub.iso_vg, allowed="one of " + ", ".join(map(str, ISO_VG)))
    if lub.iso_vg is not None and lub.nu40 is not None:
        raise SceneError(source, "give either lubricant.iso_vg or lubricant.nu40_cSt, not "
                                 "both", key="lubricant.nu40_cSt", value=lub.nu40 * 1e6)
    nu40 = lub.nu40 * 1e6 if lub.nu40 is not None else lub.iso_vg
    if lub.load_stage is not None and lub.lambda_gft is None and lub.nu100 is None:
        raise SceneError(source, "λ_GFT from the micropitting load stage needs the oil by "
                                 "grade (iso_vg or nu40_cSt, nu100_cSt, temperature_C) for its "
                                 "viscosity at the test temperature; or give "
                                 "lubricant.lambda_GFT", key="lubricant.micropitting_load_stage",
                         value=lub.load_stage)
    grade_keys = {"iso_vg": lub.iso_vg, "nu40_cSt": lub.nu40, "nu100_cSt": lub.nu100,
                  "temperature_C": lub.temperature_C}
    if all(v is None for v in grade_keys.values()):
        return lub
    missing = [k for k, v in grade_keys.items()
               if v is None and k not in ("iso_vg", "nu40_cSt")]
    if nu40 is None:
        missing.insert(0, "iso_vg (or nu40_cSt)")
    if missing:
        raise SceneError(source, "the oil by grade needs lubricant.iso_vg (or nu40_cSt), "
                                 f"nu100_cSt and temperature_C; missing: {', '.join(missing)}")
    nu100 = lub.nu100 * 1e6
    if nu100 >= nu40:
        raise SceneError(source, f"ν at 100 °C must be below ν at 40 °C = {nu40:g} mm²/s",
                         key="lubricant.nu100_cSt", value=nu100, allowed=f"< {nu40:g}")
    oil = oil_at(nu40, nu100, lub.temperature_C, lub.rho15)
    if oil.nu < 2.0:
        raise SceneError(source, f"the oil's viscosity at {lub.temperature_C:g} °C is "
                                 f"{oil.nu:.3g} mm²/s, below the 2 mm²/s where ASTM D341's "
                                 "Walther form holds", key="lubricant.temperature_C",
                         value=lub.temperature_C, allowed="a temperature where ν ≥ 2 mm²/s")
    eta_given, alpha_given = lub.eta0 is not None, lub.alpha_pv is not None
    return replace(lub, eta0=lub.eta0 if eta_given else oil.eta0,
                   alpha_pv=lub.alpha_pv if alpha_given else oil.alpha,
                   derived=oil.describe(eta_given, alpha_given))


def check_mixed_inputs(scene: Scene, why: str) -> None:
    """The mixed model needs the lubricant's rheology, even when the film is given."""
    lub, source = scene.lubricant, scene.source
    for attr, key in (("eta0", "eta0_mPas"), ("alpha_pv", "alpha_pv_1_per_GPa"),
                      ("tau0", "eyring_stress_MPa")):
        if getattr(lub, attr) is None:
            raise SceneError(source, f"missing key 'lubricant.{key}': {why}, which needs the "
                                     "lubricant's viscosity, pressure-viscosity coefficient and "
                                     "Eyring stress (or set lubrication.model = \"dry\" or "
                                     "\"smooth\")")


_GEOMETRY_KEYS = {
    "centre_distance": "gear.centre_distance_mm",
    "tip_radius1": "gear.pinion.tip_diameter_mm", "tip_radius2": "gear.wheel.tip_diameter_mm",
    "root_radius1": "gear.pinion.root_diameter_mm",
    "root_radius2": "gear.wheel.root_diameter_mm",
    "x1": "gear.pinion.profile_shift", "x2": "gear.wheel.profile_shift",
}


def _lookup(doc: Mapping[str, Any], dotted: str) -> Any:
    node: Any = doc
    for part in dotted.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return None
        node = node[part]
    return node


def _read_gear(table: Mapping[str, Any], source: str) -> tuple[GearSpec, GearMesh]:
    g: GearTable = _GEAR.read(table, source)
    for part in ("pinion", "wheel"):
        if part not in table:
            raise SceneError(source, f"missing table [gear.{part}] (at least its number of "
                                     "teeth, e.g. teeth = 23)")
    p: GearWheelTable = _PINION.read(table["pinion"], source)
    w: GearWheelTable = _WHEEL.read(table["wheel"], source)
    m, alpha = g.module, g.pressure_angle

    def radii(t: GearWheelTable) -> tuple[float, float]:
        d = m * t.teeth
        tip = t.tip_diameter if t.tip_diameter is not None else d + 2 * m * (
            1 + t.profile_shift)
        root = t.root_diameter if t.root_diameter is not None else d - 2 * m * (
            1.25 - t.profile_shift)
        return tip / 2, root / 2

    (ra1, rf1), (ra2, rf2) = radii(p), radii(w)
    doc = {"gear": table}
    try:
        a = g.centre_distance
        if a is None:
            a = zero_backlash_centre_distance(m, alpha, p.teeth, w.teeth, p.profile_shift,
                                              w.profile_shift)
        geo = GearGeometry(module=m, pressure_angle=alpha, z1=p.teeth, z2=w.teeth,
                           x1=p.profile_shift, x2=w.profile_shift, tip_radius1=ra1,
                           tip_radius2=ra2, root_radius1=rf1, root_radius2=rf2,
                           centre_distance=a, facewidth=g.facewidth)
        mesh = GearMesh.from_geometry(geo)
    except MeshingError as e:
        keys = []
        for f in e.fields:
            dotted = _GEOMETRY_KEYS[f]
            v = _lookup(doc, dotted)
            keys.append(f"{dotted} = {format_value(v)}" if v is not None else
                        f"{dotted} (default)")
        raise SceneError(source, f"the gear pair cannot mesh: {e}; check {', '.join(keys)}"
                         ) from None
    spec = GearSpec(geometry=geo, torque=g.torque, speed=g.speed, load_sharing=g.load_sharing,
                    accuracy_grade=g.accuracy_grade, slide_roll_imposed=g.slide_roll_imposed,
                    pitch_snap=g.pitch_snap, material_factor_ww=g.material_factor_ww)
    return spec, mesh


def _read_positions(doc: Mapping[str, Any], gear: GearSpec, mesh: GearMesh,
                    source: str) -> PositionSpec:
    if "positions" not in doc:
        raise SceneError(source, "missing table [positions]: say where along the path of contact "
                                 "to evaluate (roll_angle_deg, radial_pos_mm, modules_below_tip "
                                 "or n)")
    v: PositionsTable = _POSITIONS.read(doc["positions"], source)
    given = [k for k in _POSITIONS.keys if getattr(v, k.attr) is not None]
    if len(given) != 1:
        names = ", ".join(f"positions.{k.name}" for k in _POSITIONS.keys)
        raise SceneError(source, f"give exactly one of {names}; found "
                                 f"{len(given) if given else 'none'}")
    key = given[0]
    kind = key.attr
    if kind == "count":
        return PositionSpec(kind="count", count=v.count)
    values = getattr(v, kind)
    open_ends = gear.load_sharing == "linear"
    lo, hi = mesh.position_range(kind)
    for i, value in enumerate(values):
        inside = (lo < value < hi) if open_ends else (lo <= value <= hi)
        if not inside:
            op = "<" if open_ends else "≤"
            ends = " (the end points carry no load with linear load sharing)" if open_ends else ""
            raise SceneError(
                source, "outside the loaded path of contact A–E" + ends,
                key=f"positions.{key.name}[{i}]", value=doc["positions"][key.name][i],
                allowed=f"{lo / key.scale:.9g} {op} value {op} {hi / key.scale:.9g} {key.unit}")
    return PositionSpec(kind=kind, values=values)


def _read_disc(table: Mapping[str, Any], source: str) -> DiscSpec:
    v: DiscTable = _DISC.read(table, source)
    if v.slide_roll is None:
        raise SceneError(source, "missing required key 'disc.slide_roll' (one contact per "
                                 "slide-roll ratio, e.g. slide_roll = [0.05, 0.15, 0.3])")
    ry1 = v.radius1_y if v.radius1_y is not None else math.inf
    ry2 = v.radius2_y if v.radius2_y is not None else math.inf
    line = math.isinf(ry1) and math.isinf(ry2)
    if not line:
        rx = 1.0 / (1.0 / v.radius1_x + 1.0 / v.radius2_x)
        ry = 1.0 / (1.0 / ry1 + 1.0 / ry2)
        name = "radius1_y_mm" if "radius1_y_mm" in table else "radius2_y_mm"
        if not 1e-6 <= ry / rx <= 1e6:
            raise SceneError(source, f"the reduced radii R_y = {ry * 1e3:.4g} mm and R_x = "
                                     f"{rx * 1e3:.4g} mm differ by more than 1e6: this is a line "
                                     "contact (omit radius1_y_mm and radius2_y_mm) or a radius "
                                     "is mistyped", key=f"disc.{name}", value=table[name])
    loads = {"p0_GPa": v.p0, "load_N": v.load, "load_N_per_m": v.load_per_length}
    given = [k for k, x in loads.items() if x is not None]
    if len(given) != 1:
        raise SceneError(source, "give exactly one of disc.p0_GPa, disc.load_N, "
                                 f"disc.load_N_per_m; found {len(given) if given else 'none'}")
    if line and "load_N" in given:
        raise SceneError(source, "a line contact (no radius1_y_mm or radius2_y_mm) carries a "
                                 "load per unit length: use load_N_per_m or p0_GPa",
                         key="disc.load_N", value=table["load_N"])
    if not line and "load_N_per_m" in given:
        raise SceneError(source, "an elliptical contact (radius*_y_mm given) carries a total "
                                 "load: use load_N or p0_GPa", key="disc.load_N_per_m",
                         value=table["load_N_per_m"])
    load = v.load if v.load is not None else v.load_per_length
    return DiscSpec(u_mean=v.u_mean, slide_roll=v.slide_roll, radius1_x=v.radius1_x,
                    radius2_x=v.radius2_x, radius1_y=ry1, radius2_y=ry2, p0=v.p0, load=load)


def _check_film(v: FilmSpec, lub: Lubricant, line: bool, source: str) -> FilmSpec:
    """The film as read, checked against the contact and the lubricant; ``auto`` resolved."""
    model = v.model
    if model == "auto":
        model = "DH61" if line else "HD77c"
    geometry = "line" if line else "elliptical"
    if (model == "HD77c") == line:
        wanted = "DH61 or DH66" if line else "HD77c"
        raise SceneError(source, f"this is {'an' if not line else 'a'} {geometry} contact; its "
                                 f"film model is {wanted}", key="film.model", value=v.model)
    if v.hc is None:
        for attr, key in (("eta0", "eta0_mPas"), ("alpha_pv", "alpha_pv_1_per_GPa")):
            if getattr(lub, attr) is None:
                raise SceneError(source, f"missing key 'lubricant.{key}': the film is computed "
                                         "from the lubricant because film.hc_um is not given")
        if v.thermal == "wilson_sheu":
            for attr, key in (("beta", "beta_1_per_K"), ("conductivity", "conductivity_W_per_mK")):
                if getattr(lub, attr) is None:
                    raise SceneError(source, f"missing key 'lubricant.{key}': film.thermal = "
                                             "\"wilson_sheu\" needs it")
    return replace(v, model=model)
