"""Physical effects beyond the identification's base model: the one place each effect's physics lives.

The virtual campaign plants these effects in its truth (:func:`catenary.measurement.truth.draw_line`), and
the discrepancy workflow (:mod:`catenary.stages.diagnosis`) offers the same functions as candidate
extensions of the identification model: the campaign calls :func:`plant` with a seeded
generator, the diagnosis calls each effect's ``apply`` with standard normal scores taken from
its sampling design. Truth and candidate can therefore never drift apart.

Each effect acts on a table of per-span parameters (:class:`SpanParameters`), is parameterised
by magnitudes named in the truth file (SI units), vanishes at its null magnitudes (all 0), and
takes standard normal draws of one kind (:attr:`Effect.draw`): one per span, per section, per
mast, per dropper, or none.

``messenger_tension_variability`` (``std_n``; per span)
    Each span's MW tension deviates from its section's regulated tension by a zero-mean
    normal amount (friction at the cantilevers and pulleys, temperature differences along the
    section): ``T_MW += std_n z``.
``contact_tension_variability`` (``std_n``; per section)
    Each section's CW tension deviates from the design one (tensioning weights, friction in
    the balance weight): ``T_CW += std_n z``, common to the spans of the section.
``dropper_creep`` (``mean_m``, ``std_m``; per span)
    A common offset of all dropper lengths of a span (creep of the dropper wires, or a
    systematic cutting error of that span's dropper batch): ``L_i += mean_m + std_m z``.
``system_height_dropper_correlation`` (``gain``; no draw)
    The end droppers follow the system height at their mast: the dropper next to a mast is
    lengthened by ``gain`` × (ΔH at that mast − the ΔH law's mean), as fitters adjust the first
    dropper to the measured system height (paper §4.2).
``measuring_force_offset`` (``force_n``; no draw)
    The measuring pantograph pushes ``force_n`` more than the declared force. The correction
    removes the uplift of the declared force, so the corrected W keeps the uplift of the
    excess: ``force_n`` times the measured height's sensitivity to the force at the droppers
    (:func:`catenary.physics.measuring.force_influence`).
``cw_longitudinal_offset`` (``mean_m``, ``std_m``; per span)
    The CW is shifted along the line relative to the MW (thermal expansion of wires regulated
    from different anchors, or droppers fitted off the design position): every dropper of a
    span is inclined, its CW clamp ``δ = mean_m + std_m z`` from its MW clamp. The droppers'
    geometry is :func:`catenary.physics.section.inclined_dropper` (second order in δ through the
    vertical rest length, first order through the clamp position).
``steady_arm_height_difference`` (``std_m``; per mast)
    Each steady arm holds the CW ``std_m z`` higher than designed, the MW moving with it (ΔH
    kept), so the two ends of a span differ in height. The projection onto the chord between
    the steady arms removes it (paper Fig. 3): a negative control for the diagnosis.
``contact_wire_wear`` (``mean_fraction``, ``std_fraction``; per span)
    The CW loses a fraction ``ε = mean_fraction + std_fraction z`` of its section by wear (the
    pantograph strips abrade it; wear limits are 20–30 % of the section). Its weight per
    metre falls by the same fraction (its bending stiffness, negligible for W, is kept): the
    droppers carry less, the MW sags less. Its signature is close to a T_MW change: both
    change the MW's load-to-tension ratio.

``dropper_faults`` (``fraction``, ``min_m``, ``max_m``; per dropper)
    A fraction of the droppers made or fitted wrong: each dropper independently, with
    probability ``fraction``, is longer or shorter (equally likely) than its drawn length by a
    uniform ``min_m``–``max_m``. From its normal score ``z``: ``u = Φ(z) < fraction`` marks it,
    ``v = u / fraction`` gives the sign (``v < ½``: longer) and the size (``2v mod 1``), each
    uniform and independent of the others. A central dropper a centimetre or two too long goes
    slack. Not a diagnosis candidate (a few droppers do not change the laws' form): the
    maintenance stage looks for it, span by span (:mod:`catenary.stages.maintenance`).

All magnitudes are SI. Effects are applied in the order listed in the truth file.

Effects of your own
-------------------
A user's effect is a function of the same form in a module of the user's own, listed in the
config (``effects_modules``; a campaign lists its planting code in its truth file's
``effects_modules``). The module defines ``EFFECTS``, a list of :class:`Effect` with their
:class:`EffectParameter` declarations (bounds, scale, realistic size, unit); :func:`load_modules`
registers them beside the built-ins. Besides every parameter above, an effect can act where real
ones do between the droppers: :meth:`SpanParameters.add_cw_point_masses` clamps concentrated
masses on the CW (connectors, splices, section insulators), which the FE models carry (the
campaign's measuring pass, the per-span tests of :mod:`catenary.stages.diagnosis.span_effects`). An
effect of ``scope="span"`` is a local anomaly: the diagnosis fits its magnitudes span by span on
the spans the final model does not explain; one of ``scope="population"`` is tested on the law of
W like the built-ins (the fast model then must carry what it changes: point masses it does not).
"""

