"""The interactive preview window (``glrender preview``): progressive rendering you can steer.

- :mod:`.app`: the window's frame loop, input handling, title and screenshots;
- :mod:`.progressive`: samples added within a time budget per frame;
- :mod:`.display`: the display pass (tonemapping on the device, straight from the
  accumulation buffers);
- :mod:`.camera`: orbit, pan, zoom and fly;
- :mod:`.keys`: the key and mouse bindings;
- :mod:`.command`: the command line.

The window's context comes from ``glrender.gl.context.create_window_context`` (glfw,
the ``preview`` extra).
"""
