"""Acceleration structures: a 4-wide (or 8-wide) BVH built in numpy for the GLSL traversal.

``build_bvh`` (no GL) is the entry point; ``glrender.gpu.bvh_upload.GpuBvh`` uploads
the result as buffer textures.
"""
from .bvh import Bvh, build_bvh
from .instances import MotionInstance, flatten_instances

__all__ = ["Bvh", "MotionInstance", "build_bvh", "flatten_instances"]