from __future__ import annotations

import importlib.util
import inspect
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from scipy import special

from catenary.plumbing.errors import ConfigError

__all__ = ["DRAW_KINDS", "EFFECTS", "PARAMETER_KINDS", "SCOPES", "Effect", "EffectParameter", "SpanParameters",
           "draws_for", "load_modules", "plant"]

#: What one standard normal draw of an effect belongs to.
DRAW_KINDS = ("span", "section", "mast", "dropper")


@dataclass
class SpanParameters:
    """Mutable per-span and per-section parameters of a line (or of a model sample).

    In a model sample every sample is a span of its own section with masts of its own
    (``section_index = arange(N)``, ``left_mast = 2 arange(N)``).

    Attributes
    ----------
    dropper_lengths_m : numpy.ndarray
        (n_spans, n_droppers) unstretched dropper lengths [m].
    system_height_left_m, system_height_right_m : numpy.ndarray
        ΔH at each span's left and right mast [m].
    system_height_mean_m : numpy.ndarray
        Mean of the ΔH law of each span's type [m].
    messenger_tension_n, contact_tension_n : numpy.ndarray
        Per-span tensions [N] (equal within a section unless an effect changes them).
    section_index : numpy.ndarray
        Section of each span.
    measuring_force_n : float
        Force the measuring pantograph really applies [N].
    creep_offset_m : numpy.ndarray
        Common dropper-length offset planted in each span [m] (0 without creep).
    cw_offset_m : numpy.ndarray
        Longitudinal offset of each span's CW clamps from its MW clamps [m] (0: vertical droppers).
    left_mast : numpy.ndarray
        Index of each span's left mast (its right mast is the next one).
    mast_cw_height_offset_m : numpy.ndarray
        Raise of the CW (and the MW with it) at each mast's steady arm above its drawn height [m].
    cw_wear_fraction : numpy.ndarray
        Fraction of each span's CW section lost by wear (0: new wire).
    cw_point_mass_x_m, cw_point_mass_kg : numpy.ndarray
        (n_spans, k) concentrated masses clamped on each span's CW: position from the span's left
        mast [m] and mass [kg] (0: none; k = 0 without any, :meth:`add_cw_point_masses`).
    span_length_m : numpy.ndarray or None
        Length of each span [m] (where an effect places something along it).
    dropper_x_m : numpy.ndarray or None
        (n_spans, n_droppers) design positions of each span's droppers from its left mast [m].
    """

    dropper_lengths_m: np.ndarray
    system_height_left_m: np.ndarray
    system_height_right_m: np.ndarray
    system_height_mean_m: np.ndarray
    messenger_tension_n: np.ndarray
    contact_tension_n: np.ndarray
    section_index: np.ndarray
    measuring_force_n: float
    creep_offset_m: np.ndarray
    cw_offset_m: np.ndarray
    left_mast: np.ndarray
    mast_cw_height_offset_m: np.ndarray
    cw_wear_fraction: np.ndarray
    cw_point_mass_x_m: np.ndarray | None = None
    cw_point_mass_kg: np.ndarray | None = None
    span_length_m: np.ndarray | None = None
    dropper_x_m: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.n_spans
        if self.cw_point_mass_kg is None or self.cw_point_mass_x_m is None:
            self.cw_point_mass_x_m = np.zeros((n, 0))
            self.cw_point_mass_kg = np.zeros((n, 0))

    def add_cw_point_masses(self, x_m: np.ndarray, mass_kg: np.ndarray) -> None:
        """Clamp one more concentrated mass on each span's CW: at ``x_m`` from its left mast [m],
        of ``mass_kg`` [kg] (0 where a span gets none); arrays of one value per span."""
        n = self.n_spans
        x = np.broadcast_to(np.asarray(x_m, dtype=float), (n,))
        m = np.broadcast_to(np.asarray(mass_kg, dtype=float), (n,))
        if np.any(~np.isfinite(m)) or np.any(m < 0) or np.any(~np.isfinite(x[m > 0])):
            raise ValueError("add_cw_point_masses: expected finite masses ≥ 0 [kg] at finite positions [m]")
        self.cw_point_mass_x_m = np.column_stack([self.cw_point_mass_x_m, np.where(m > 0, x, 0.0)])
        self.cw_point_mass_kg = np.column_stack([self.cw_point_mass_kg, m])

    @property
    def has_point_masses(self) -> bool:
        return bool(np.any(self.cw_point_mass_kg > 0))

    @classmethod
    def independent_spans(cls, dropper_lengths_m: np.ndarray, messenger_tension_n: np.ndarray,
                          system_height_left_m: np.ndarray, system_height_right_m: np.ndarray, *,
                          system_height_mean_m: float, contact_tension_n: float,
                          measuring_force_n: float, span_length_m: float | None = None,
                          dropper_x_m: np.ndarray | None = None) -> "SpanParameters":
        """N spans each in a section of its own, with masts of its own (a model sample)."""
        lengths = np.asarray(dropper_lengths_m, dtype=float)
        n = lengths.shape[0]
        return cls(dropper_lengths_m=lengths, system_height_left_m=np.asarray(system_height_left_m, dtype=float),
                   system_height_right_m=np.asarray(system_height_right_m, dtype=float),
                   system_height_mean_m=np.full(n, float(system_height_mean_m)),
                   messenger_tension_n=np.asarray(messenger_tension_n, dtype=float),
                   contact_tension_n=np.full(n, float(contact_tension_n)), section_index=np.arange(n),
                   measuring_force_n=float(measuring_force_n), creep_offset_m=np.zeros(n), cw_offset_m=np.zeros(n),
                   left_mast=2 * np.arange(n), mast_cw_height_offset_m=np.zeros(2 * n), cw_wear_fraction=np.zeros(n),
                   span_length_m=None if span_length_m is None else np.full(n, float(span_length_m)),
                   dropper_x_m=None if dropper_x_m is None else np.tile(np.asarray(dropper_x_m, dtype=float), (n, 1)))

    @property
    def n_spans(self) -> int:
        return int(self.dropper_lengths_m.shape[0])

    @property
    def n_sections(self) -> int:
        return int(self.section_index.max()) + 1 if self.section_index.size else 0

    @property
    def n_masts(self) -> int:
        return int(self.mast_cw_height_offset_m.size)

    @property
    def cw_height_offset_left_m(self) -> np.ndarray:
        return self.mast_cw_height_offset_m[self.left_mast]

    @property
    def cw_height_offset_right_m(self) -> np.ndarray:
        return self.mast_cw_height_offset_m[self.left_mast + 1]


