"""Geometry of a catenary section (one span or many consecutive spans) and its mesh.

A *section* is a run of consecutive spans between masts. Each mast ``j`` holds the contact
wire (CW) at its steady arm at height ``cw_support_heights_m[j]`` and the messenger wire (MW)
at ``cw_support_heights_m[j] + system_heights_m[j]``. Dropper ``i`` hangs from the MW in span
``dropper_span[i]`` at ``dropper_x_m[i]`` from that span's left mast (its design position, where
W is measured) and has the unstretched length ``dropper_lengths_m[i]``. Its CW clamp sits
``dropper_offset_m[i]`` further along the line (0: a vertical dropper; see
:func:`inclined_dropper`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .config import SpanType
from catenary.plumbing.errors import ConfigError

#: Offsets of the CW clamp smaller than this [m] are treated as vertical droppers: their
#: shortening δ²/(2L) is below 1e-6 m and a sub-millimetre element would be ill-conditioned.
MIN_DROPPER_OFFSET_M = 1e-3


def inclined_dropper(lengths_m: np.ndarray, offsets_m: np.ndarray,
                     axial_stiffness_n: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertical rest length [m] and vertical stiffness [N/m] of inclined droppers.

    A dropper of unstretched length ``L`` whose CW clamp is offset by ``δ`` along the line from
    its MW clamp spans the vertical distance ``L_v = √(L² − δ²)`` when unstretched. Linearising
    its axial force ``EA (ℓ − L) / L`` about that state, the vertical force per vertical
    stretch is ``EA L_v² / L³`` (``EA cos²θ / L``); the horizontal components, ``F δ / L`` on
    each wire, are below 1e-3 of the wire tensions and are neglected. This is the one place
    the inclined-dropper physics lives: the FE models, the fast model and the campaign's
    ``cw_longitudinal_offset`` effect all use it.

    Parameters
    ----------
    lengths_m : array_like
        Unstretched dropper lengths ``L`` [m].
    offsets_m : array_like
        Longitudinal offsets ``δ`` of the CW clamps from the MW clamps [m]; ``|δ| < L``.
    axial_stiffness_n : float
        Dropper axial stiffness ``EA`` [N].

    Returns
    -------
    rest_length_m, stiffness_n_m : numpy.ndarray
    """
    length = np.asarray(lengths_m, dtype=float)
    offset = np.asarray(offsets_m, dtype=float)
    vertical = np.sqrt(length ** 2 - offset ** 2)
    return vertical, axial_stiffness_n * vertical ** 2 / length ** 3


