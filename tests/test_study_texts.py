"""Sentences the studies print: a one-point sweep makes no claim of a trend."""

from types import SimpleNamespace

import pandas as pd

from ufmt.studies.sweep import sweep_headline


def test_one_point_sweep_headline_states_the_point_not_a_trend():
    axis = SimpleNamespace(parameter="head_radial_stiffness_N_m")
    study = SimpleNamespace(
        groups=[SimpleNamespace(name="k", axes=[axis])], options={"metric": "pv_nm"}
    )
    table = pd.DataFrame(
        {"group": ["k"], "head_radial_stiffness_N_m": [6e7], "pv_nm": [143.0], "status": ["ok"]}
    )
    headline = sweep_headline(table, study)
    assert headline == (
        "whole-plate PV (pv_nm): 143 nm at head_radial_stiffness_N_m = 6e+07 (one point)."
    )
    assert "falls" not in headline and "rises" not in headline