def messenger_tension_variability(p: SpanParameters, z: np.ndarray, *, std_n: float) -> None:
    p.messenger_tension_n = p.messenger_tension_n + std_n * z


def contact_tension_variability(p: SpanParameters, z: np.ndarray, *, std_n: float) -> None:
    p.contact_tension_n = p.contact_tension_n + (std_n * z)[p.section_index]


def dropper_creep(p: SpanParameters, z: np.ndarray, *, mean_m: float, std_m: float = 0.0) -> None:
    offset = mean_m + std_m * z
    p.creep_offset_m = p.creep_offset_m + offset
    p.dropper_lengths_m = p.dropper_lengths_m + offset[:, None]


def system_height_dropper_correlation(p: SpanParameters, z: None, *, gain: float) -> None:
    lengths = p.dropper_lengths_m.copy()
    n = np.sum(np.isfinite(lengths), axis=1) - 1          # last dropper of each span (types may differ)
    rows = np.arange(lengths.shape[0])
    lengths[:, 0] += gain * (p.system_height_left_m - p.system_height_mean_m)
    lengths[rows, n] += gain * (p.system_height_right_m - p.system_height_mean_m)
    p.dropper_lengths_m = lengths


def measuring_force_offset(p: SpanParameters, z: None, *, force_n: float) -> None:
    p.measuring_force_n = p.measuring_force_n + force_n


def cw_longitudinal_offset(p: SpanParameters, z: np.ndarray, *, mean_m: float, std_m: float = 0.0) -> None:
    p.cw_offset_m = p.cw_offset_m + mean_m + std_m * z


def steady_arm_height_difference(p: SpanParameters, z: np.ndarray, *, std_m: float) -> None:
    p.mast_cw_height_offset_m = p.mast_cw_height_offset_m + std_m * z


