"""Settings of the diagnosis rule, read from the ``diagnosis`` block of the config.

Every key is documented in ``docs/configuration.md`` and checked against the ``diagnosis`` block of
the shipped config schema (:mod:`catenary.plumbing.schema`). The base model's laws, ΔH mode, design
method and likelihood come from the ``identification`` block; the diagnosis's ``start`` says
which inputs are random, which means are free, the span model and the effects the starting
model already has. The default start is the paper's first attempt: dropper lengths and ΔH
random, T_MW deterministic (its mean free), so that the diagnosis must find the tension spread.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from catenary.plumbing.errors import ConfigError
from catenary.plumbing.schema import check, merged_mapping
from catenary.stages.identification.settings import IdentificationSettings
from .candidates import CANDIDATES, known
from .profile_check import ProfileSettings
from .span_check import SpanCheckSettings

__all__ = ["DiagnosisSettings"]


def _span_check(block: Mapping[str, Any], raw: Mapping[str, Any]) -> SpanCheckSettings:
    """``diagnosis.spans`` as :class:`SpanCheckSettings` (its profile keys in its ``profile``;
    one seed for both, the profile's calibration offset by one)."""
    profile_keys = {f.name for f in dataclasses.fields(ProfileSettings)}
    profile = {k: v for k, v in block.items() if k in profile_keys and k != "seed"}
    check_keys = {f.name for f in dataclasses.fields(SpanCheckSettings)} - {"profile", "fdr", "level",
                                                                            "fault_probability"}
    rest = {k: v for k, v in block.items() if k in check_keys}
    return SpanCheckSettings(**rest, fdr=raw["fdr"], level=raw["level"],
                             profile=ProfileSettings(**profile, seed=int(block.get("seed", 23)) + 1))


@dataclass(frozen=True)
class DiagnosisSettings:
    """What the diagnosis rule does for each span type (config block ``diagnosis``).

    Attributes
    ----------
    random_inputs, free_means : tuple of str
        The starting model's random inputs and free means (names as in the identification).
    neighbours : int
        Span model of the start (0 pinned, 1 in the line).
    start_effects : tuple of str
        Candidate effects the starting model already has (fitted from their null).
    candidates : tuple of str
        Candidates tried at each step (those already in the model are skipped).
    level : float
        Family-wise level of the tests (Bonferroni over the candidates of a step).
    bic_margin : float
        The leading candidate is named only if the runner-up's BIC is at least this much
        higher (6: "strong" evidence on the scale of Kass & Raftery, 2 ln Bayes factor).
    max_steps : int
        Forward-selection steps at most.
    power : float
        Power at which the detectable magnitudes are stated.
    n_samples : int
        Design size N (the same for every model of a step).
    seed : int
        Seed of the design; ``seed + 1`` draws the bootstrap's i.i.d. model spans.
    bootstrap_replicates : int
        Data sets in the eigenvalue bootstrap.
    max_evaluations : int
        J evaluations of each refit at most.
    optimiser : {"fisher-scoring", "nelder-mead"}
        Each candidate's refit (:func:`.problem.refit`): Fisher scoring, with Nelder–Mead where
        it cannot certify its maximum, or Nelder–Mead alone. The starting model is fitted by
        Nelder–Mead with the identification's tolerances: every Δℓ is measured from its J.
    xtol, ftol : float
        Convergence tolerances of each candidate's refit: the scoring stops on a full step
        predicted to gain less than ``ftol``; Nelder–Mead when its simplex lies within ``xtol``
        in θ and ``ftol`` in J. The test needs Δℓ to about 0.1; at 0.1 and 0.01 every refit of
        the default campaign ended within 0.07 of its Δℓ at 0.01 and 0.001, with 26 % (N2) and
        39 % (N3) fewer evaluations of J (docs/diagnosis.md, "The refits").
    fdr : float
        False-discovery rate of the per-span check (:mod:`.span_check`).
    later_stages_laws : {"without_unexplained", "all_spans"}
        The laws the maintenance and contact-force stages use: identified without the spans the
        final model does not explain, or with every span.
    spans : SpanCheckSettings
        The per-span check (``diagnosis.spans``; its ``fdr`` and ``level`` are this block's, its
        ``fault_probability`` the maintenance block's, set by the rule script).
    """

    random_inputs: tuple[str, ...] = ("dropper_lengths_m", "system_height_m")
    free_means: tuple[str, ...] = ("messenger_tension_n", "system_height_m")
    neighbours: int = 1
    start_effects: tuple[str, ...] = ()
    candidates: tuple[str, ...] = tuple(CANDIDATES)
    level: float = 0.01
    bic_margin: float = 6.0
    max_steps: int = 3
    power: float = 0.8
    n_samples: int = 10_000
    seed: int = 5
    bootstrap_replicates: int = 1000
    max_evaluations: int = 4000
    optimiser: str = "fisher-scoring"
    xtol: float = 0.1
    ftol: float = 0.01
    fdr: float = 0.05
    later_stages_laws: str = "without_unexplained"
    spans: SpanCheckSettings = dataclasses.field(default_factory=SpanCheckSettings)

    def __post_init__(self) -> None:
        check(self.as_mapping(), "config", "diagnosis")
        for key in ("neighbours", "max_steps", "n_samples", "seed", "bootstrap_replicates", "max_evaluations"):
            object.__setattr__(self, key, int(getattr(self, key)))
        unknown = [c for c in (*self.candidates, *self.start_effects) if not known(c)]
        if unknown:
            raise ConfigError(f"diagnosis: unknown candidate effect(s) {unknown}; known: {', '.join(CANDIDATES)} and "
                              "the effects of effects_modules")
        local = [c for c in self.start_effects if c not in CANDIDATES]
        if local:
            raise ConfigError(f"diagnosis.start.effects: {local} act span by span (scope span): list them among "
                              "diagnosis.candidates instead")
        if "wire_continuity" in self.start_effects and self.neighbours != 0:
            raise ConfigError("diagnosis.start.effects: wire_continuity needs the pinned span (start.neighbours: 0)")

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None, where: str = "diagnosis") -> "DiagnosisSettings":
        """Settings from the config block (missing keys take their defaults); a bad key or value
        is a :class:`~catenary.plumbing.errors.ConfigError` naming it."""
        raw = merged_mapping(cls().as_mapping(), mapping)
        check(raw, "config", "diagnosis", where=where)
        start = raw["start"]
        return cls(random_inputs=tuple(start["random_inputs"]), free_means=tuple(start["free_means"]),
                   neighbours=start["neighbours"], start_effects=tuple(start["effects"]),
                   candidates=tuple(raw["candidates"]), level=raw["level"], bic_margin=raw["bic_margin"],
                   max_steps=raw["max_steps"], power=raw["power"], n_samples=raw["n_samples"], seed=raw["seed"],
                   bootstrap_replicates=raw["bootstrap_replicates"], max_evaluations=raw["max_evaluations"],
                   optimiser=raw["optimiser"], xtol=raw["xtol"], ftol=raw["ftol"], fdr=raw["fdr"],
                   later_stages_laws=raw["later_stages_laws"], spans=_span_check(raw["spans"], raw))

    def as_mapping(self) -> dict[str, Any]:
        """The settings as the config block ``diagnosis`` (the schema's layout)."""
        return {"start": {"random_inputs": list(self.random_inputs), "free_means": list(self.free_means),
                          "neighbours": self.neighbours, "effects": list(self.start_effects)},
                "candidates": list(self.candidates), "level": self.level, "bic_margin": self.bic_margin,
                "max_steps": self.max_steps, "power": self.power, "n_samples": self.n_samples, "seed": self.seed,
                "bootstrap_replicates": self.bootstrap_replicates, "max_evaluations": self.max_evaluations,
                "optimiser": self.optimiser, "xtol": self.xtol, "ftol": self.ftol, "fdr": self.fdr,
                "later_stages_laws": self.later_stages_laws,
                "spans": {k: v for k, v in {**dataclasses.asdict(self.spans.profile),
                                            **dataclasses.asdict(self.spans)}.items()
                          if k not in ("fdr", "level", "profile", "seed", "fault_probability")}
                | {"seed": self.spans.seed}}

    def span_check(self) -> SpanCheckSettings:
        """The per-span check's settings with this block's ``fdr`` and ``level``."""
        return dataclasses.replace(self.spans, fdr=self.fdr, level=self.level)

    def base(self, identification: IdentificationSettings) -> IdentificationSettings:
        """The identification settings of the starting model's base."""
        return dataclasses.replace(identification, random_inputs=self.random_inputs, free_means=self.free_means,
                                   neighbours=self.neighbours, n_samples=self.n_samples, seed=self.seed)
