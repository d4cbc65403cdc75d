"""GLSL sources of glrender (data only; found through importlib.resources)."""