def contact_wire_wear(p: SpanParameters, z: np.ndarray, *, mean_fraction: float, std_fraction: float = 0.0) -> None:
    p.cw_wear_fraction = p.cw_wear_fraction + mean_fraction + std_fraction * z


def dropper_faults(p: SpanParameters, z: np.ndarray, *, fraction: float, min_m: float, max_m: float) -> None:
    if not (0.0 <= fraction < 1.0 and 0.0 <= min_m <= max_m):
        raise ValueError(f"dropper_faults: expected 0 ≤ fraction < 1 and 0 ≤ min_m ≤ max_m, got {fraction}, "
                         f"{min_m}, {max_m}")
    u = special.ndtr(z.reshape(p.dropper_lengths_m.shape))
    faulty = u < fraction
    v = np.where(faulty, u / max(fraction, 1e-300), 0.0)
    size = min_m + (max_m - min_m) * np.mod(2.0 * v, 1.0)
    p.dropper_lengths_m = p.dropper_lengths_m + np.where(faulty, np.where(v < 0.5, size, -size), 0.0)


#: Kinds of an effect's parameter: a spread (σ ≥ 0, null on the boundary), a signed shift (null
#: 0 inside), a position along the span (no null: read only where the effect is not null).
PARAMETER_KINDS = ("spread", "shift", "position")
#: Where the diagnosis tests an effect: on the law of W of the whole population, or span by span.
SCOPES = ("population", "span")


@dataclass(frozen=True)
class EffectParameter:
    """One magnitude of an effect, as the diagnosis fits and reports it.

    Attributes
    ----------
    name : str
        The magnitude's keyword in the effect's function (``std_n``, ``mean_m``…).
    kind : {"spread", "shift", "position"}
    bounds : (float, float)
        Allowed range [SI]; the null 0 lies inside (a spread's on its lower edge) unless a position.
    scale : float
        Typical size [SI]: the optimiser's unit and the finite-difference scale.
    realistic : float
        A realistic magnitude on a high-speed line [SI] (the size the validation plants).
    unit : str
        Unit for reports (``N``, ``m``, ``kg``, ``-``).
    label : str
        What it is, in words, for reports.
    """

    name: str
    kind: str
    bounds: tuple[float, float]
    scale: float
    realistic: float
    unit: str
    label: str

    def __post_init__(self):
        if self.kind not in PARAMETER_KINDS:
            raise ValueError(f"{self.name}: kind must be one of {PARAMETER_KINDS}, got {self.kind!r}")
        lo, hi = self.bounds
        if not lo < hi:
            raise ValueError(f"{self.name}: bounds {self.bounds} must be ordered")
        if self.kind != "position" and (not (lo <= 0.0 <= hi) or (self.kind == "spread" and lo != 0.0)):
            raise ValueError(f"{self.name}: bounds {self.bounds} must contain the null 0 (a spread's as lower bound)")
        if not self.scale > 0:
            raise ValueError(f"{self.name}: scale must be > 0, got {self.scale}")


@dataclass(frozen=True)
class Effect:
    """A physical effect: its function, the draws it takes and its magnitudes.

    Attributes
    ----------
    name : str
    apply : callable
        ``apply(p, z, **magnitudes)``: changes the :class:`SpanParameters` ``p`` in place;
        ``z`` holds standard normal scores, ``n_draws`` per span, section, mast or dropper
        (``draw``; shape (items,) for one, (items, n_draws) for more), or None.
    draw : str or None
        One of :data:`DRAW_KINDS`, or None for an effect without randomness.
    n_draws : int
        Standard normal scores per item of ``draw``.
    parameters : tuple of EffectParameter
        How the diagnosis fits the magnitudes (a user's effect declares them here; the built-ins'
        are :data:`catenary.stages.diagnosis.candidates.CANDIDATES`).
    scope : {"population", "span"}
        Where the diagnosis tests it (:data:`SCOPES`).
    summary : str
        One line of physics for reports.
    """

    name: str
    apply: Callable[..., None]
    draw: str | None
    n_draws: int = 1
    parameters: tuple[EffectParameter, ...] = field(default=())
    scope: str = "population"
    summary: str = ""

    def __post_init__(self):
        if self.draw not in (*DRAW_KINDS, None):
            raise ValueError(f"effect {self.name}: draw must be one of {DRAW_KINDS} or None, got {self.draw!r}")
        if self.scope not in SCOPES:
            raise ValueError(f"effect {self.name}: scope must be one of {SCOPES}, got {self.scope!r}")
        if int(self.n_draws) != self.n_draws or self.n_draws < 1:
            raise ValueError(f"effect {self.name}: n_draws must be an integer ≥ 1, got {self.n_draws!r}")
        declared = {p.name for p in self.parameters}
        unknown = declared - set(self.magnitudes)
        if unknown:
            raise ValueError(f"effect {self.name}: parameters {sorted(unknown)} are not keywords of its function")

    @property
    def magnitudes(self) -> tuple[str, ...]:
        """Keyword names of the magnitudes."""
        return tuple(k for k, q in inspect.signature(self.apply).parameters.items()
                     if q.kind is inspect.Parameter.KEYWORD_ONLY)

    @property
    def required(self) -> tuple[str, ...]:
        """Magnitudes without a default."""
        params = inspect.signature(self.apply).parameters
        return tuple(k for k in self.magnitudes if params[k].default is inspect.Parameter.empty)


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("messenger_tension_variability", messenger_tension_variability, "span"),
    Effect("contact_tension_variability", contact_tension_variability, "section"),
    Effect("dropper_creep", dropper_creep, "span"),
    Effect("system_height_dropper_correlation", system_height_dropper_correlation, None),
    Effect("measuring_force_offset", measuring_force_offset, None),
    Effect("cw_longitudinal_offset", cw_longitudinal_offset, "span"),
    Effect("steady_arm_height_difference", steady_arm_height_difference, "mast"),
    Effect("contact_wire_wear", contact_wire_wear, "span"),
    Effect("dropper_faults", dropper_faults, "dropper"),
)}


