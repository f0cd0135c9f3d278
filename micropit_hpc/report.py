"""Reports at the engineering-unit boundary: the contact-conditions table and path summary."""

from __future__ import annotations

import math

from micropit_hpc.conditions import ContactStudy
from micropit_hpc.io.atomic import write_text_atomic  # noqa: F401  (re-exported)

CONTACT_COLUMNS = ("position", "roll_angle_deg", "radial_pos_mm", "R_mm", "w_N_per_m", "p0_GPa",
                   "b_um", "S", "u_mean_m_s", "hc_um", "Lambda", "region", "lambda_GF")


def _f(x: float, fmt: str) -> str:
    """A number for a CSV cell: empty when not defined (NaN), ``inf`` when infinite."""
    if math.isnan(x):
        return ""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, fmt)


def contact_csv(study: ContactStudy) -> str:
    """One row per position, columns :data:`CONTACT_COLUMNS` (engineering units);
    ``lambda_GF`` is ISO/TS 6336-22's h/R_a with R_a from :func:`~micropit_hpc.iso6336_22.
    flank_ra`.

    ``w_N_per_m`` is empty for an elliptical contact (its load is a force, not a line load);
    ``roll_angle_deg`` and ``radial_pos_mm`` are empty for a disc rig.
    """
    from micropit_hpc.film import iso_lambda_gf
    from micropit_hpc.iso6336_22 import flank_ra

    ra, _ = flank_ra(study.scene)
    lines = [",".join(CONTACT_COLUMNS)]
    for c in study.conditions:
        w = c.load if c.geometry == "line" else math.nan
        lines.append(",".join((
            str(c.position), _f(math.degrees(c.roll_angle), ".4f"),
            _f(c.radial_position * 1e3, ".4f"), _f(c.R * 1e3, ".5f"), _f(w, ".1f"),
            _f(c.p0 / 1e9, ".5f"), _f(c.b * 1e6, ".4f"), _f(c.S, ".5f"), _f(c.u_mean, ".5f"),
            _f(c.hc * 1e6, ".5f"), _f(c.Lambda, ".5f"), c.region,
            _f(float(iso_lambda_gf(c.hc, ra, ra)), ".5f"))))
    return "\n".join(lines) + "\n"


def path_summary(study: ContactStudy) -> list[str]:
    """Human-readable lines: the gear pair's path of contact (A, B, C, D, E, ε_α), or the rig."""
    scene = study.scene
    out = [f"study {scene.name} ({scene.source}): {len(study.conditions)} positions"]
    E_note = ("set by hertz.E_star_GPa" if scene.hertz_E_star is not None else "= E'/2")
    if scene.lubricant.derived:
        out.append(scene.lubricant.derived)
    out.append(f"moduli: E' = {study.E_prime / 1e9:.2f} GPa (film), E* = "
               f"{study.E_star / 1e9:.2f} GPa (Hertz, {E_note})")
    if study.mesh is not None:
        m, geo = study.mesh, study.mesh.geometry
        out.append(f"gear pair: z1 = {geo.z1}, z2 = {geo.z2}, m = {geo.module * 1e3:g} mm, "
                   f"alpha = {math.degrees(geo.pressure_angle):g} deg, a = "
                   f"{geo.centre_distance * 1e3:.4f} mm, alpha_w = {math.degrees(m.alpha_w):.4f} "
                   f"deg, load sharing {scene.gear.load_sharing}")
        out.append("path of contact    rho1_mm  roll_angle_deg  radial_pos_mm")
        names = {"A": "start of active profile", "B": "lowest point of single contact",
                 "C": "pitch point", "D": "highest point of single contact",
                 "E": "tip of gear 1"}
        for label, desc in names.items():
            rho = getattr(m, label)
            out.append(f"  {label} {rho * 1e3:14.4f} {math.degrees(rho / geo.base_radius1):15.4f} "
                       f"{float(m.radial_position(rho)) * 1e3:14.4f}   {desc}")
        out.append(f"transverse contact ratio eps_alpha = {m.contact_ratio:.4f}, base pitch "
                   f"p_b = {m.pb * 1e3:.4f} mm, line of action g = {m.g * 1e3:.4f} mm")
    else:
        d = scene.disc
        kind = "line contact" if d.is_line else f"elliptical contact, Ry = {d.Ry * 1e3:.4g} mm"
        out.append(f"disc rig: Rx = {d.Rx * 1e3:.4g} mm, {kind}, u_mean = {d.u_mean:g} m/s")
        if not d.is_line:
            c = study.conditions[0]
            out.append(f"Hertz ellipse: load F = {c.load:.4g} N, semi-axes a_x = "
                       f"{c.b * 1e6:.4g} µm (rolling), a_y = {c.a * 1e6:.4g} µm (across)")
    from micropit_hpc.iso6336_22 import method_b
    return out + method_b(study).lines()
