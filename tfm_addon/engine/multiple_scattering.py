"""Multiple scattering approximated by octaves (Wrenninge, Kulla, Lundqvist, "Oz: the great and
volumetric", SIGGRAPH 2013 talk), read from the single-scattering maps.

Octave n (0 = single scattering) re-evaluates the light scattered at each view sample with the
light's transmittance raised to a^n (T^(a^n) = exp(a^n ln T): the same map, one more power), its
contribution scaled by (b albedo (1 - T_through))^n and the phase anisotropy by c^n; the octaves
add up. albedo = sigma_s / sigma_t of the medium there (light scattered n more times kept that
share each time); T_through the transmittance of the whole light ray through the media there
(read from the same map past the media's far side: in a thin medium light that scatters again
mostly leaves, in a thick one it stays). c is fitted with b on media of anisotropy 0 and 0.6 (lit
from the front and from behind). Light that
scattered many times has travelled through less medium on average, spreads forward less and is
brighter in the shadowed parts of the medium: the octaves stand in for it with no new map.

In thick media light scatters hundreds of times and the octaves' T^(a^n) leaves their inside too
dark; and from one bounce on Cycles lights the media with the light the surfaces reflect. Two
fields on a lattice over the media carry both (engine/diffusion.py, built once per light set up from
the same maps): the surfaces' light, weighed by ``surface``, and the diffused light (the
diffusion equation's fluence of light scattered at least twice), weighed by ``grid``; and where the
first medium emits, its emission's light (whole at every bounce count, 0 included: Cycles scatters
a medium's emission with no bounces) and that light diffused, weighed by ``emission``. Where no
lattice can be made (fog filling the scene, a GL with too few texture units) a diffusion term of
the light ray's own slab stands in from 16 bounces on: k albedo^m times the diffuse fluence of a
slab as thick as the light ray's optical depth through the media there (boundary extrapolated by
z), lowered where the view enters the medium nearer than the slab's faces.

``octaves(bounces)`` is the rule: Cycles' Volume Bounces in, the octave count, (a, b, c) and the
fields' weights out, fitted against Cycles (scripts/fit_octaves.py, docs/multiple_scattering.md).
0 bounces is single scattering, exactly the single-scattering image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace


@dataclass(frozen=True)
class Octaves:
    """``count`` octaves (1: single scattering); octave n scales the light transmittance's
    optical depth by ``a``^n, the contribution by (``b`` albedo (1 - T_through))^n and the anisotropy
    by ``c``^n; the slab diffusion term weighs ``k`` albedo^``m``, ``z`` its extrapolated boundary
    (an optical depth); ``surface`` and ``grid`` weigh the surfaces' light and the diffused light
    of engine/diffusion.py, ``emission`` the diffused light of the media's own emission."""

    count: int = 1
    a: float = 1.0
    b: float = 0.0
    c: float = 1.0
    k: float = 0.0
    z: float = 0.67
    m: float = 0.0
    surface: float = 0.0
    grid: float = 0.0
    emission: float = 0.0

    @property
    def fields(self) -> bool:
        """Whether the frame reads engine/diffusion.py's fields (weights ``surface``, ``grid``)."""
        return self.surface > 0.0 or self.grid > 0.0


SINGLE = Octaves()

# Fitted against Cycles (scripts/fit_octaves.py on bench/bounces.FIT; docs/multiple_scattering.md):
# bounce count -> octaves; a count between two rows is interpolated in the logarithm of the count
# (``octaves``), so that the image changes smoothly with the count, and a count above the last row
# takes the last row. The surfaces' light is
# taken whole from one bounce on; the diffused light carries the light that scatters many times in
# thick media, a little from 4 bounces on, most from 16, more at 128 (only its weight may grow from
# the 16-bounce row: more bounces never give less light), as Cycles' thick media are brighter at
# 128 than at 16.
FITTED: dict[int, Octaves] = {
    1: Octaves(2, 0.7, 0.575, 0.625, surface=1.0, grid=0.0, emission=0.7),
    2: Octaves(2, 0.4, 0.775, 0.5, surface=1.0, grid=0.0, emission=1.2),
    4: Octaves(2, 0.5, 0.95, 0.5, surface=1.0, grid=0.15, emission=1.7),
    16: Octaves(2, 0.4, 0.725, 0.625, k=0.45, z=0.3, m=1.0, surface=1.0, grid=0.8, emission=2.05),
    128: Octaves(2, 0.4, 0.725, 0.625, k=0.55, z=0.3, m=1.0, surface=1.0, grid=1.1, emission=2.05),
}


def octaves(bounces: int) -> Octaves:
    """The octaves that approximate ``bounces`` volume bounces (0: single scattering): the fitted
    row of that count, or between two rows each weight interpolated linearly in log2 of the count
    (every weight is then continuous in the count: 15 and 16 bounces differ as little as 16 and
    17)."""
    if bounces <= 0:
        return SINGLE
    counts = sorted(FITTED)
    if bounces >= counts[-1]:
        return FITTED[counts[-1]]
    lo = max(n for n in counts if n <= bounces)
    hi = min(n for n in counts if n > bounces)
    t = (math.log2(bounces) - math.log2(lo)) / (math.log2(hi) - math.log2(lo))
    a, b = FITTED[lo], FITTED[hi]
    values = {f.name: (1.0 - t) * getattr(a, f.name) + t * getattr(b, f.name)
              for f in fields(Octaves) if f.name != "count"}
    for name in ("z", "m"):     # the slab term's shape: the row's where it is on (k > 0) alone
        if a.k == 0.0 or b.k == 0.0:
            values[name] = getattr(b if a.k == 0.0 else a, name)
    return replace(a, **values)


def for_settings(settings) -> Octaves:
    """The octaves a frame renders with (``RenderSettings.octaves`` or the rule)."""
    return settings.octaves if settings.octaves is not None else octaves(settings.volume_bounces)


def bind(prog, o: Octaves) -> None:
    """octaves.glsl's uniforms."""
    if "u_octave" in prog:
        prog["u_octave"].value = (float(o.a), float(o.b), float(o.c))
    if "u_diffusion" in prog:
        prog["u_diffusion"].value = (float(o.k), float(o.z), float(o.m))


def notes(scene, settings) -> list[str]:
    """The render report's line for a frame with volume bounces and media."""
    o = for_settings(settings)
    if o.count <= 1 or not scene.media:
        return []
    diffusion = " and diffusion" if o.k > 0.0 or o.grid > 0.0 else ""
    surfaces = (", and light that surfaces reflect into the media from their base colour" if o.surface > 0.0
                else "; light that surfaces reflect into the media is not rendered")
    return [f"Volume Bounces {settings.volume_bounces}: multiple scattering approximated by {o.count} "
            f"octaves of the single scattering{diffusion}{surfaces}"]
