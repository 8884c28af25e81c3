"""How data/example/recording.csv and masts.csv were made (kept for the record; not run by the workflow).

A hand-made measuring run over one tensioning section of 16 N2 spans (58.5 m), written from a
textbook picture of a span, independently of the package's campaign and physics code:

- the contact wire is held by the steady arms (design height 5.08 m, each arm set within ±10 mm)
  and by nine droppers per span (at 4.5, 11.25, 18, 24.75, 29.25, 33.75, 40.5, 47.25, 54 m), which
  hold it on a parabolic presag of 24 mm at mid-span;
- each span departs from that design at its droppers by a smooth random shape, the sum of the
  first three half-sine modes over the span with normal amplitudes of σ 4, 2 and 1 mm: what
  dropper-length errors, a tension differing from span to span and a system height off its
  design do to a wire pulled at 25 kN (independent millimetre steps at each clamp would ask the
  droppers to push: no real span looks like that, and the correction rightly fails on it);
- between two of its supports the wire (1.35 kg/m at 25.5 kN) hangs as a string under its own
  weight: straight from one to the next, sagging q (x − a)(b − x) / 2T, so that it kinks at every
  dropper;
- the measuring pantograph (36 N at ≈ 40 km/h) lifts the wire by 36 N × the local elasticity:
  0.40 mm/N at the steady arms and 0.50 mm/N at mid-span over the whole span, plus the string's
  own yield between two supports, (x − a)(b − x) / (T (b − a));
- the sensor adds 1 mm of normal noise and rounds to the millimetre; one 15 cm spike (a bird or an
  insulator), one 1.2 m drop-out that the projection tolerates and one 9 m drop-out over a dropper
  that makes the projection reject its span.

Chainages are in metres from the line's origin (kilometre point 104.25), one sample every 0.2 m.
"""

from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
rng = np.random.default_rng(20261123)

SPAN_M = 58.5
N_SPANS = 16
START_M = 104_250.0
DROPPERS_M = np.array([4.5, 11.25, 18.0, 24.75, 29.25, 33.75, 40.5, 47.25, 54.0])
WEIGHT_N_M = 1.35 * 9.81
TENSION_N = 25500.0
design_height_m = 5.08
arm_heights_m = design_height_m + rng.uniform(-0.010, 0.010, N_SPANS + 1)
mode_amplitudes_m = rng.normal(0.0, 1.0, (N_SPANS, 3)) * np.array([0.004, 0.002, 0.001])

masts_m = START_M + SPAN_M * np.arange(N_SPANS + 1)
chainage_m = np.round(np.arange(masts_m[0] - 20.0, masts_m[-1] + 20.0, 0.2), 1)
height_m = np.full(chainage_m.size, design_height_m)
for k in range(N_SPANS):
    inside = (chainage_m >= masts_m[k]) & (chainage_m < masts_m[k + 1])
    x = chainage_m[inside] - masts_m[k]
    supports = np.r_[0.0, DROPPERS_M, SPAN_M]
    chord = arm_heights_m[k] + (arm_heights_m[k + 1] - arm_heights_m[k]) * supports / SPAN_M
    presag = 0.024 * 4.0 * supports * (SPAN_M - supports) / SPAN_M**2
    shape = sum(a * np.sin((m + 1) * np.pi * supports / SPAN_M) for m, a in enumerate(mode_amplitudes_m[k]))
    held = chord - presag + shape                           # the wire's height at the arms and droppers
    bay = np.clip(np.searchsorted(supports, x, side="right") - 1, 0, supports.size - 2)
    a, b = supports[bay], supports[bay + 1]
    string = held[bay] + (held[bay + 1] - held[bay]) * (x - a) / (b - a) - WEIGHT_N_M * (x - a) * (b - x) / (2 * TENSION_N)
    uplift = 36.0 * (1e-3 * (0.40 + 0.10 * np.sin(np.pi * x / SPAN_M) ** 2) + (x - a) * (b - x) / (TENSION_N * (b - a)))
    height_m[inside] = string + uplift
height_m += rng.normal(0.0, 0.001, chainage_m.size)
height_m = np.round(height_m, 3)
speed_kmh = np.round(40.0 + 0.6 * np.sin(2 * np.pi * (chainage_m - START_M) / 700.0), 1)

text = np.array([f"{h:.3f}" for h in height_m], dtype=object)
spike = np.argmin(np.abs(chainage_m - (masts_m[3] + 20.0)))
text[spike] = f"{height_m[spike] + 0.150:.3f}"                                                   # spike
text[(chainage_m >= masts_m[6] + 8.0) & (chainage_m < masts_m[6] + 9.2)] = ""                  # tolerated gap
text[(chainage_m >= masts_m[11] + 26.0) & (chainage_m < masts_m[11] + 35.0)] = ""              # rejects the span

with open(HERE / "recording.csv", "w") as f:
    f.write("chainage_m,height_m,speed_kmh\n")
    for c, h, v in zip(chainage_m, text, speed_kmh):
        f.write(f"{c:.1f},{h},{v:.1f}\n")
with open(HERE / "masts.csv", "w") as f:
    f.write("mast_id,chainage_m,section_id,span_type\n")
    for k, c in enumerate(masts_m):
        span_type = "N2" if k % 4 else ""          # every fourth left blank: typed by its length
        f.write(f"P{104 + (k + 5) // 17}/{(k + 5) % 17 + 1:02d},{c:.2f},E01,{span_type if k < N_SPANS else ''}\n")
