"""What a measuring car adds to the line it measures, as the virtual campaign plants it.

A measuring car does not write the line's true geometry against its true chainage. Each
**run** (one passage of the car: a track, a direction of travel, a day) has

* a **direction** of travel: the dynamic pass of the pantograph lags behind its position, so a
  run towards decreasing chainage does not report the heights of a run towards increasing
  chainage (the correction models each run in its own direction);
* an **odometer** that counts distance with a scale error (a wheel diameter off by 0.1–1 %),
  starts from a chainage that is offset by metres, and drifts slowly (wheel slip, temperature):
  the recorded chainage of a point ``x`` is ``x + offset + (scale − 1)·(x − x_start) + drift``,
  ``x_start`` the chainage where the run starts (the line's first mast towards increasing
  chainage, its last towards decreasing), the drift a smooth random function of the distance
  travelled (:func:`smooth_profile`);
* a **speed** that varies along the run around its mean (a smooth random profile);
* a **sensor**: noise, quantisation, drop-outs and spikes (:func:`sensor`);
* optionally the **stagger**, the lateral position of the contact point: the steady arms pull
  the CW alternately to each side, so the stagger runs linearly between supports and reverses
  at each of them (:func:`stagger_at`, the geometry the registration also reads it with).

The **mast table** the car is given (the infrastructure's database) is not the truth either: a
few masts are missing from it, a few listed ones do not exist (moved or removed), and every
chainage carries an error of some decimetres (:func:`mast_table_with_errors`).

Every draw takes its seed from the campaign file; the streams are independent of the line's
own draw, so adding runs or table errors does not change the line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["ForceChannel", "MastTableErrors", "Odometer", "RunSpec", "StaggerSpec", "Variation", "WearChannel",
           "mast_stagger",
           "mast_table_with_errors", "sensor", "smooth_profile", "stagger_at"]

#: Random Fourier features of a smooth profile (squared-exponential covariance).
_N_FEATURES = 64


def smooth_profile(x_m: np.ndarray, std: float, length_m: float, seed) -> np.ndarray:
    """A smooth random function of position with standard deviation ``std`` and correlation
    length ``length_m``, evaluated at ``x_m``.

    A stationary Gaussian process of covariance ``std² exp(−Δx² / (2 length²))``, approximated
    by 64 random Fourier features drawn from ``seed``: the same seed gives the same function,
    wherever it is evaluated (a section at a time or the whole line at once).

    Parameters
    ----------
    x_m : array_like
        Positions [m].
    std : float
        Standard deviation of the process (any unit).
    length_m : float
        Correlation length [m], > 0.
    seed : int or sequence of int
        Seed of the function.

    Returns
    -------
    numpy.ndarray
        The function at ``x_m``; zeros when ``std`` is 0.
    """
    x = np.asarray(x_m, dtype=float)
    if std == 0.0:
        return np.zeros_like(x)
    if not length_m > 0:
        raise ValueError(f"length_m: expected > 0, got {length_m}")
    rng = np.random.default_rng(seed)
    omega = rng.standard_normal(_N_FEATURES) / length_m
    phase = rng.uniform(0.0, 2.0 * np.pi, _N_FEATURES)
    return std * np.sqrt(2.0 / _N_FEATURES) * np.cos(np.multiply.outer(x, omega) + phase).sum(axis=-1)


@dataclass(frozen=True)
class Variation:
    """A smooth random variation along the run: standard deviation ``std`` (unit of the
    quantity) and correlation length ``length_m`` [m]."""

    std: float = 0.0
    length_m: float = 500.0


@dataclass(frozen=True)
class Odometer:
    """The car's odometer over one run.

    Attributes
    ----------
    offset_m : float
        Error of the recorded chainage where the run starts [m].
    scale : float
        Recorded distance per true distance (1.003: the odometer counts 0.3 % too much).
    drift : Variation
        Smooth random drift of the recorded chainage [m] with the distance travelled.
    """

    offset_m: float = 0.0
    scale: float = 1.0
    drift: Variation = Variation()

    def recorded(self, x_m: np.ndarray, start_m: float, seed) -> np.ndarray:
        """Recorded chainage of the true chainages ``x_m`` for a run starting at ``start_m`` [m]."""
        x = np.asarray(x_m, dtype=float)
        travelled = np.abs(x - start_m)
        return (x + self.offset_m + (self.scale - 1.0) * (x - start_m)
                + smooth_profile(travelled, self.drift.std, self.drift.length_m, seed))

    @property
    def exact(self) -> bool:
        return self.offset_m == 0.0 and self.scale == 1.0 and self.drift.std == 0.0


@dataclass(frozen=True)
class RunSpec:
    """One run of the measuring car.

    Attributes
    ----------
    run_id : str
    direction : int
        +1 towards increasing chainage, -1 towards decreasing.
    seed : int or None
        Seed of the run's sensor noise, speed, force and drift streams; None: the campaign's
        single default run (the stream of the campaigns made before several runs existed).
    odometer : Odometer
    speed_variation : Variation
        Around the measurement's ``speed_kmh`` [km/h].
    force_variation : Variation
        Fluctuation of the regulated uplift force around its static value [N].
    force_n : float or None
        Static force the car is set to for this run [N] (declared as such in the recording's
        ``force_n``); None: the measurement's.
    """

    run_id: str = "campaign"
    direction: int = 1
    seed: int | None = None
    odometer: Odometer = Odometer()
    speed_variation: Variation = Variation()
    force_variation: Variation = Variation()
    force_n: float | None = None

    def stream(self, *key: int) -> list[int]:
        """Seed of one of the run's random streams, ``key`` naming the purpose."""
        return [*key] if self.seed is None else [*key, 7919, int(self.seed)]


