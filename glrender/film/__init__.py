"""The rendered image: accumulation read back, resolved, tonemapped and written."""
from .film import Film
from .io import read_image, write_image

__all__ = ["Film", "read_image", "write_image"]
