"""The metallic-roughness model (glTF 2.0, and OBJ's PBR extension ``Pr``/``Pm``) mapped onto
the renderer's BSDFs; one rule for every loader that reads it:

- transmission > 0: a (rough) dielectric of IOR ``ior``, tinted by the base colour;
- metallic >= 0.5: a (rough) conductor that reflects the base colour (texture included);
- otherwise: a (rough) plastic with the base colour (texture included) as its diffuse
  reflectance and IOR 1.5;
- roughness r becomes GGX alpha = r^2 (glTF's convention); below r = 0.03 the smooth BSDF.
"""
from __future__ import annotations

from .. import model as m

SMOOTH_ROUGHNESS = 0.03


def metallic_roughness_material(color: tuple | m.Texture, metallic: float, roughness: float, *,
                                ior: float = 1.5, transmission: float = 0.0, two_sided: bool = False,
                                name: str = "") -> m.Material:
    """The material for base ``color`` (RGB or a texture), ``metallic`` and ``roughness``
    in [0, 1] (roughness is clamped there), ``ior`` and ``transmission`` (> 0: glass)."""
    roughness = min(max(float(roughness), 0.0), 1.0)
    alpha = max(roughness * roughness, 1e-3)
    smooth = roughness < SMOOTH_ROUGHNESS
    if transmission > 0:
        return m.Material("dielectric" if smooth else "roughdielectric", int_ior=ior, ext_ior=1.0,
                          alpha=(alpha, alpha), distribution="ggx",
                          specular_transmittance=color if not isinstance(color, m.Texture) else (1, 1, 1),
                          name=name)
    if metallic >= 0.5:
        return m.Material("conductor" if smooth else "roughconductor", eta=(0.0, 0.0, 0.0),
                          k=(1.0, 1.0, 1.0), specular_reflectance=color, alpha=(alpha, alpha),
                          distribution="ggx", two_sided=two_sided, name=name)
    return m.Material("plastic" if smooth else "roughplastic", reflectance=color, int_ior=1.5,
                      ext_ior=1.0, alpha=(alpha, alpha), distribution="ggx", two_sided=two_sided,
                      name=name)
