"""Solid surfaces as Cycles' direct lighting shades them: its Principled BSDF (Blender 4+ "v2").

A mesh's material reaches the renderer as a ``Surface``: the constant inputs of a Principled BSDF
(base colour, metallic, roughness, the IOR after Specular IOR Level, specular tint), the weight of
its reflecting layers and its emission. A Diffuse BSDF is a Principled BSDF without a specular
layer (IOR 1), a Glossy BSDF a metallic one whose Fresnel is its colour at every angle; Mix and Add
Shader combine them (``mix``). The light passes evaluate it per pixel (shaders/surface.glsl) for
each light face, the ambient light and the world's directions:

- metal (weight w·m): GGX with Cycles' F82-tint Fresnel (F0 the base colour, the tint at 82°);
- dielectric specular (w·(1 − m)): GGX, Fresnel the real dielectric curve remapped to F0..1 with
  F0 = F0(IOR)·tint, as Cycles' generalized Schlick with a negative exponent;
- diffuse (w·(1 − m)·base colour): Lambert, under the specular layer: its weight is
  1 − max(specular albedo at the view angle) (Cycles' ``closure_layering_weight``);
- Multiscatter GGX (Blender's default): each GGX lobe times 1 + Fms·(1 − E)/E (Kulla and Conty's
  energy compensation as Cycles applies it).

The directional albedos the layering and the compensation read are integrals that Cycles
tabulates (``cycles_precompute.cpp``); ``compute_ggx_tables`` computes the same integrals by a
deterministic quadrature over the distribution of visible normals, on Cycles' grids, and the
shader reads them with Cycles' interpolation (``lookup_table_read``). They are stored with the
package (``data/ggx_tables.npz``, by scripts/make_ggx_tables.py, 22 s here).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import caches

RGB = tuple[float, float, float]

MAX_MATERIALS = 128          # surfaces one frame holds (the material table's entries)
# Table sizes as Cycles': E and Eavg over 32 roughnesses (x 32 view cosines), the dielectric
# Fresnel interpolation factor over 16 roughnesses x 16 view cosines x 16 IORs, and the factor of
# the generalized Schlick curve of exponent 5 (the metal's) over 16 x 16.
E_SIZE, S_SIZE = 32, 16


def f0_from_ior(ior: float) -> float:
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def ior_from_f0(f0: float) -> float:
    s = np.sqrt(min(max(f0, 0.0), 0.9999999))
    return float((1.0 + s) / (1.0 - s))


def effective_ior(ior: float, specular_ior_level: float) -> float:
    """The IOR of the Principled BSDF's specular layer: Specular IOR Level scales F0 (0.5 keeps
    it, 0 removes the layer: IOR 1), as Cycles' ``svm_node_closure_bsdf`` does."""
    ior = max(float(ior), 1e-5)
    level = max(float(specular_ior_level), 0.0)
    if level == 0.5:
        return ior
    eta = ior_from_f0(f0_from_ior(ior) * 2.0 * level)
    return 1.0 / eta if ior < 1.0 else eta


@dataclass(frozen=True)
class Surface:
    """A surface's shading: ``base_color`` (diffuse colour and metal F0), ``metallic``,
    ``roughness`` (Blender's, alpha = roughness²), ``ior`` of the specular layer (1: none; see
    ``effective_ior``), ``specular_tint``, ``weight`` of the reflecting closures (0: emission
    only), ``emission`` radiance (W/(sr m²), both sides), ``multiscatter`` (Multiscatter GGX),
    ``constant_fresnel`` (the metal's Fresnel is its base colour at every angle: Glossy BSDF);
    ``alpha``: the fraction of camera rays the surface stops (the rest pass through it, Cycles'
    stochastic transparency; the G-buffer pass discards the others);
    ``base_texture``, ``roughness_texture``, ``metallic_texture``: ``shading.ShaderGraph``s whose
    output is that input where it varies over the surface (textures), evaluated per pixel
    (passes/surface_textures.py)."""

    base_color: RGB = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5
    ior: float = 1.5
    specular_tint: RGB = (1.0, 1.0, 1.0)
    weight: float = 1.0
    emission: RGB = (0.0, 0.0, 0.0)
    multiscatter: bool = True
    constant_fresnel: bool = False
    alpha: float = 1.0
    base_texture: object = None
    roughness_texture: object = None
    metallic_texture: object = None

    @property
    def textured(self) -> bool:
        return any(t is not None for t in (self.base_texture, self.roughness_texture, self.metallic_texture))

    @staticmethod
    def lambert(color: RGB) -> Surface:
        """A Diffuse BSDF of albedo ``color`` (no specular layer)."""
        return Surface(base_color=tuple(float(c) for c in color), ior=1.0, multiscatter=False)

    def entry(self) -> np.ndarray:
        """The material table's entry: four vec4 (shaders/surface.glsl ``Material``)."""
        return np.array([*self.base_color, self.weight,
                         self.roughness, self.metallic, self.ior, float(self.multiscatter),
                         *self.specular_tint, float(self.constant_fresnel),
                         *self.emission, self.alpha], np.float32)


