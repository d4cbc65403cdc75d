"""Synthetic scenes shared by the statistical tests and the benchmarks (beside the lab's own
scenes): a street between two walls and the lamps above it."""
from __future__ import annotations

from ..scene import model as m


def street(scene: m.Scene) -> int:
    """Furnish ``scene`` as a street 40 long and 8 wide between two walls, seen along its
    length from one end: the camera, a glossy floor and the two diffuse walls (the lights are
    the caller's). Returns the index of a black material for the caller's emitters."""
    scene.camera = m.Camera(world_from_camera=m.look_at((0, -21, 2.5), (0, 0, 0.5), (0, 0, 1)), fov=50)
    floor = scene.add_material(m.Material("roughconductor", eta=(0.2, 0.9, 1.1), k=(3.9, 2.4, 2.2),
                                          alpha=(0.2, 0.2), distribution="ggx"))
    wall = scene.add_material(m.Material("diffuse", reflectance=(0.6, 0.6, 0.55)))
    black = scene.add_material(m.Material("diffuse", reflectance=(0.0, 0.0, 0.0)))
    scene.shapes.append(m.Shape("rectangle", material=floor, world_from_object=m.scale((4.0, 20.0, 1.0))))
    for side in (-1, 1):
        scene.shapes.append(m.Shape("rectangle", material=wall, world_from_object=(
            m.translate((4 * side, 0, 3)) @ m.rotate((0, 1, 0), -90 * side) @ m.scale((3.0, 20.0, 1.0)))))
    return black


def street_lamp(rng, spot: bool) -> m.Light:
    """A lamp above the street: a point light, or a spot shining straight down (35 degrees),
    its intensity log-uniform over three decades; draws from ``rng`` in a fixed order."""
    position = (rng.uniform(-3, 3), rng.uniform(-19, 19), rng.uniform(3, 5))
    intensity = tuple(10 ** rng.uniform(0, 3) * rng.uniform(0.5, 1.0, 3) * 0.01)
    if not spot:
        return m.Light("point", position=position, intensity=intensity)
    target = (position[0], position[1], 0.0)
    return m.Light("spot", world_from_light=m.look_at(position, target, (0, 1, 0)),
                   intensity=intensity, cutoff_angle=35.0, beam_width=25.0)
