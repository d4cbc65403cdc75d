"""Several OpenGL contexts in one process (another device, a command run in-process): GL
calls go to the context current on the thread, so every renderer makes its own current at
each entry point. A renderer made before another context, one made after it, and two used
in turn all render the bits a renderer alone in the process renders."""
from __future__ import annotations

import numpy as np

from glrender.gl.context import create_context
from glrender.render.renderer import Renderer, settings_from_scene
from test_share import small_textured  # the textured Cornell box with a BVH mesh


def test01_renderers_on_two_contexts_render_the_same_bits(gl_ctx):
    scene = small_textured()
    settings = settings_from_scene(scene, spp=4, seed=1, integrator="path")
    with Renderer(scene, settings, ctx=gl_ctx) as alone:
        alone.step(4)
        expected = alone.film()
    first = Renderer(scene, settings, ctx=gl_ctx)     # before the second context exists
    other = create_context()                          # current on this thread from here
    try:
        second = Renderer(scene, settings, ctx=other)
        late = Renderer(scene, settings, ctx=gl_ctx)  # the first context, after the second
        for _ in range(4):                            # in turn, a sample each
            for r in (first, second, late):
                r.step(1)
        for r in (first, second, late):
            film = r.film()
            assert film.spp == 4
            np.testing.assert_array_equal(film.mean, expected.mean)
            np.testing.assert_array_equal(film.variance, expected.variance)
            r.release()
    finally:
        other.gl.release()
        gl_ctx.make_current()     # the session's context for the tests that follow