def mix(parts: list[tuple[float, Surface]]) -> tuple[Surface, bool]:
    """Closures added with weights (Mix and Add Shader): one Surface, and whether it is exact.
    The reflecting weights and the emissions add; the other inputs are their weight-averaged
    means, exact when the parts agree on them (a mix of colours, or of a surface with emission);
    a texture is kept where one part reflects; the alpha is the parts' mean by their factors,
    exact when they agree."""
    parts = [(float(f), s) for f, s in parts if f > 0.0]
    if not parts:
        return Surface(weight=0.0), True
    emission = tuple(float(sum(f * s.emission[i] for f, s in parts)) for i in range(3))
    alpha = float(sum(f * s.alpha for f, s in parts) / sum(f for f, _ in parts))
    same_alpha = all(s.alpha == parts[0][1].alpha for _, s in parts)
    lit = [(f * s.weight, s) for f, s in parts if f * s.weight > 0.0]
    if not lit:
        return Surface(weight=0.0, emission=emission, alpha=alpha), same_alpha
    total = sum(w for w, _ in lit)

    def mean(get):
        v = sum(w * np.asarray(get(s), np.float64) for w, s in lit) / total
        return tuple(float(x) for x in v) if np.ndim(v) else float(v)

    shape = [(s.metallic, s.roughness, s.ior, s.specular_tint, s.multiscatter, s.constant_fresnel)
             for _, s in lit]
    exact = all(x == shape[0] for x in shape)
    one = lit[0][1] if len(lit) == 1 else Surface()
    exact = exact and same_alpha and (len(lit) == 1 or not any(s.textured for _, s in lit))
    return Surface(base_texture=one.base_texture, roughness_texture=one.roughness_texture,
                   metallic_texture=one.metallic_texture, base_color=mean(lambda s: s.base_color),
                   metallic=mean(lambda s: s.metallic),
                   roughness=mean(lambda s: s.roughness), ior=mean(lambda s: s.ior),
                   specular_tint=mean(lambda s: s.specular_tint), weight=total, emission=emission,
                   multiscatter=lit[0][1].multiscatter,
                   constant_fresnel=lit[0][1].constant_fresnel, alpha=alpha), exact


def table_note(meshes) -> list[str]:
    """The report's line when the camera sees more distinct surfaces than the table holds."""
    count = len({m.shading for m in meshes if not m.holdout})
    if count <= MAX_MATERIALS:
        return []
    return [f"{count} distinct surfaces are seen: the first {MAX_MATERIALS - 1} are shaded as set, the "
            f"others all as one of them"]


def material_table(surfaces: list[Surface]) -> bytes:
    """The uniform block of the frame's surfaces (std140: MAX_MATERIALS x 4 vec4)."""
    data = np.zeros((MAX_MATERIALS, 16), np.float32)
    for i, s in enumerate(surfaces[:MAX_MATERIALS]):
        data[i] = s.entry()
    return data.tobytes()


# ---- the directional albedo tables ----------------------------------------------------------

