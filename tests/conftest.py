"""Shared fixtures: the project's catenary data, loaded once.

One BLAS thread per process unless the caller set one, before NumPy loads
(:mod:`catenary.plumbing.blas`; measured: the diagnosis's workers test 59.5 s with OpenBLAS's default
threads, 10.8 s with one; the restart test 34.5 s and 4.8 s), and the steady heap
(:mod:`catenary.plumbing.heap`), as the rule scripts set both where their process starts.
"""

import sys

from catenary.plumbing.blas import one_blas_thread
from catenary.plumbing.heap import steady_heap

one_blas_thread(override=False)
steady_heap()
if "numpy" in sys.modules:                 # too late for the BLAS threads: say so, do not hide it
    import warnings

    warnings.warn("tests/conftest.py: NumPy was loaded before the BLAS thread count could be set", stacklevel=1)

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest

from catenary.physics.config import load_catenary
from catenary.stages.identification.design import default_inputs

ROOT = Path(__file__).resolve().parents[1]


def workflow_dir(tmp_path: Path) -> Path:
    """A working directory of its own for one Snakemake run of a test: links to the project's
    workflow, scripts, config and data, and its own ``.snakemake`` (metadata, locks). Tests run
    on both cores (pytest-xdist); two Snakemake runs in one directory race on its lock files
    (measured: ``FileNotFoundError: .snakemake/locks/0.input.lock`` when a failure test and a
    registration test ran side by side in the project's directory)."""
    where = tmp_path / "workdir"
    where.mkdir(exist_ok=True)
    for name in ("config", "workflow", "scripts", "data", "Snakefile"):
        if not (where / name).exists():
            (where / name).symlink_to(ROOT / name)
    return where

# Paper Table 2 (N2, s_opt): means and standard deviations of the random inputs.
TABLE2_DROPPER_MEAN_M = [1.244, 1.098, 0.998, 0.945, 0.934, 0.945, 0.998, 1.098, 1.244]
TABLE2_DROPPER_SIGMA_M = [0.0067, 0.0050, 0.0045, 0.0045, 0.0038, 0.0044, 0.0035, 0.0034, 0.0070]
TABLE2_MESSENGER_TENSION_N = (20575.0, 818.0)
TABLE2_SYSTEM_HEIGHT_M = (1.388, 0.0065)


@pytest.fixture(scope="session")
def catenary():
    return load_catenary(ROOT / "config" / "catenary.yaml")


@pytest.fixture(scope="session")
def n2(catenary):
    return catenary.span_type("N2")


@pytest.fixture(scope="module")
def truth(catenary, n2):
    """Paper Table 2 laws, dropper means at the nominal table: (means, sigmas) in design order."""
    means = np.array([s.mean for s in default_inputs(n2, catenary)])
    means[9], means[10] = TABLE2_MESSENGER_TENSION_N[0], TABLE2_SYSTEM_HEIGHT_M[0]
    sigmas = np.r_[TABLE2_DROPPER_SIGMA_M, TABLE2_MESSENGER_TENSION_N[1], TABLE2_SYSTEM_HEIGHT_M[1]]
    return means, sigmas


def population_laws(spec, span_type: str) -> dict[str, tuple[float, float]]:
    """The laws a campaign's spans are drawn from: T_MW's mean and σ (the section's and the
    per-span ``messenger_tension_variability`` in quadrature) and ΔH's, by parameter name."""
    tension = spec.messenger_tension[span_type]
    spread = dict(spec.hidden_effects).get("messenger_tension_variability", {}).get("std_n", 0.0)
    height = spec.system_height[span_type]
    return {"messenger_tension_n": (tension.mean, float(np.hypot(tension.std, spread))),
            "system_height_m": (height.mean, height.std)}


def identify_line(span_type, catenary, w_m, mast_pairs, settings):
    """Identify a replicate line's W as the rule does (its settings' design, N and neighbours,
    sandwich standard errors over the spans that share a mast), without profiles: the
    likelihood, the start and the result."""
    from catenary.stages.identification.fit import identify, make_likelihood

    start = settings.start_inputs(span_type, catenary)
    lik = make_likelihood(span_type, catenary, w_m, start=start, n_samples=settings.n_samples,
                          design_method=settings.design, seed=settings.seed,
                          system_height_mode=settings.system_height_mode, neighbours=settings.neighbours)
    n = span_type.n_droppers
    result = identify(lik, start, free_means=settings.free_mean_names(n), free_sigmas=settings.random_names(n),
                      mast_pairs=mast_pairs, covariance="sandwich")
    return lik, start, result
