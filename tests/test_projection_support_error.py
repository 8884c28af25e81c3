"""What the projection says about each span's W from where its masts are placed (issue [20]): the
uncertainty of W that the masts' registered positions cause (``w_support_std_m``), the sensor's
(``w_noise_std_m``), and the reason of a length mismatch that the mast table caused."""

import numpy as np
import pytest

from catenary.measurement.projection import ProjectionSettings, project
from catenary.measurement.recording import run_samples, validate_recording
from catenary.measurement.registration import unregistered_run

from .test_projection import synthetic_line


def _registration(recording, masts, catenary, **columns):
    """The masts as a registration of the recording's one run would give them, with ``columns``
    (a value for every mast, or a {mast_id: value} mapping) overriding the registered ones."""
    samples = run_samples(validate_recording(recording), str(validate_recording(recording)["run_id"].iloc[0]))
    run = unregistered_run(samples, masts, catenary)
    for name, value in columns.items():
        if isinstance(value, dict):
            for mast, v in value.items():
                run.masts.loc[run.masts["mast_id"] == mast, name] = v
        else:
            run.masts[name] = value
    return {run.run_id: run}


def _w(result):
    table = result.spans["N2"].set_index("span_id").sort_index()
    return table[[f"w{i}_m" for i in range(1, 10)]].to_numpy(), table


def test_a_length_mismatch_the_table_caused_names_the_mast_and_the_distance(catenary):
    # A mast the trace did not show, placed by a table 0.8 m off: its two spans are rejected, and
    # the reason names that mast as placed by the table and says how far off its span's type it
    # puts it; a mismatch between two masts the trace placed keeps the plain reason.
    recording, masts, _, _ = synthetic_line(catenary, seed=2)
    x = dict(zip(masts["mast_id"], masts["chainage_m"]))
    moved = {"M1": x["M1"] + 0.8}
    runs = _registration(recording, masts, catenary, method="height", chainage_m=moved)
    runs[next(iter(runs))].masts.loc[lambda m: m["mast_id"] == "M1", "method"] = "table"
    report = project(recording, masts, catenary, registration=runs).report.set_index("span_id")
    for span in ("M0-M1", "M1-M2"):
        reason = report.loc[span, "reason"]
        assert report.loc[span, "status"] == "rejected"
        assert "mast M1 is placed by the mast table alone" in reason, reason
    # the true span lengths differ from the type's by up to ±0.2 m (synthetic_line): 0.8 ± 0.2
    distance = float(report.loc["M0-M1", "reason"].split("alone (the trace does not show its support), ")[1][:4])
    assert 0.6 <= distance <= 1.0
    runs = _registration(recording, masts, catenary, method="height", chainage_m=moved)
    reason = project(recording, masts, catenary, registration=runs).report.set_index("span_id").loc["M0-M1", "reason"]
    assert reason.startswith("length mismatch") and "placed by the mast table" not in reason


@pytest.mark.parametrize("corr", [0.0, 1.0])
def test_the_support_error_is_what_moving_the_masts_does_to_w(catenary, corr):
    # Noise-free heights, every mast placed to ±5 cm: the stated W error is the change of W when
    # the masts move by that much — both masts of each span together when their errors are one
    # (correlation 1: a section fit that moves them together), each on its own when independent.
    # Linear in the shift up to the local fits' curvature: within 15 % (measured 0.1–8 %).
    recording, masts, _, true_h = synthetic_line(catenary, seed=3)
    recording = recording.assign(height_m=true_h)
    std = 0.05
    base = project(recording, masts, catenary, registration=_registration(recording, masts, catenary, std_m=std,
                                                                           corr_next=corr))
    w0, table = _w(base)
    stated = table["w_support_std_m"].to_numpy()
    ids = list(masts["mast_id"])
    x = dict(zip(ids, masts["chainage_m"]))
    if corr == 1.0:
        shifted = {m: x[m] + std for m in ids}
        w1, _ = _w(project(recording, masts, catenary,
                           registration=_registration(recording, masts, catenary, chainage_m=shifted)))
        moved = np.sqrt(np.mean((w1 - w0) ** 2, axis=1))
    else:
        squares = np.zeros_like(w0)
        for parity in (0, 1):
            # every other mast: each span has one end moved, its neighbours' other ends too
            shifted = {m: x[m] + std for k, m in enumerate(ids) if k % 2 == parity}
            w1, _ = _w(project(recording, masts, catenary,
                               registration=_registration(recording, masts, catenary, chainage_m=shifted)))
            squares += (w1 - w0) ** 2
        moved = np.sqrt(np.mean(squares, axis=1))
    assert np.all(stated > 0)
    np.testing.assert_allclose(stated, moved, rtol=0.15)


def test_the_noise_error_is_the_spread_of_w_over_noise_draws(catenary):
    # The same line recorded 60 times with 1 mm of noise and 1 mm quantisation: the spread of each
    # span's W over the draws is what w_noise_std_m states. 60 draws know a standard deviation to
    # 9 %; over the 4 N2 spans' mean, 4.5 %: within 12 % (measured 2.4 % low).
    recording, masts, _, true_h = synthetic_line(catenary, seed=4)
    rng = np.random.default_rng(5)
    ws, stated = [], []
    for _ in range(60):
        noisy = recording.assign(height_m=1e-3 * np.round((true_h + rng.normal(0, 1e-3, true_h.size)) / 1e-3))
        w, table = _w(project(noisy, masts, catenary, ProjectionSettings(check_cuts=False)))   # the cuts are exact
        ws.append(w)
        stated.append(table["w_noise_std_m"].to_numpy())
    spread = np.sqrt(np.mean(np.var(np.array(ws), axis=0, ddof=1), axis=1))
    assert np.mean(np.array(stated), axis=0).mean() == pytest.approx(spread.mean(), rel=0.12)
    # Without a registration no support error is stated.
    assert table["w_support_std_m"].isna().all()
