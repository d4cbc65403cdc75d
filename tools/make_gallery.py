"""Render the README's gallery into docs/images/ with the command line, one command per image.

    python tools/make_gallery.py [NAME ...]      # all images, or the named ones

Each entry is the command the README shows under its image (with ``--seed 1``; run here
with this Python's ``-m glrender``); an entry with a ``pick`` writes into a scratch folder and
copies one file of it to docs/images/. The sizes and sample counts keep each image under a
minute on two llvmpipe cores and the PNGs small. The seconds each took are printed.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"


@dataclass(frozen=True)
class Shot:
    name: str          # docs/images/NAME.png
    args: str          # the command after ``glrender``; {out} is the output, {dir} a scratch folder
    pick: str = ""     # the file of {dir} that becomes the image, when the command writes a folder


GALLERY = [
    Shot("caustic", "render scenes/caustic/scene.toml -o {out} --integrator sppm "
                    "--iterations 96 --photons 65536 --width 320 --seed 1"),
    Shot("door", "render scenes/door/scene.toml -o {out} --integrator bdpt --spp 144 "
                 "--width 320 --exposure 1.5 --seed 1"),
    Shot("depth-of-field", "render scenes/depth-of-field/scene.toml -o {out} --spp 128 "
                           "--width 384 --seed 1"),
    Shot("motion-blur", "render scenes/motion-blur/scene.toml -o {out} --spp 256 "
                        "--width 384 --seed 1"),
    Shot("envmap", "render scenes/envmap/scene.toml -o {out} --spp 256 --width 384 --seed 1"),
    Shot("veach-mis", "render scenes/veach-mis/scene.toml -o {out} --spp 128 --width 384 "
                      "--seed 1"),
    Shot("sampling-disks", "sampling --out {dir} --samples 100000 --seed 1", pick="disks.png"),
    Shot("bdpt-strategies", "render scenes/cornell-box/scene.toml -o {dir}/cornell.png "
                            "--integrator bdpt --spp 64 --width 96 --exposure 2 "
                            "--strategy-images {dir}/strategies --seed 1",
         pick="strategies/weighted.png"),
]


def render(shot: Shot) -> float:
    """Run one entry's command and put its image at docs/images/NAME.png; return seconds."""
    out = IMAGES / f"{shot.name}.png"
    with tempfile.TemporaryDirectory() as scratch:
        args = shot.args.format(out=out.relative_to(ROOT).as_posix(), dir=scratch).split()
        t0 = time.perf_counter()
        quiet = ["--quiet"] if args[0] == "render" else []
        subprocess.run([sys.executable, "-m", "glrender", *args, *quiet], cwd=ROOT, check=True,
                       stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - t0
        if shot.pick:
            shutil.copyfile(Path(scratch) / shot.pick, out)
    return seconds


def main(names: list[str]) -> None:
    known = {shot.name for shot in GALLERY}
    unknown = set(names) - known
    if unknown:
        sys.exit(f"make_gallery: unknown image {sorted(unknown)}; one of {sorted(known)}")
    IMAGES.mkdir(parents=True, exist_ok=True)
    for shot in GALLERY:
        if names and shot.name not in names:
            continue
        seconds = render(shot)
        size = (IMAGES / f"{shot.name}.png").stat().st_size
        print(f"{shot.name:16s} {seconds:6.1f} s  {size / 1024:6.0f} KB  glrender {shot.args}",
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
