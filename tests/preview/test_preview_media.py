"""The preview on a scene with participating media: key I cycles only through the
integrators that render media (the others would refuse the scene), and elsewhere through
them all."""
from types import SimpleNamespace

from glrender import integrators
from glrender.preview.app import INTEGRATOR_ORDER, PreviewApp
from glrender.scene import model as m


def test01_key_i_cycles_the_integrators_that_render_the_scene():
    scene = m.Scene()
    null = scene.add_material(m.Material("null"))
    scene.shapes.append(m.Shape("sphere", material=null))
    app = SimpleNamespace(scene=scene)
    assert PreviewApp._integrator_order(app) == tuple(INTEGRATOR_ORDER)
    scene.shapes[0].interior = scene.add_medium(m.Medium())
    order = PreviewApp._integrator_order(app)
    assert order and "path" in order and all(integrators.get(n).media for n in order)
    assert "ao" not in order and "bdpt" in order
