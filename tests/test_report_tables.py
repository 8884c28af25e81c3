"""catenary.report.tables: the report's tables in an engineer's units, the files kept SI."""

import numpy as np
import pandas as pd
import pytest

from catenary.report.tables import engineer_table, header, quantity


def test_columns_take_an_engineers_unit_and_positions_along_the_line_stay_in_metres():
    spans = pd.DataFrame({"span_id": ["M1-M2"], "start_chainage_m": [585.0], "end_chainage_m": [643.5],
                          "length_m": [58.5], "gap_norm_m": [0.00083], "static_tension_n": [124.9],
                          "speed_kmh": [320.0], "converged": [True]})
    shown = engineer_table(spans)
    assert list(shown.columns) == ["span id", "start chainage [m]", "end chainage [m]", "length [m]",
                                   "gap norm [mm]", "static tension [N]", "speed [km/h]", "converged"]
    row = shown.iloc[0]
    assert row["start chainage [m]"] == 585.0 and row["length [m]"] == 58.5     # along the line: m
    assert row["gap norm [mm]"] == pytest.approx(0.83)                          # a gap: mm
    assert row["static tension [N]"] == 124.9 and row["converged"] == True      # noqa: E712
    # a dropper's length is not a span's: in a table about droppers it is read in mm
    droppers = engineer_table(pd.DataFrame({"dropper": [1], "x_m": [4.5], "length_m": [1.2545]}))
    assert list(droppers.columns) == ["dropper", "x [m]", "length [mm]"]
    assert droppers.iloc[0]["length [mm]"] == pytest.approx(1254.5) and droppers.iloc[0]["x [m]"] == 4.5


def test_rows_of_quantities_are_named_and_read_in_their_own_unit():
    s_opt = pd.DataFrame({"parameter": ["dropper_1_length_m", "messenger_tension_n", "system_height_m"],
                          "mu": [1.24296, 20601.0, 1.38691], "sigma": [0.00745, 833.0, 0.00637],
                          "mu_se": [0.0, 82.0, 0.00084], "mu_total_low": [np.nan, 20426.0, 1.3851],
                          "mu_variance_widening": [np.nan, 1.2, 1.1], "mu_fixed": [True, False, False]})
    shown = engineer_table(s_opt).set_index("parameter")
    assert list(shown.index) == ["dropper 1 length [mm]", "messenger tension T_MW [N]", "system height ΔH [mm]"]
    assert shown.loc["dropper 1 length [mm]", "mu"] == pytest.approx(1242.96)
    assert shown.loc["dropper 1 length [mm]", "sigma"] == pytest.approx(7.45)
    assert shown.loc["system height ΔH [mm]", "mu total low"] == pytest.approx(1385.1)
    assert shown.loc["messenger tension T_MW [N]", "mu"] == 20601.0
    # a ratio is no length: the variance widening is left as it is
    assert shown.loc["system height ΔH [mm]", "mu variance widening"] == 1.1
    # a contact-force criterion by its EN 50367 name; the uplift in mm
    summary = engineer_table(pd.DataFrame({"speed_kmh": [320, 320], "quantity": ["std_force_n", "max_support_uplift_m"],
                                           "mean": [36.5, 0.0359], "probability": [np.nan, np.nan]}))
    assert list(summary["quantity"]) == ["standard deviation σ_F [N]", "steady-arm uplift [mm]"]
    assert summary["mean"].tolist() == pytest.approx([36.5, 35.9])


def test_names_without_a_unit_stay_as_they_are():
    assert header("dominant_source") == ("dominant source", 1.0)
    assert quantity("span") == ("span", 1.0, "")
    assert header("converged_within_3_percent") == ("converged within 3 [%]", 1.0)
    assert header("gap_closed_fraction") == ("gap closed [%]", 100.0)


def test_a_rules_tables_are_copied_and_an_empty_one_stays_empty(tmp_path):
    # every output <name>_shown is the copy of output <name>; a stage with nothing to write (the
    # model-error budget switched off) writes an empty file, shown empty
    from catenary.report.tables import write_shown

    (tmp_path / "budget.csv").write_text("\n")
    (tmp_path / "table1.csv").write_text("dropper,std_cm\n1,1.05\n")
    outputs = {"budget": tmp_path / "budget.csv", "budget_shown": tmp_path / "shown" / "budget.csv",
               "table1": tmp_path / "table1.csv", "table1_shown": tmp_path / "shown" / "table1.csv",
               "figure": tmp_path / "fig.png"}
    written = write_shown(outputs)
    assert written == [outputs["budget_shown"], outputs["table1_shown"]]
    assert outputs["budget_shown"].read_text() == "\n"
    assert outputs["table1_shown"].read_text() == "dropper,std [mm]\n1,10.5\n"           # the paper's cm in mm
