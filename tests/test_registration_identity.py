"""When a trace's supports say the recording's chainage is already right: the identity test of
:func:`catenary.measurement.registration.runner._agrees_with_identity`, on supports built to the figures
measured on the default campaign's height trace (exact odometer and mast table)."""

import numpy as np
import pytest

from catenary.measurement.registration.runner import _agrees_with_identity
from catenary.measurement.registration.settings import RegistrationSettings

#: A section as the default campaign's S08: 21 masts 54 m apart, 18 placed by the height.
TABLE_M = 8274.5 + 54.0 * np.arange(21)


def _supports(bias_start_m, bias_end_m, scatter_m, seed, offset_m=0.0, scale=1.0):
    """Supports along a line of lag bias from ``bias_start_m`` at the first confirmed mast to
    ``bias_end_m`` at the last, scattered about it by exactly ``scatter_m`` RMS (the scatter
    drawn, then made orthogonal to the line and scaled, so that every seed has S08's figures)."""
    rng = np.random.default_rng(seed)
    listed = np.ones(TABLE_M.size, dtype=bool)
    listed[[0, 3, 20]] = False                       # three masts the trace did not confirm
    x = TABLE_M[listed]
    u = (TABLE_M - x[0]) / np.ptp(x)
    a = np.column_stack([np.ones(x.size), x - x.mean()])
    noise = rng.standard_normal(x.size)
    noise -= a @ np.linalg.lstsq(a, noise, rcond=None)[0]
    scatter = np.zeros(TABLE_M.size)
    scatter[listed] = scatter_m * noise / np.sqrt(np.mean(noise ** 2))
    truth = offset_m + TABLE_M[0] + scale * (TABLE_M - TABLE_M[0])
    return truth + bias_start_m * (1 - u) + bias_end_m * u + scatter, listed


@pytest.mark.parametrize("seed", range(5))
def test_a_height_trace_biased_by_its_lag_keeps_an_exact_chainage(seed):
    # The height-placed supports of S08 lay −0.28 m from the truth at its first confirmed mast
    # and −0.07 m at its last, 0.12 m RMS about that line: within the lag's uncertainty (0.2 m
    # at each end), so the recording's chainage, exact here, is kept. With the lag as one offset
    # error of 0.1 m the test rejected it (χ² ≈ 7 > 5.99) and mapped the section off by 0.34 m;
    # without any lag it would be rejected far more.
    position, listed = _supports(-0.28, -0.07, 0.12, seed)
    methods = np.full(TABLE_M.size, "height")
    assert _agrees_with_identity(TABLE_M, position, listed, methods, RegistrationSettings())
    assert not _agrees_with_identity(TABLE_M, position, listed, methods,
                                     RegistrationSettings(height_lag_std_m=0.0))


@pytest.mark.parametrize("seed", range(5))
def test_an_odometer_off_by_a_tenth_of_a_percent_is_mapped(seed):
    # 0.1 % over the section's 1 080 m is 1.08 m, four times what the lag can hide at its ends:
    # the map is fitted, with the same lag bias and scatter as above.
    position, listed = _supports(-0.28, -0.07, 0.12, seed, scale=1.001)
    methods = np.full(TABLE_M.size, "height")
    assert not _agrees_with_identity(TABLE_M, position, listed, methods, RegistrationSettings())
    position, listed = _supports(0.0, 0.0, 0.12, seed, offset_m=0.6)
    assert not _agrees_with_identity(TABLE_M, position, listed, methods, RegistrationSettings())


def test_the_stagger_has_no_lag_to_hide_an_offset():
    # The stagger's reversals are where the masts are: the same 0.21 m trend is an odometer's.
    position, listed = _supports(-0.28, -0.07, 0.02, 0)
    assert not _agrees_with_identity(TABLE_M, position, listed, np.full(TABLE_M.size, "stagger"),
                                     RegistrationSettings())