@dataclass(frozen=True)
class WearChannel:
    """The car's wear channel: the CW's residual thickness, read with ``noise_std_m`` per sample,
    an error ``span_std_m`` of each span's reading in each run (the sensor's local response) and
    one ``run_bias_std_m`` per run (its calibration), quantised to ``quantisation_m`` [m]."""

    noise_std_m: float = 9.0e-5
    span_std_m: float = 3.0e-5
    run_bias_std_m: float = 9.0e-5
    quantisation_m: float = 1.0e-5


@dataclass(frozen=True)
class ForceChannel:
    """The car's contact-force channel: the simulated contact force read with ``noise_std_n`` per
    sample and one ``run_bias_std_n`` per run (the load cells' calibration) [N]."""

    noise_std_n: float = 5.0
    run_bias_std_n: float = 1.0


@dataclass(frozen=True)
class StaggerSpec:
    """The stagger the car records: ``amplitude_m`` at the steady arms (alternating sides, each
    mast's value varying by ``amplitude_std_m``), measured with noise ``noise_std_m`` [m]."""

    amplitude_m: float = 0.2
    amplitude_std_m: float = 0.02
    noise_std_m: float = 0.002


@dataclass(frozen=True)
class MastTableErrors:
    """Errors of the mast table the campaign writes.

    Attributes
    ----------
    position_error_m : float
        Every listed chainage is off by a uniform error in ±this [m].
    missing : int
        Masts left out of the table (drawn among the masts inside the sections).
    extra : int
        Masts listed that do not exist (each in the middle of a span drawn at random).
    seed : int
    """

    position_error_m: float = 0.0
    missing: int = 0
    extra: int = 0
    seed: int = 0


def mast_stagger(n_masts: int, spec: StaggerSpec, seed) -> np.ndarray:
    """Stagger at each steady arm [m]: alternating sides, amplitude ``spec.amplitude_m`` ± its
    spread."""
    rng = np.random.default_rng(seed)
    sides = np.where(np.arange(n_masts) % 2 == 0, 1.0, -1.0)
    return sides * (spec.amplitude_m + spec.amplitude_std_m * rng.standard_normal(n_masts))


def stagger_at(x_m: np.ndarray, support_x_m: np.ndarray, support_stagger_m: np.ndarray) -> np.ndarray:
    """Stagger of the CW at chainages ``x_m`` [m]: linear between consecutive supports (the CW
    is straight in plan between the steady arms that pull it aside), so it reverses at each.

    This is the geometry the campaign draws the stagger with and the registration reads the
    supports from (:mod:`catenary.measurement.registration.supports`).
    """
    return np.interp(np.asarray(x_m, dtype=float), support_x_m, support_stagger_m)


