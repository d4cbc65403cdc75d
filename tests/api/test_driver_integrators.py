"""Integrators with their own driver (SPPM, photon mapping) are refused by Renderer with a one-line pointer
to that driver, not a KeyError."""
from __future__ import annotations

from pathlib import Path

import pytest

import glrender
from glrender.errors import UsageError

CORNELL = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "scene.toml"


def test01_sppm_through_render_is_a_usage_error(gl_ctx):
    with pytest.raises(UsageError, match=r"integrator 'sppm' has its own driver.*SppmRenderer"):
        glrender.render(CORNELL, spp=1, integrator="sppm")


def test02_photon_through_render_is_a_usage_error(gl_ctx):
    with pytest.raises(UsageError, match=r"integrator 'photon' has its own driver.*PhotonRenderer"):
        glrender.render(CORNELL, spp=1, integrator="photon")
