"""The distributed tests keep the unit-size calibration cache in a temporary folder
(glrender.distributed.calibrate), never in the user's cache."""
import os

import pytest


@pytest.fixture(scope="session", autouse=True)
def unit_size_cache(tmp_path_factory):
    old = os.environ.get("GLRENDER_CACHE_DIR")
    os.environ["GLRENDER_CACHE_DIR"] = str(tmp_path_factory.mktemp("glrender-cache"))
    yield os.environ["GLRENDER_CACHE_DIR"]
    if old is None:
        del os.environ["GLRENDER_CACHE_DIR"]
    else:
        os.environ["GLRENDER_CACHE_DIR"] = old
