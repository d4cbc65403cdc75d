"""Package discovery for glrender.

The GLSL sources live in the top-level ``shaders/`` folder and ship inside the
package as ``glrender.shaders``, so they are found through importlib.resources
in a wheel and in an editable install alike, never through the current directory.
"""
from setuptools import find_packages, setup

setup(
    packages=find_packages(include=["glrender", "glrender.*"]) + ["glrender.shaders"],
    package_dir={"glrender.shaders": "shaders"},
)