def draws_for(kind: str | None, p: SpanParameters) -> int:
    """Number of items an effect of draw ``kind`` takes standard normal draws for in ``p``."""
    return {"span": p.n_spans, "section": p.n_sections, "mast": p.n_masts,
            "dropper": int(p.dropper_lengths_m.size), None: 0}[kind]


def plant(name: str, p: SpanParameters, rng: np.random.Generator, magnitudes: dict[str, float]) -> None:
    """Draw the effect's standard normal scores from ``rng`` and apply it (the campaign's way)."""
    effect = EFFECTS[name]
    z = None
    if effect.draw:
        items = draws_for(effect.draw, p)
        z = rng.standard_normal(items) if effect.n_draws == 1 else rng.standard_normal((items, effect.n_draws))
    effect.apply(p, z, **magnitudes)


_LOADED: dict[str, tuple[str, ...]] = {}


#: Modules a plug-in written before the package's layers (issue [19]) may import, and where they are.
_MOVED = {"catenary.effects": "catenary.physics.effects", "catenary.config": "catenary.physics.config",
          "catenary.errors": "catenary.plumbing.errors"}


def load_modules(paths, where: str = "effects_modules") -> tuple[str, ...]:
    """Register the effects of users' modules (their ``EFFECTS`` lists) beside the built-ins.

    Parameters
    ----------
    paths : iterable of str or pathlib.Path
        Python files, each defining ``EFFECTS``: a list of :class:`Effect`.
    where : str
        The config key that lists them (for messages).

    Returns
    -------
    tuple of str
        The names registered (a module loaded before registers nothing again).

    Raises
    ------
    ConfigError
        A file missing, without ``EFFECTS``, or naming an effect already known.
    """
    out: list[str] = []
    for i, raw in enumerate(paths or []):
        path = Path(raw).resolve()
        if str(path) in _LOADED:
            out += _LOADED[str(path)]
            continue
        if not path.is_file():
            raise ConfigError(f"{where}[{i}]: {raw}: no such file; expected a Python module defining EFFECTS")
        name = f"catenary_user_effects_{len(_LOADED)}_{path.stem}"
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except ModuleNotFoundError as exc:
            if exc.name not in _MOVED:
                raise
            raise ConfigError(f"{where}[{i}]: {raw}: imports {exc.name}, which the package's layers moved to "
                              f"{_MOVED[exc.name]} (docs/layout.md); import Effect and EffectParameter from "
                              f"there") from None
        effects = getattr(module, "EFFECTS", None)
        if not isinstance(effects, (list, tuple)) or not all(isinstance(e, Effect) for e in effects):
            raise ConfigError(f"{where}[{i}]: {raw}: expected a module-level list EFFECTS of catenary.physics.effects.Effect")
        names = []
        for effect in effects:
            if effect.name in EFFECTS:
                raise ConfigError(f"{where}[{i}]: {raw}: effect {effect.name!r} is known already "
                                  f"({', '.join(EFFECTS)})")
            EFFECTS[effect.name] = effect
            names.append(effect.name)
        _LOADED[str(path)] = tuple(names)
        out += names
    return tuple(out)