@dataclass(frozen=True)
class Section:
    """Geometry and tensions of a section of consecutive spans.

    Attributes
    ----------
    span_lengths_m : numpy.ndarray
        Lengths of the spans [m], shape (n_spans,).
    dropper_span : numpy.ndarray
        Span index of each dropper, shape (n_droppers,), non-decreasing.
    dropper_x_m : numpy.ndarray
        Dropper abscissa from the left mast of its span [m].
    dropper_lengths_m : numpy.ndarray
        Unstretched dropper lengths [m].
    cw_support_heights_m : numpy.ndarray
        Contact-wire height at each steady arm [m], shape (n_spans + 1,).
    system_heights_m : numpy.ndarray
        System height ΔH at each mast (MW above CW) [m], shape (n_spans + 1,).
    contact_tension_n, messenger_tension_n : float or numpy.ndarray
        T_CW and T_MW [N]: one value for the section (tensioning weights at its ends), or one
        per span (shape (n_spans,)) to model tension differences between spans.
    dropper_offset_m : float or numpy.ndarray
        Offset of each dropper's CW clamp from its MW clamp along the line [m] (inclined
        droppers; positive towards increasing chainage). Default 0: vertical droppers.
    cw_mass_factor : float or numpy.ndarray
        CW mass per length of each span as a fraction of the catenary's (one value, or one per
        span; ``1 − ε`` for a wire worn by a fraction ε of its section: the
        ``contact_wire_wear`` effect). Default 1.
    cw_point_mass_x_m, cw_point_mass_kg : numpy.ndarray
        Concentrated masses clamped on the CW (connectors, splices, section insulators): their
        chainages from the section start [m] and masses [kg] (default none). The mesh has a node
        at each; they weigh on the CW statically and move with it dynamically.
    """

    span_lengths_m: np.ndarray
    dropper_span: np.ndarray
    dropper_x_m: np.ndarray
    dropper_lengths_m: np.ndarray
    cw_support_heights_m: np.ndarray
    system_heights_m: np.ndarray
    contact_tension_n: float | np.ndarray
    messenger_tension_n: float | np.ndarray
    dropper_offset_m: float | np.ndarray = 0.0
    cw_mass_factor: float | np.ndarray = 1.0
    cw_point_mass_x_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cw_point_mass_kg: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        for name in ("span_lengths_m", "dropper_x_m", "dropper_lengths_m",
                     "cw_support_heights_m", "system_heights_m"):
            object.__setattr__(self, name, np.atleast_1d(np.asarray(getattr(self, name), dtype=float)))
        object.__setattr__(self, "dropper_span", np.atleast_1d(np.asarray(self.dropper_span, dtype=int)))
        n_spans = self.span_lengths_m.size
        n_d = self.dropper_x_m.size
        if n_spans < 1 or np.any(~np.isfinite(self.span_lengths_m)) or np.any(self.span_lengths_m <= 0):
            raise ConfigError(f"span_lengths_m: expected positive lengths [m], got {self.span_lengths_m}")
        for name, size in (("cw_support_heights_m", n_spans + 1), ("system_heights_m", n_spans + 1),
                           ("dropper_span", n_d), ("dropper_lengths_m", n_d)):
            if getattr(self, name).size != size:
                raise ConfigError(f"{name}: expected {size} values, got {getattr(self, name).size}")
        offset = np.asarray(self.dropper_offset_m, dtype=float)
        if offset.ndim and offset.shape != (n_d,):
            raise ConfigError(f"dropper_offset_m: expected one offset or {n_d} (one per dropper), got shape {offset.shape}")
        offset = np.broadcast_to(offset, (n_d,)).copy()
        if np.any(~np.isfinite(offset)):
            raise ConfigError(f"dropper_offset_m: expected finite offsets [m], got {offset}")
        object.__setattr__(self, "dropper_offset_m", offset)
        if np.any(self.system_heights_m <= 0):
            raise ConfigError(f"system_heights_m: expected values > 0 [m], got {self.system_heights_m}")
        if np.any(~np.isfinite(self.dropper_lengths_m)) or np.any(self.dropper_lengths_m <= 0):
            raise ConfigError(f"dropper_lengths_m: expected values > 0 [m], got {self.dropper_lengths_m}")
        if np.any(np.abs(offset) >= self.dropper_lengths_m):
            bad = int(np.flatnonzero(np.abs(offset) >= self.dropper_lengths_m)[0])
            raise ConfigError(f"dropper_offset_m[{bad}] = {offset[bad]} m: a dropper of length "
                              f"{self.dropper_lengths_m[bad]} m cannot reach that far")
        factor = np.asarray(self.cw_mass_factor, dtype=float)
        if factor.ndim and factor.shape != (n_spans,):
            raise ConfigError(f"cw_mass_factor: expected one factor or {n_spans} (one per span), got shape {factor.shape}")
        if np.any(~np.isfinite(factor)) or np.any(factor <= 0):
            raise ConfigError(f"cw_mass_factor: expected factors > 0, got {factor}")
        object.__setattr__(self, "cw_mass_factor", float(factor) if factor.ndim == 0 else factor)
        px = np.atleast_1d(np.asarray(self.cw_point_mass_x_m, dtype=float))
        pm = np.atleast_1d(np.asarray(self.cw_point_mass_kg, dtype=float))
        if px.shape != pm.shape or px.ndim != 1:
            raise ConfigError(f"cw_point_mass_x_m, cw_point_mass_kg: expected two arrays of one length, got shapes "
                              f"{px.shape} and {pm.shape}")
        total = float(np.sum(self.span_lengths_m))
        if np.any(~np.isfinite(px)) or np.any(px <= 0) or np.any(px >= total) or np.any(~np.isfinite(pm)) \
                or np.any(pm < 0):
            raise ConfigError(f"cw point masses: expected chainages inside the section (0, {total}) m and masses "
                              f"≥ 0 kg, got {px} m, {pm} kg")
        keep = pm > 0
        object.__setattr__(self, "cw_point_mass_x_m", px[keep])
        object.__setattr__(self, "cw_point_mass_kg", pm[keep])
        for name in ("contact_tension_n", "messenger_tension_n"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.ndim == 0:
                object.__setattr__(self, name, float(value))
            elif value.shape != (n_spans,):
                raise ConfigError(f"{name}: expected one tension or {n_spans} (one per span), got shape {value.shape}")
            else:
                object.__setattr__(self, name, value)
            if np.any(~np.isfinite(value)) or np.any(value <= 0):
                raise ConfigError(f"{name}: expected tensions > 0 [N], got {value}")
        if n_d:
            if np.any(np.diff(self.dropper_span) < 0) or self.dropper_span[0] < 0 or self.dropper_span[-1] >= n_spans:
                raise ConfigError("dropper_span: expected non-decreasing span indices in [0, n_spans)")
            length = self.span_lengths_m[self.dropper_span]
            if np.any(self.dropper_x_m <= 0) or np.any(self.dropper_x_m >= length):
                bad = int(np.flatnonzero((self.dropper_x_m <= 0) | (self.dropper_x_m >= length))[0])
                raise ConfigError(f"dropper_x_m[{bad}] = {self.dropper_x_m[bad]} m lies outside its span "
                                  f"(0, {length[bad]}) m")
            clamp = self.dropper_x_m + self.clamp_offset_m
            if np.any(clamp <= 0) or np.any(clamp >= length):
                bad = int(np.flatnonzero((clamp <= 0) | (clamp >= length))[0])
                raise ConfigError(f"dropper_offset_m[{bad}] = {offset[bad]} m puts the CW clamp outside its span")
            same = self.dropper_span[1:] == self.dropper_span[:-1]
            if np.any(same & (np.diff(self.dropper_x_m) <= 0)):
                raise ConfigError("dropper_x_m: positions within a span must be strictly increasing")

    @property
    def n_spans(self) -> int:
        return int(self.span_lengths_m.size)

    @property
    def contact_tension_by_span_n(self) -> np.ndarray:
        """T_CW of each span [N], shape (n_spans,)."""
        return np.broadcast_to(np.asarray(self.contact_tension_n, dtype=float), (self.n_spans,))

    @property
    def messenger_tension_by_span_n(self) -> np.ndarray:
        """T_MW of each span [N], shape (n_spans,)."""
        return np.broadcast_to(np.asarray(self.messenger_tension_n, dtype=float), (self.n_spans,))

    @property
    def cw_mass_factor_by_span(self) -> np.ndarray:
        """CW mass per length of each span relative to the catenary's, shape (n_spans,)."""
        return np.broadcast_to(np.asarray(self.cw_mass_factor, dtype=float), (self.n_spans,))

    @property
    def mast_chainage_m(self) -> np.ndarray:
        """Chainage of each mast from the section start [m], shape (n_spans + 1,)."""
        return np.concatenate([[0.0], np.cumsum(self.span_lengths_m)])

    @property
    def dropper_chainage_m(self) -> np.ndarray:
        """Chainage of each dropper from the section start [m]."""
        return self.mast_chainage_m[self.dropper_span] + self.dropper_x_m

    @property
    def clamp_offset_m(self) -> np.ndarray:
        """Offset of each CW clamp from its dropper's design position in the mesh [m]: the
        dropper offsets, with those below :data:`MIN_DROPPER_OFFSET_M` set to 0."""
        offset = self.dropper_offset_m
        return np.where(np.abs(offset) < MIN_DROPPER_OFFSET_M, 0.0, offset)

    @property
    def cw_clamp_chainage_m(self) -> np.ndarray:
        """Chainage of each dropper's CW clamp from the section start [m]."""
        return self.dropper_chainage_m + self.clamp_offset_m

    @property
    def mw_support_heights_m(self) -> np.ndarray:
        """Messenger-wire height at each mast [m]."""
        return self.cw_support_heights_m + self.system_heights_m

    def chord_height_m(self, chainage_m: np.ndarray) -> np.ndarray:
        """Height of the chord joining the CW at the two steady arms of the span holding each point [m]."""
        s = np.asarray(chainage_m, dtype=float)
        masts = self.mast_chainage_m
        span = np.clip(np.searchsorted(masts, s, side="right") - 1, 0, self.n_spans - 1)
        frac = (s - masts[span]) / self.span_lengths_m[span]
        h = self.cw_support_heights_m
        return h[span] + frac * (h[span + 1] - h[span])

    def chord_at_droppers(self, values_at_masts: np.ndarray) -> np.ndarray:
        """Per-mast values (heights [m], gaps, ...) interpolated linearly along each span to its
        droppers' design positions, shape (n_droppers,)."""
        v = np.asarray(values_at_masts, dtype=float)
        span = self.dropper_span
        frac = self.dropper_x_m / self.span_lengths_m[span]
        return v[span] + frac * (v[span + 1] - v[span])

    def with_dropper_lengths(self, dropper_lengths_m: np.ndarray) -> "Section":
        """A copy with other unstretched dropper lengths [m]."""
        return _replace(self, dropper_lengths_m=np.asarray(dropper_lengths_m, dtype=float))

    def with_cw_support_heights(self, cw_support_heights_m: np.ndarray) -> "Section":
        """A copy with other CW heights at the steady arms [m] (system heights kept)."""
        return _replace(self, cw_support_heights_m=np.asarray(cw_support_heights_m, dtype=float))

    def with_dropper_offsets(self, dropper_offset_m: float | np.ndarray) -> "Section":
        """A copy with other CW clamp offsets [m] (inclined droppers)."""
        return _replace(self, dropper_offset_m=dropper_offset_m)

    def mirrored(self) -> "Section":
        """The same section seen from its other end: chainage ``x`` becomes ``length − x``.

        Spans, masts and droppers come in reverse order; a dropper at ``x`` from its span's left
        mast sits at ``L − x`` from the new left mast, and its CW clamp offset changes sign.
        A pantograph running towards decreasing chainage over this section is a pantograph
        running towards increasing chainage over the mirrored one.
        """
        def flip(value):
            value = np.asarray(value, dtype=float)
            return float(value) if value.ndim == 0 else value[::-1].copy()

        span = self.dropper_span[::-1]
        return _replace(
            self,
            span_lengths_m=self.span_lengths_m[::-1].copy(),
            dropper_span=self.n_spans - 1 - span,
            dropper_x_m=self.span_lengths_m[span] - self.dropper_x_m[::-1],
            dropper_lengths_m=self.dropper_lengths_m[::-1].copy(),
            cw_support_heights_m=self.cw_support_heights_m[::-1].copy(),
            system_heights_m=self.system_heights_m[::-1].copy(),
            contact_tension_n=flip(self.contact_tension_n),
            messenger_tension_n=flip(self.messenger_tension_n),
            dropper_offset_m=-self.dropper_offset_m[::-1],
            cw_mass_factor=flip(self.cw_mass_factor),
            cw_point_mass_x_m=float(np.sum(self.span_lengths_m)) - self.cw_point_mass_x_m[::-1],
            cw_point_mass_kg=self.cw_point_mass_kg[::-1].copy(),
        )

    def with_tensions(self, *, contact_tension_n: float | None = None,
                      messenger_tension_n: float | None = None) -> "Section":
        """A copy with other wire tensions [N]."""
        return _replace(
            self,
            contact_tension_n=self.contact_tension_n if contact_tension_n is None else contact_tension_n,
            messenger_tension_n=self.messenger_tension_n if messenger_tension_n is None else messenger_tension_n,
        )


def _replace(section: Section, **changes) -> Section:
    fields = {k: getattr(section, k) for k in Section.__dataclass_fields__}
    fields.update(changes)
    return Section(**fields)


def uniform_section(span_type: SpanType, n_spans: int, dropper_lengths_m: np.ndarray, *,
                    contact_tension_n: float | None = None, messenger_tension_n: float | None = None,
                    system_height_m: float | None = None, cw_height_m: float | None = None) -> Section:
    """A section of ``n_spans`` identical spans of ``span_type`` at its design values.

    Parameters
    ----------
    dropper_lengths_m : array_like
        Unstretched lengths of the droppers of one span [m], repeated in every span.
    """
    lengths = np.asarray(dropper_lengths_m, dtype=float)
    if lengths.shape != span_type.dropper_positions_m.shape:
        raise ConfigError(f"dropper_lengths_m: expected {span_type.n_droppers} lengths for span type "
                          f"{span_type.name}, got {lengths.size}")
    n_d = span_type.n_droppers
    return Section(
        span_lengths_m=np.full(n_spans, span_type.length_m),
        dropper_span=np.repeat(np.arange(n_spans), n_d),
        dropper_x_m=np.tile(span_type.dropper_positions_m, n_spans),
        dropper_lengths_m=np.tile(lengths, n_spans),
        cw_support_heights_m=np.full(n_spans + 1, span_type.cw_height_m if cw_height_m is None else cw_height_m),
        system_heights_m=np.full(n_spans + 1, span_type.system_height_m if system_height_m is None else system_height_m),
        contact_tension_n=span_type.contact_tension_n if contact_tension_n is None else contact_tension_n,
        messenger_tension_n=span_type.messenger_tension_n if messenger_tension_n is None else messenger_tension_n,
    )


def single_span(span_type: SpanType, dropper_lengths_m: np.ndarray, *,
                contact_tension_n: float | None = None, messenger_tension_n: float | None = None,
                system_height_left_m: float | None = None, system_height_right_m: float | None = None,
                cw_height_left_m: float | None = None, cw_height_right_m: float | None = None) -> Section:
    """One span of ``span_type`` with fixed ends (the paper's identification model)."""
    base = uniform_section(span_type, 1, dropper_lengths_m, contact_tension_n=contact_tension_n,
                           messenger_tension_n=messenger_tension_n)
    dh = span_type.system_height_m
    h = span_type.cw_height_m
    return _replace(
        base,
        system_heights_m=np.array([dh if system_height_left_m is None else system_height_left_m,
                                   dh if system_height_right_m is None else system_height_right_m]),
        cw_support_heights_m=np.array([h if cw_height_left_m is None else cw_height_left_m,
                                       h if cw_height_right_m is None else cw_height_right_m]),
    )


@dataclass(frozen=True)
class Mesh:
    """Finite-element mesh shared by the contact and messenger wires.

    Attributes
    ----------
    x_m : numpy.ndarray
        Node chainages from the section start [m], increasing.
    mast_nodes : numpy.ndarray
        Node index of each mast.
    dropper_nodes : numpy.ndarray
        Node index of each dropper's design position (its MW clamp; W is read there).
    cw_clamp_nodes : numpy.ndarray
        Node index of each dropper's CW clamp (equal to ``dropper_nodes`` for vertical droppers).
    element_span : numpy.ndarray
        Span index of each element.
    cw_point_mass_nodes : numpy.ndarray
        Node index of each concentrated mass on the CW.
    """

    x_m: np.ndarray
    mast_nodes: np.ndarray
    dropper_nodes: np.ndarray
    element_span: np.ndarray
    cw_clamp_nodes: np.ndarray
    cw_point_mass_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def n_nodes(self) -> int:
        return int(self.x_m.size)

    @property
    def element_length_m(self) -> np.ndarray:
        return np.diff(self.x_m)

    def locate(self, chainage_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Element index and local coordinate ξ ∈ [0, 1] of each chainage [m]."""
        s = np.asarray(chainage_m, dtype=float)
        if np.any(s < self.x_m[0] - 1e-9) or np.any(s > self.x_m[-1] + 1e-9):
            raise ValueError(f"chainage outside the section [{self.x_m[0]}, {self.x_m[-1]}] m")
        e = np.clip(np.searchsorted(self.x_m, s, side="right") - 1, 0, self.x_m.size - 2)
        xi = np.clip((s - self.x_m[e]) / (self.x_m[e + 1] - self.x_m[e]), 0.0, 1.0)
        return e, xi


def build_mesh(section: Section, max_element_length_m: float) -> Mesh:
    """Mesh with a node at every mast and dropper and elements no longer than the bound [m]."""
    if max_element_length_m <= 0:
        raise ConfigError(f"max_element_length_m: expected > 0, got {max_element_length_m}")
    key = np.concatenate([section.mast_chainage_m, section.dropper_chainage_m, section.cw_clamp_chainage_m,
                          section.cw_point_mass_x_m])
    key = np.unique(np.round(key, 9))
    gaps = np.diff(key)
    n_sub = np.maximum(1, np.ceil(gaps / max_element_length_m - 1e-9).astype(int))
    pieces = [key[i] + gaps[i] * np.arange(n_sub[i]) / n_sub[i] for i in range(gaps.size)]
    x = np.concatenate(pieces + [key[-1:]])
    def nodes(s: np.ndarray) -> np.ndarray:
        idx = np.searchsorted(x, np.round(s, 9) - 1e-9)
        assert np.allclose(x[idx], s, atol=1e-8)
        return idx
    mid = 0.5 * (x[1:] + x[:-1])
    span = np.clip(np.searchsorted(section.mast_chainage_m, mid) - 1, 0, section.n_spans - 1)
    return Mesh(x_m=x, mast_nodes=nodes(section.mast_chainage_m), dropper_nodes=nodes(section.dropper_chainage_m),
                element_span=span, cw_clamp_nodes=nodes(section.cw_clamp_chainage_m),
                cw_point_mass_nodes=nodes(section.cw_point_mass_x_m).astype(int))
