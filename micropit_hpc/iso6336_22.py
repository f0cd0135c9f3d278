"""ISO/TS 6336-22:2018 Method B beside A_p: λ_GF along the path, λ_GF,min, λ_GFP and S_λ.

The standard's micropitting criterion compares the smallest specific lubricant film thickness
along the path of contact with a permissible one derived from the oil's micropitting test:

* λ_GF,Y = h_Y / R_a along the path, R_a = ½(R_a1 + R_a2) (the standard's λ_GF,Y;
  :func:`micropit_hpc.film.iso_lambda_gf`), and λ_GF,min its minimum over the path A…E.
  Here h_Y is the scene's film (``film.model``, DH61 by default, a Dowson–Higginson form like
  the standard's; without its thermal sliding parameter S_GF and at the oil inlet temperature
  instead of the bulk temperature θ_M: "Method B style", docs/lubricant.md).
* λ_GFP = 1.4 W_W λ_GFT: the permissible specific film thickness from λ_GFT, the specific film
  thickness of the FVA 54 test gears (FZG type C) at the oil's failure load stage SKS and test
  temperature, and the material factor W_W (1.0 for case-carburised steel).
* S_λ = λ_GF,min / λ_GFP, the safety against micropitting (the standard recommends a minimum
  S_λ,min agreed between supplier and customer; S_λ < 1 means micropitting is expected).

λ_GFT is computed with the same film formula as the design, for the FZG type C test gear pair
(z 16/24, m 4.5 mm, α 20°, a 91.5 mm, x 0.1817/0.1715, d_a 82.46/118.36 mm, b 14 mm, pinion
2170 rpm: 8.3 m/s; R_a 0.5 µm on both flanks; steel E 206 GPa, ν 0.3; pinion torque of each
FZG load stage below) at the test's oil temperature, from the oil's ν40 and ν100. Using one
formula for both keeps the ratio λ_GF,min/λ_GFP free of the formula's own bias, which is the
point of Method B. A known λ_GFT (KISSsoft, datasheet) can be given instead
(``lubricant.lambda_GFT``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from micropit_hpc.errors import SceneError

#: Pinion torque [N·m] of the FZG load stages (FZG test rig, DIN ISO 14635-1 / FVA 54; the
#: table as widely quoted; not re-checked against the standard's text here).
FZG_TORQUE_NM = {1: 3.3, 2: 13.7, 3: 35.3, 4: 60.8, 5: 94.1, 6: 135.5, 7: 183.4, 8: 239.3,
                 9: 302.0, 10: 372.6, 11: 450.1, 12: 534.5}
#: λ_GFP = LAMBDA_GFP_FACTOR W_W λ_GFT (ISO/TS 6336-22 Method B).
LAMBDA_GFP_FACTOR = 1.4
TEST_RA = 0.5e-6          #: R_a of the FZG type C test flanks
#: The FZG type C test gear pair, as a scene document (tip diameters as built; a = 91.5 mm is
#: the zero-backlash distance of these shifts to 0.1 µm, so it is left to the default).
FZG_C_GEAR = {"module_mm": 4.5, "pressure_angle_deg": 20.0,
              "facewidth_mm": 14.0, "speed_rpm": 2170.0, "load_sharing": "iso_unmodified",
              "accuracy_grade": 5,
              "pinion": {"teeth": 16, "profile_shift": 0.1817, "tip_diameter_mm": 82.46},
              "wheel": {"teeth": 24, "profile_shift": 0.1715, "tip_diameter_mm": 118.36}}
PATH_POINTS = 201         #: points of the path A…E where λ_GF,Y is evaluated


@dataclass(frozen=True)
class MethodB:
    """The Method B numbers of a scene: λ_GF,Y at ``roll_angle`` [rad] along the path,
    its minimum and where, R_a [m], λ_GFT and how it was obtained, W_W, λ_GFP and S_λ (NaN
    when the oil's micropitting rating is not given)."""

    roll_angle: np.ndarray
    lambda_gf: np.ndarray
    lambda_gf_min: float
    roll_angle_min: float
    ra: float
    ra_note: str
    lambda_gft: float
    gft_note: str
    ww: float
    lambda_gfp: float
    s_lambda: float

    def lines(self) -> list[str]:
        """The summary printed by ``micropit contact`` and recorded with the results."""
        out = [f"ISO/TS 6336-22:2018 Method B: λ_GF,Y = h_Y/R_a along the path, R_a = "
               f"½(R_a1 + R_a2) = {self.ra * 1e6:.4g} µm ({self.ra_note}); λ_GF,min = "
               f"{self.lambda_gf_min:.4g}"
               + (f" at roll angle {math.degrees(self.roll_angle_min):.3f} deg"
                  if math.isfinite(self.roll_angle_min) and math.isfinite(self.lambda_gf_min)
                  else " (smooth flanks: no roughness to compare the film with)"
                  if self.ra == 0 else "")]
        if math.isfinite(self.lambda_gfp):
            verdict = ("≥ 1: micropitting not expected" if self.s_lambda >= 1.0
                       else "< 1: micropitting expected")
            out.append(f"λ_GFT = {self.lambda_gft:.4g} ({self.gft_note}); λ_GFP = 1.4 W_W "
                       f"λ_GFT = 1.4 × {self.ww:g} × {self.lambda_gft:.4g} = "
                       f"{self.lambda_gfp:.4g}; S_λ = λ_GF,min/λ_GFP = {self.s_lambda:.4g} "
                       f"({verdict})")
        else:
            out.append("λ_GFP and S_λ: give lubricant.micropitting_load_stage (with the oil "
                       "by grade) or lubricant.lambda_GFT")
        return out


def permissible_lambda(lambda_gft: float, ww: float = 1.0) -> float:
    """λ_GFP = 1.4 W_W λ_GFT (ISO/TS 6336-22:2018 Method B): the permissible specific film
    thickness from the test's λ_GFT and the material factor W_W."""
    return LAMBDA_GFP_FACTOR * ww * lambda_gft


def safety(lambda_gf_min: float, lambda_gfp: float) -> float:
    """S_λ = λ_GF,min / λ_GFP (ISO/TS 6336-22:2018 Method B safety against micropitting)."""
    return lambda_gf_min / lambda_gfp


def flank_ra(scene) -> tuple[float, str]:
    """R_a = ½(R_a1 + R_a2) [m] of the scene's bodies: ``Ra_um`` where given, else √(2/π) R_q
    (the R_a of a Gaussian height distribution); and a note saying which."""
    ras, notes = [], []
    for i, body in enumerate((scene.body1, scene.body2), start=1):
        if body.Ra is not None:
            ras.append(body.Ra)
            notes.append(f"body{i}.Ra_um")
        else:
            ras.append(math.sqrt(2.0 / math.pi) * body.Rq)
            notes.append(f"√(2/π) body{i}.Rq_um")
    return 0.5 * (ras[0] + ras[1]), " and ".join(notes)


def fzg_lambda_gft(scene, load_stage: int, temperature_C: float) -> float:
    """λ_GFT: the smallest λ_GF,Y = h/R_a along the path of the FZG type C test gears at the
    pinion torque of FZG ``load_stage``, with the scene's oil at ``temperature_C`` (by grade:
    ν40, ν100) and the scene's film model (isothermal), R_a = 0.5 µm."""
    from micropit_hpc.conditions import contact_study
    from micropit_hpc.scene import scene_from_dict

    lub = scene.lubricant
    nu40 = lub.nu40 * 1e6 if lub.nu40 is not None else lub.iso_vg
    doc = {"study": {"name": "FZG type C test gears"},
           "gear": {**FZG_C_GEAR, "torque_Nm": FZG_TORQUE_NM[load_stage]},
           "positions": {"n": PATH_POINTS},
           "body1": {"E_GPa": 206.0, "nu": 0.3, "Rq_um": 0.5, "Ra_um": 0.5},
           "body2": {"E_GPa": 206.0, "nu": 0.3, "Rq_um": 0.5, "Ra_um": 0.5},
           "lubricant": {"nu40_cSt": float(nu40), "nu100_cSt": lub.nu100 * 1e6,
                         "temperature_C": float(temperature_C),
                         "density_15C_kg_m3": lub.rho15},
           "film": {"model": scene.film.model if scene.film.model != "HD77c" else "DH61"}}
    test = contact_study(scene_from_dict(doc, f"{scene.source} (FZG C test gears)"))
    hc = np.array([c.hc for c in test.conditions])
    return float(np.min(hc) / TEST_RA)


def method_b(study, ra: float | None = None, ra_note: str | None = None) -> MethodB:
    """Method B for a :class:`~micropit_hpc.conditions.ContactStudy`: λ_GF,Y at
    :data:`PATH_POINTS` points from A to E (a gear) or at the rig's positions, λ_GF,min,
    λ_GFT (``lubricant.lambda_GFT``, or :func:`test_gear_lambda` from
    ``lubricant.micropitting_load_stage``), λ_GFP (:func:`permissible_lambda`) and S_λ
    (:func:`safety`). ``ra``: R_a [m] to use instead of :func:`flank_ra`."""
    from micropit_hpc.conditions import gear_conditions
    from micropit_hpc.film import iso_lambda_gf

    scene = study.scene
    if ra is None:
        ra, ra_note = flank_ra(scene)
    if study.mesh is not None:
        m = study.mesh
        rho1 = np.linspace(m.A, m.E, PATH_POINTS)
        with np.errstate(all="ignore"):
            cond = gear_conditions(replace(scene, gear=replace(scene.gear, pitch_snap=0.0)),
                                   m, rho1)
        roll = np.array([c.roll_angle for c in cond])
    else:
        cond = study.conditions
        roll = np.full(len(cond), math.nan)
    hc = np.array([c.hc for c in cond])
    lam = np.asarray(iso_lambda_gf(hc, ra, ra))
    finite = np.where(np.isfinite(lam), lam, np.inf)
    k = int(np.argmin(finite))
    lam_min = float(finite[k])
    lub = scene.lubricant
    gft, note = math.nan, ""
    if lub.lambda_gft is not None:
        gft, note = lub.lambda_gft, "lubricant.lambda_GFT"
    elif lub.load_stage is not None:
        if lub.nu100 is None:
            raise SceneError(scene.source, "λ_GFT from the micropitting load stage needs the "
                                           "oil by grade (iso_vg or nu40_cSt, nu100_cSt, "
                                           "temperature_C) for its viscosity at the test "
                                           "temperature, or give lubricant.lambda_GFT",
                             key="lubricant.micropitting_load_stage", value=lub.load_stage)
        gft = fzg_lambda_gft(scene, lub.load_stage, lub.test_temperature_C)
        note = (f"FZG type C test gears at load stage {lub.load_stage} "
                f"({FZG_TORQUE_NM[lub.load_stage]:g} N·m), {lub.test_temperature_C:g} °C, "
                f"R_a 0.5 µm, film.model {scene.film.model}")
    ww = scene.gear.material_factor_ww if scene.gear is not None else 1.0
    gfp = permissible_lambda(gft, ww) if math.isfinite(gft) else math.nan
    s = safety(lam_min, gfp) if math.isfinite(gfp) else math.nan
    return MethodB(roll_angle=roll, lambda_gf=lam, lambda_gf_min=lam_min,
                   roll_angle_min=float(roll[k]), ra=ra, ra_note=ra_note or "", lambda_gft=gft,
                   gft_note=note, ww=ww, lambda_gfp=gfp, s_lambda=s)
