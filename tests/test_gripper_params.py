"""The gripper FMUs' default parameters and the shipped contact conditions against the project's reference table
``../shared/data/gripper_params.csv`` (seed 002; the product never reads it, the tests may).

Every default that the docs attribute to the paper or to an estimate row must equal that row (rtol 1e-3: the
table prints 4-6 significant digits).
"""

import csv

import pytest
from numpy.testing import assert_allclose

from test_gripper_support import ROOT, load_conditions

SHARED = ROOT.parent / "shared" / "data" / "gripper_params.csv"

# FMU parameter -> (symbol in gripper_params.csv, quantity prefix to disambiguate repeated symbols)
DEFAULTS = {
    "R_s": ("R_s", ""), "L_d": ("L_d", ""), "L_q": ("L_q", ""), "k_t": ("k_t", ""), "J_r": ("J_r", ""),
    "J_g": ("J_g", ""), "B_r": ("B_r", ""), "ratio": ("tau", ""), "eta_g": ("eta_g1", ""), "T_max": ("T_max", ""),
    "omega_max": ("omega_max", ""), "play": ("play", ""), "r_p": ("r_p", ""), "J_p": ("J_p", ""),
    "m_jf": ("m_jf", ""), "eta_grease": ("eta", ""), "S_i": ("S_i", ""), "d_grease": ("d", ""),
    "k_f": ("k_f_FEM", ""), "d_lim": ("x_lim", ""), "C_h": ("C_h", ""),
}


@pytest.fixture(scope="module")
def table():
    if not SHARED.exists():
        pytest.skip(f"reference table not present: {SHARED}")
    rows = {}
    with open(SHARED, newline="") as f:
        for row in csv.DictReader(f):
            if row["symbol"] and row["value_si"]:
                rows.setdefault(row["symbol"], []).append(row)
    return rows


def _value(table, symbol):
    return float(table[symbol][0]["value_si"])


@pytest.mark.slow
def test_fmu_defaults_match_reference_table(gripper_fmus, table):
    from fmpy import read_model_description

    md = read_model_description(str(gripper_fmus["GripperPlant"]))
    start = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    for name, (symbol, _) in DEFAULTS.items():
        assert_allclose(start[name], _value(table, symbol), rtol=1e-3, err_msg=name)
    # dependent parameters follow: B_g of eq. (9) at eta = 0.68, Psi_m = k_t / P
    b_g = [r for r in table["B_g"] if "0.68" in r["quantity"]][0]
    assert_allclose(start["T_max"] * (1 - start["eta_g"]) * start["ratio"] ** 2 / start["omega_max"],
                    float(b_g["value_si"]), rtol=1e-3)
    assert_allclose(start["k_t"] / _value(table, "P"), _value(table, "Psi_m"), rtol=1e-3)
    # guide friction: mu_i * m_jf * g; grease: 4 surfaces give the table's c_v
    assert_allclose(start["F_cj"], _value(table, "mu_i") * start["m_jf"] * 9.81, rtol=1e-3)
    assert_allclose(4 * start["eta_grease"] * start["S_i"] / start["d_grease"], _value(table, "c_v"), rtol=1e-3)
    # no-load drag = the paper's 0.2 A dead zone times k_t
    assert_allclose(start["T_c0"], _value(table, "i_dz") * start["k_t"], rtol=1e-3)


def test_conditions_match_reference_table(table):
    conds = load_conditions()
    assert sorted(conds) == sorted(f"{c}_{o}" for c in ("bare", "P1", "P2", "P3") for o in ("static_al", "dynamic_abs"))
    for name, c in conds.items():
        coating, obj = name.split("_", 1)
        assert_allclose(c["k_obj"], _value(table, "k_cyl") if obj == "dynamic_abs" else
                        _value(table, "E_f") * _value(table, "A") / _value(table, "L0"), rtol=2e-3)
        assert_allclose(c["C_h"], _value(table, "C_h"))
        assert_allclose(c["d_lim"], _value(table, "x_lim"))
        if coating == "bare":
            assert c["t_coat"] == 0 and c["k_P"] >= 1e12
            assert_allclose(c["C_p"], _value(table, "C_hs"))
        else:
            assert_allclose(c["t_coat"], _value(table, "t_coat"))
            assert_allclose(c["k_P"], _value(table, f"k_{coating}"))
            assert_allclose(c["k_P"] * c["k_H_ratio"], _value(table, f"k_H{coating[1]}"))
            assert_allclose(c["C_p"], _value(table, "C_p"))


IMPACT_FIT = ROOT / "cosim" / "data" / "gripper_impact_fit.csv"
IMPACT_START = {"J_r": "J_r", "C_h": "C_h", "C_p": "C_hs", "d_lim": "x_lim"}  # fitted parameter -> reference row
IMPACT_CONFIGS = {"bare_dynamic_abs": "gripper_impact.toml", "P3_dynamic_abs": "gripper_impact_p3.toml"}


def test_impact_fit_starts_from_the_reference_and_the_impact_configs_use_it(table):
    import tomllib

    with open(IMPACT_FIT, newline="") as f:
        rows = list(csv.DictReader(row for row in f if not row.startswith("#")))
    assert sorted(r["parameter"] for r in rows) == sorted(IMPACT_START)
    for r in rows:
        assert_allclose(float(r["start"]), _value(table, IMPACT_START[r["parameter"]]), rtol=1e-3)
        assert r["fitted_to"], r["parameter"]
    for condition, name in IMPACT_CONFIGS.items():
        with open(ROOT / "examples" / name, "rb") as f:
            used = tomllib.load(f)["fmus"]["plant"]["parameters"]
        fitted = {r["parameter"]: float(r["value"]) for r in rows if condition in r["conditions"].split(";")}
        assert fitted and {k: used.get(k) for k in fitted} == fitted, name
