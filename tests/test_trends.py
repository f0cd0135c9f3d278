"""The trend checks of docs/model.md §7 (trends 2–6): the paper's own tables pass them, and tables
that break each trend in the way a model could fail it do not."""

from __future__ import annotations

from dataclasses import replace

import pytest
from helpers import read_table

from micropit_hpc.trends import FlankPoint, trend2, trend3, trend4, trend5, trend6

REGION = {int(r["position"]): r["pair_region"] == "single"
          for r in read_table("table3_contact_conditions_z23.csv")}


def table4(column: str) -> list[FlankPoint]:
    return [FlankPoint(int(r["position"]), float(r["S"]), REGION[int(r["position"])],
                       float(r[column])) for r in read_table("table4_Ap_along_flank_z23.csv")]


def set_ap(points, **by_position):
    return [replace(p, ap=by_position.get(f"p{p.position}", p.ap)) for p in points]


@pytest.mark.parametrize("body", ["driver", "driven"])
def test_the_papers_table4_passes_trends_2_3_and_4(body):
    k0, k1, k5 = (table4(f"Ap_pct_klub{k}_{body}") for k in ("0", "1e-11", "5e-11"))
    for v in (trend2(k0), trend3(k0, k1), trend4(k1, k5)):
        assert v.holds, v.line()


def test_the_papers_table5_and_table8_pass_trends_5_and_6():
    rows = read_table("table5_constant_SRR_z23.csv")
    pts = [FlankPoint(int(r["position"]), float(r["S_imposed"]), REGION[int(r["position"])],
                      float(r["Ap_pct_klub1e-11_driver"])) for r in rows]
    assert trend5(pts).holds, trend5(pts).line()
    t8 = {(int(r["z"]), r["nominal_location_below_tip"]): r
          for r in read_table("table8_Ap_z23_vs_z18.csv")}
    by_k = {z: {0.0: float(t8[(z, "0.7m")]["Ap_pct_klub0_driver"]),
                1e-11: float(t8[(z, "0.7m")]["Ap_pct_klub1e-11_driver"])} for z in (18, 23)}
    assert trend6(by_k[23], by_k[18]).holds


def test_trend2_fails_on_pits_at_the_pitch_a_dip_or_a_rise_into_the_double_pair_zone():
    k0 = table4("Ap_pct_klub0_driver")
    assert not trend2(set_ap(k0, p6=3.0)).holds                  # pits without sliding
    assert not trend2(set_ap(k0, p4=40.0)).holds                 # 47 at 5, 40 at 4: a dip
    # 60 → 99 past the single-pair zone after a rise of 60 across it (the paper: 85 → 91)
    assert not trend2(set_ap(k0, p1=99.0, p2=95.0, p3=60.0, p4=55.0)).holds
    saturated = [replace(p, ap=0.0 if p.position == 6 else 99.0) for p in k0]
    assert not trend2(saturated).holds                            # nothing rises: saturated


def test_trend3_fails_when_wear_raises_a_p_or_moves_its_maximum_to_the_ends():
    k0, k1 = table4("Ap_pct_klub0_driver"), table4("Ap_pct_klub1e-11_driver")
    assert not trend3(k0, set_ap(k1, p2=95.0)).holds              # above k_lub = 0
    assert not trend3(k0, set_ap(k1, p3=60.0)).holds              # max at the zone's end
    assert not trend3(k0, set_ap(k1, p10=50.0)).holds             # max in the double zone


def test_trend4_fails_above_the_milder_wear_or_not_flat():
    k1, k5 = table4("Ap_pct_klub1e-11_driver"), table4("Ap_pct_klub5e-11_driver")
    assert not trend4(k1, set_ap(k5, p1=30.0)).holds              # above k_lub = 1e-11 s
    assert not trend4(k1, set_ap(k5, p3=25.0)).holds              # a 20-point bump


def test_trend5_and_trend6_fail_when_reversed():
    pts = [FlankPoint(1, -0.044, False, 10.0), FlankPoint(4, -0.044, True, 45.0),
           FlankPoint(6, 0.0, True, 0.0), FlankPoint(8, 0.044, True, 44.0),
           FlankPoint(10, 0.044, False, 44.5)]
    assert not trend5(pts).holds
    assert trend5(set_ap(pts, p10=43.0)).holds
    assert not trend6({0.0: 67.0, 1e-11: 35.0}, {0.0: 60.0, 1e-11: 28.0}).holds
    assert not trend6({0.0: 67.0, 1e-11: 35.0}, {0.0: 88.0, 1e-11: 40.0}).holds