def _fresnel_dielectric_cos(c, eta):
    """Cycles' ``fresnel_dielectric_cos`` (1 past total internal reflection)."""
    c = np.abs(c)
    g = eta * eta - 1.0 + c * c
    ok = g > 0.0
    g = np.sqrt(np.where(ok, g, 1.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(ok, 0.5 * a * a * (1.0 + b * b), 1.0)


def _vndf_samples(rough: float, mu: float, k: int):
    """Microfacet normals H drawn from GGX's visible normals for the view (sqrt(1 - mu²), 0, mu)
    at the k x k stratified points (Heitz 2018, as Cycles samples them): (H, wo, valid, G2/G1)."""
    alpha = max(rough * rough, 1e-7)
    wi = np.array([np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    wi_ = np.array([alpha * wi[0], alpha * wi[1], wi[2]])
    wi_ /= np.linalg.norm(wi_)
    lensq = wi_[0] ** 2 + wi_[1] ** 2
    t1 = np.array([-wi_[1], wi_[0], 0.0]) / np.sqrt(lensq) if lensq > 1e-7 else np.array([1.0, 0.0, 0.0])
    t2 = np.cross(wi_, t1)
    u = (np.arange(k) + 0.5) / k
    u1, u2 = (a.ravel() for a in np.meshgrid(u, u, indexing="ij"))
    # concentric disk
    a, b = 2.0 * u1 - 1.0, 2.0 * u2 - 1.0
    first = np.abs(a) > np.abs(b)
    r = np.where(first, a, b)
    phi = np.where(first, (np.pi / 4) * b / np.where(a == 0, 1, a),
                   np.pi / 2 - (np.pi / 4) * a / np.where(b == 0, 1, b))
    tx, ty = r * np.cos(phi), r * np.sin(phi)
    m = 0.5 * (1.0 + wi_[2])
    ty = (1.0 - m) * np.sqrt(np.maximum(1.0 - tx * tx, 0.0)) + m * ty
    h_ = (tx[:, None] * t1 + ty[:, None] * t2
          + np.sqrt(np.maximum(1.0 - tx * tx - ty * ty, 0.0))[:, None] * wi_)
    h = np.stack([alpha * h_[:, 0], alpha * h_[:, 1], np.maximum(h_[:, 2], 0.0)], -1)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    cos_hi = h @ wi
    wo = 2.0 * cos_hi[:, None] * h - wi
    valid = wo[:, 2] > 0.0

    def lam(cos):
        cos = np.clip(cos, 1e-7, 1.0)
        return 0.5 * (np.sqrt(1.0 + alpha * alpha * np.maximum(1.0 / (cos * cos) - 1.0, 0.0)) - 1.0)

    g2_over_g1 = (1.0 + lam(mu)) / (1.0 + lam(mu) + lam(wo[:, 2]))
    return cos_hi, valid, g2_over_g1


def compute_ggx_tables(k: int = 256) -> dict[str, np.ndarray]:
    """Cycles' microfacet tables, on its grids (axis value i/(n-1), clamped as it clamps them):
    'E' (32, 32) [mu, rough] the GGX albedo with F = 1; 'Eavg' (32,) its cosine-weighted mean;
    's_ior' (16, 16, 16) [z, mu, rough] the mean Fresnel interpolation factor of the dielectric
    curve (IOR from z: F0 = z⁴); 's5' (16, 16) [mu, rough] that of the Schlick curve (exponent 5)."""
    def axis(n, hi=1.0):
        return np.clip(np.arange(n) / (n - 1), 1e-4, hi)

    e = np.zeros((E_SIZE, E_SIZE))
    for j, mu in enumerate(axis(E_SIZE)):
        for i, r in enumerate(axis(E_SIZE)):
            _, valid, w = _vndf_samples(r, mu, k)
            e[j, i] = np.mean(np.where(valid, w, 0.0))
    mus = (np.arange(256) + 0.5) / 256
    eavg = np.zeros(E_SIZE)
    for i in range(E_SIZE):
        rows = np.array([np.interp(mu, axis(E_SIZE), e[:, i]) for mu in mus])
        eavg[i] = np.mean(2.0 * mus * rows)
    zs = axis(S_SIZE, 0.99)
    etas = np.array([ior_from_f0(z ** 4) for z in zs])
    f0s = np.array([f0_from_ior(eta) for eta in etas])
    s_ior = np.zeros((S_SIZE, S_SIZE, S_SIZE))
    s5 = np.zeros((S_SIZE, S_SIZE))
    for j, mu in enumerate(axis(S_SIZE)):
        for i, r in enumerate(axis(S_SIZE)):
            cos_hi, valid, _ = _vndf_samples(r, mu, k)
            s5[j, i] = np.mean(np.where(valid, np.clip(1.0 - cos_hi, 0.0, 1.0) ** 5, 0.0))
            f = _fresnel_dielectric_cos(cos_hi[None, :], etas[:, None])
            s = np.clip((f - f0s[:, None]) / (1.0 - f0s[:, None]), 0.0, 1.0)
            s_ior[:, j, i] = np.mean(np.where(valid[None, :], s, 0.0), axis=1)
    return {"E": e.astype(np.float32), "Eavg": eavg.astype(np.float32),
            "s_ior": s_ior.astype(np.float32), "s5": s5.astype(np.float32)}


TABLES = Path(__file__).resolve().parent / "data" / "ggx_tables.npz"


def ggx_tables() -> dict[str, np.ndarray]:
    """The tables of ``compute_ggx_tables``, as scripts/make_ggx_tables.py stored them (read once)."""
    def read():
        with np.load(TABLES) as f:
            return {k: f[k] for k in f.files}

    return _TABLES.made(str(TABLES), read)


_TABLES = caches.memo("surface.ggx tables", 1)


def table_blocks() -> tuple[bytes, bytes]:
    """The tables as two std140 uniform blocks of vec4s: (s_ior), (E, Eavg, s5)."""
    t = ggx_tables()
    first = t["s_ior"].ravel()
    second = np.concatenate([t["E"].ravel(), t["Eavg"].ravel(), t["s5"].ravel()])
    return first.tobytes(), second.tobytes()
