"""The metallic-roughness model (glTF 2.0, and OBJ's PBR extension ``Pr``/``Pm``) mapped onto
the renderer's BSDFs; one rule for every loader that reads it, and for the device, which
applies it per surface point where a texture varies metallic and roughness
(``shaders/bsdf/metallic_roughness.glsl``, checked against :func:`metallic_roughness_bsdf`
by tests/bsdf/test_metallic_roughness.py):

- transmission > 0: a (rough) dielectric of IOR ``ior``, tinted by the base colour;
- metallic >= 0.5: a (rough) conductor that reflects the base colour (texture included);
- otherwise: a (rough) plastic with the base colour (texture included) as its diffuse
  reflectance and IOR 1.5;
- roughness r (clamped to [0, 1]) becomes GGX alpha = max(r^2, 1e-3) (glTF's convention);
  below r = 0.03 the smooth BSDF.

A hard switch at metallic 1/2 rather than glTF's linear blend of the two lobes: texels of
real assets are 0 or 1 except along the edges between metal and dielectric, and each
point stays one of the renderer's BSDFs, with their sampling and their tests.
"""
from __future__ import annotations

from .. import model as m

SMOOTH_ROUGHNESS = 0.03
METALLIC_THRESHOLD = 0.5
MIN_ALPHA = 1e-3
PLASTIC_IOR = 1.5


def metallic_roughness_bsdf(metallic: float, roughness: float) -> tuple[str, float]:
    """The BSDF kind and GGX alpha of an opaque point of ``metallic`` and ``roughness``."""
    roughness = min(max(float(roughness), 0.0), 1.0)
    alpha = max(roughness * roughness, MIN_ALPHA)
    smooth = roughness < SMOOTH_ROUGHNESS
    if metallic >= METALLIC_THRESHOLD:
        return ("conductor" if smooth else "roughconductor"), alpha
    return ("plastic" if smooth else "roughplastic"), alpha


def metallic_roughness_kinds(metallic: tuple[float, float], roughness: tuple[float, float]) -> set[str]:
    """Every kind :func:`metallic_roughness_bsdf` gives for values in the ranges (lo, hi)."""
    return {metallic_roughness_bsdf(mv, rv)[0] for mv in metallic for rv in roughness}


def metallic_roughness_material(color: tuple | m.Texture, metallic: float, roughness: float, *,
                                ior: float = 1.5, transmission: float = 0.0, two_sided: bool = False,
                                name: str = "") -> m.Material:
    """The material for base ``color`` (RGB or a texture), ``metallic`` and ``roughness``
    in [0, 1] (roughness is clamped there), ``ior`` and ``transmission`` (> 0: glass)."""
    kind, alpha = metallic_roughness_bsdf(metallic, roughness)
    smooth = kind in ("conductor", "plastic")
    if transmission > 0:
        return m.Material("dielectric" if smooth else "roughdielectric", int_ior=ior, ext_ior=1.0,
                          alpha=(alpha, alpha), distribution="ggx",
                          specular_transmittance=color if not isinstance(color, m.Texture) else (1, 1, 1),
                          name=name)
    if kind in ("conductor", "roughconductor"):
        return m.Material(kind, eta=(0.0, 0.0, 0.0), k=(1.0, 1.0, 1.0), specular_reflectance=color,
                          alpha=(alpha, alpha), distribution="ggx", two_sided=two_sided, name=name)
    return m.Material(kind, reflectance=color, int_ior=PLASTIC_IOR, ext_ior=1.0,
                      alpha=(alpha, alpha), distribution="ggx", two_sided=two_sided, name=name)


def textured_metallic_roughness_material(color: tuple | m.Texture, metallic_roughness: m.Texture, *,
                                         two_sided: bool = False, name: str = "") -> m.Material:
    """An opaque material whose metallic (blue) and roughness (green) vary with the raw
    texture ``metallic_roughness`` (factors multiplied in): the rule above per point."""
    return m.Material("metallicroughness", reflectance=color, metallic_roughness=metallic_roughness,
                      specular_reflectance=(1.0, 1.0, 1.0), int_ior=PLASTIC_IOR, ext_ior=1.0,
                      distribution="ggx", two_sided=two_sided, name=name)
