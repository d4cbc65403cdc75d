"""``glrender sampling`` writes a picture per 2D warp, the disk comparison and the chi2 table."""
import numpy as np
import pytest
from PIL import Image

from glrender.commands.cli import main
from glrender.sampling.catalog import CATALOG
from glrender.sampling.plots import STRATA, jittered_grid


def test01_jittered_grid_has_one_point_per_stratum():
    p = jittered_grid(STRATA, np.random.default_rng(0))
    cells = np.floor(p * STRATA).astype(int)
    assert len(np.unique(cells[:, 0] * STRATA + cells[:, 1])) == STRATA * STRATA
    assert np.all((p >= 0) & (p < 1))


@pytest.mark.slow
def test02_sampling_command_writes_every_plot(gl_ctx, tmp_path, capsys):
    out = tmp_path / "plots"
    assert main(["sampling", "--out", str(out), "--seed", "3", "--samples", "20000"]) == 0
    assert capsys.readouterr().out.strip() == str(out.resolve())
    planar = [w for w in CATALOG if w.plot != "none"]
    for warp in planar:
        image = Image.open(out / f"{warp.name}.png")
        assert image.width > 2 * image.height * 0.9  # two panels side by side
        # the points are drawn: many non-white, non-grey (coloured) pixels
        rgb = np.asarray(image.convert("RGB")).astype(int)
        coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 60
        assert coloured.sum() > 2000, warp.name
    assert Image.open(out / "disks.png").size[0] > 4 * 300
    table = (out / "chi2.md").read_text()
    rows = [line for line in table.splitlines() if line.startswith("| ") and "---" not in line][1:]
    assert [r.split("|")[1].strip() for r in rows] == [w.name for w in CATALOG]
    assert all(r.rstrip(" |").endswith("accepted") for r in rows), table


def test03_bad_sample_count_is_a_usage_error(tmp_path, capsys):
    assert main(["sampling", "--out", str(tmp_path), "--samples", "10"]) == 2
    assert "at least 1000" in capsys.readouterr().err