def sensor(chainage_m: np.ndarray, height_m: np.ndarray, noise_std_m: float, quantisation_m: float,
           dropout_rate_per_km: float, dropout_length_m: float, spike_rate_per_km: float, spike_height_m: float,
           rng: np.random.Generator) -> np.ndarray:
    """Recorded heights: noise, quantisation, drop-outs (NaN runs) and single-sample spikes [m]."""
    h = height_m + noise_std_m * rng.standard_normal(height_m.size)
    if quantisation_m > 0:
        h = quantisation_m * np.round(h / quantisation_m)
    length_km = (chainage_m[-1] - chainage_m[0]) / 1e3
    for start in rng.uniform(chainage_m[0], chainage_m[-1], rng.poisson(dropout_rate_per_km * length_km)):
        h[(chainage_m >= start) & (chainage_m < start + dropout_length_m)] = np.nan
    n_spikes = rng.poisson(spike_rate_per_km * length_km)
    where = rng.integers(0, h.size, n_spikes)
    h[where] += spike_height_m * rng.choice([-1.0, 1.0], n_spikes)
    return h


def mast_table_with_errors(masts: pd.DataFrame, errors: MastTableErrors) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The mast table as the infrastructure's database holds it, and what it did to each mast.

    Parameters
    ----------
    masts : pandas.DataFrame
        The true masts file (``mast_id``, ``chainage_m``, ``section_id``, ``span_type``).
    errors : MastTableErrors

    Returns
    -------
    table : pandas.DataFrame
        The same columns, with ``errors.missing`` inner masts left out, ``errors.extra`` masts
        that do not exist added (ids ``X001``…, in the middle of a span, with the span's type)
        and every chainage moved by a uniform error in ±``position_error_m``.
    truth : pandas.DataFrame
        One row per mast of the line or of the table: ``mast_id``, ``section_id``,
        ``chainage_m`` (true; NaN for a mast that does not exist), ``table_chainage_m`` (NaN
        when left out) and ``status``: ``listed``, ``missing_from_table``, ``extra_in_table``.
    """
    rng = np.random.default_rng([errors.seed, 424242])
    m = masts.reset_index(drop=True)
    section = m["section_id"].to_numpy(dtype=object)
    inner = np.flatnonzero((np.r_[False, section[1:] == section[:-1]]) & (np.r_[section[:-1] == section[1:], False]))
    if errors.missing > inner.size:
        raise ValueError(f"missing: {errors.missing} masts asked, only {inner.size} inner masts")
    missing = np.sort(rng.choice(inner, errors.missing, replace=False)) if errors.missing else np.zeros(0, int)
    spans = np.flatnonzero(section[:-1] == section[1:])
    extra_after = np.sort(rng.choice(spans, errors.extra, replace=False)) if errors.extra else np.zeros(0, int)
    rows = []
    for i in range(len(m)):
        listed = i not in set(missing.tolist())
        rows.append({"mast_id": m.loc[i, "mast_id"], "section_id": m.loc[i, "section_id"],
                     "span_type": m.loc[i, "span_type"], "chainage_m": float(m.loc[i, "chainage_m"]),
                     "status": "listed" if listed else "missing_from_table", "order": float(i)})
    for k, i in enumerate(extra_after):
        x = 0.5 * (m.loc[i, "chainage_m"] + m.loc[i + 1, "chainage_m"]) + rng.uniform(-5.0, 5.0)
        rows.append({"mast_id": f"X{k + 1:03d}", "section_id": m.loc[i, "section_id"],
                     "span_type": m.loc[i, "span_type"], "chainage_m": float("nan"), "table_x": x,
                     "status": "extra_in_table", "order": i + 0.5})
    truth = pd.DataFrame(rows).sort_values("order", kind="stable").reset_index(drop=True)
    in_table = truth["status"] != "missing_from_table"
    base = truth["chainage_m"].where(truth["status"] != "extra_in_table", truth.get("table_x"))
    error = rng.uniform(-1.0, 1.0, len(truth)) * errors.position_error_m
    truth["table_chainage_m"] = np.where(in_table, base + error, np.nan)
    table = truth.loc[in_table, ["mast_id", "section_id", "span_type"]].copy()
    table["chainage_m"] = truth.loc[in_table, "table_chainage_m"].round(4)
    table = table[["mast_id", "chainage_m", "section_id", "span_type"]].reset_index(drop=True)
    truth = truth[["mast_id", "section_id", "chainage_m", "table_chainage_m", "status"]]
    return table, truth
