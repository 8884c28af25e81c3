"""An effect of one's own: a concentrated mass clamped on the contact wire (worked example).

The report shows spans the model does not explain, each with a peak between two droppers and
the point load that would bend the CW so. Equipment clamped on the CW — a current connector, a
splice, a section insulator's fitting — is such a load: its weight pulls the wire down at one
point, the wire kinks there by ``m g / T_CW`` and hangs from its two neighbouring droppers as a
tent, and the whole span sags a little with it. Written from that physics, the effect needs only
to clamp the mass on the span's CW; the FE model does the rest.

List this file in the config (``effects_modules: [docs/examples/concentrated_mass.py]``) and
its name among the diagnosis' candidates (``diagnosis.candidates``); the diagnosis then fits the
mass and its position on every span it could not explain, and says which spans the effect
explains (docs/diagnosis.md, "An effect of your own").
"""

from catenary.physics.effects import Effect, EffectParameter


def concentrated_mass(p, z, *, mass_kg: float, x_m: float) -> None:
    """A mass of ``mass_kg`` [kg] clamped on each span's CW at ``x_m`` [m] from its left mast."""
    p.add_cw_point_masses(x_m, mass_kg)


EFFECTS = [
    Effect("concentrated_mass", concentrated_mass, None, scope="span",
           parameters=(EffectParameter("mass_kg", "shift", (0.0, 50.0), 5.0, 5.0, "kg", "mass clamped on the CW"),
                       EffectParameter("x_m", "position", (0.0, 60.0), 10.0, 30.0, "m",
                                       "its position from the span's left mast")),
           summary="equipment clamped on the contact wire between two droppers"),
]
