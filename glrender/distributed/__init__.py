"""Scale-out on Dask: a render split into units (frame, band of tile rows, sample range)
that Dask schedules on a cluster's workers, merged there in a fixed order.

    from dask.distributed import Client
    import glrender.distributed

    result = glrender.distributed.render("scene.toml", client=Client("tcp://host:8786"), spp=256)
    film = result.films[None]        # frames of an animation: result.films[frame]

Needs the optional extra ``distributed`` (``pip install 'glrender[distributed]'``).
See docs/scale-out.md.
"""
from .client import Result, connect, local_cluster, render
from .plan import Plan, Unit, default_unit_size

__all__ = ["Plan", "Result", "Unit", "connect", "default_unit_size", "local_cluster", "render"]
