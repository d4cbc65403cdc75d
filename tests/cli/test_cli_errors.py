"""Every user error: exit code 2, one line naming the problem and the fix, no traceback."""
from __future__ import annotations

import pytest

from cli_run import CORNELL, ROOT, glrender, one_error_line

SMALL = ["--width", 16, "--height", 16, "--spp", 1]


def case(tmp, name):
    """Arguments of each error case (built in the test's folder)."""
    out = tmp / "out.png"
    bad_toml = tmp / "bad.toml"
    bad_toml.write_text("[film\nwidth = 3\n")
    unknown = tmp / "scene.xyz"
    unknown.write_text("whatever")
    afile = tmp / "afile"
    afile.write_text("")
    return {
        "missing scene": (["render", tmp / "nope.toml", "-o", out], ["nope.toml", "no such scene file"]),
        "scene is a folder": (["render", CORNELL.parent, "-o", out], ["is a folder", "scene.toml"]),
        "unreadable scene": (["render", bad_toml, "-o", out], ["bad.toml", "invalid TOML"]),
        "unknown scene format": (["render", unknown, "-o", out], ["unsupported scene format .xyz"]),
        "unknown output format": (["render", CORNELL, "-o", tmp / "out.tiff"],
                                  ["unknown output format .tiff", ".exr"]),
        "unknown integrator": (["render", CORNELL, "--integrator", "radiosity"],
                               ["--integrator", "invalid choice: 'radiosity'", "--help"]),
        "unknown tone curve": (["render", CORNELL, "--tonemap", "reinhard"], ["--tonemap", "reinhard"]),
        "unknown aov": (["render", CORNELL, "-o", out, "--aov", "albedo,motion"],
                        ["unknown AOV motion", "albedo,normal,depth,emission,variance"]),
        "bad spp": (["render", CORNELL, "-o", out, "--spp", "0"], ["--spp 0", "positive"]),
        "bad time": (["render", CORNELL, "-o", out, "--time", "-1"], ["--time -1", "positive"]),
        "bad max depth": (["render", CORNELL, "-o", out, "--max-depth", "0"], ["--max-depth 0", "-1"]),
        "not a number": (["render", CORNELL, "--spp", "many"], ["--spp", "invalid int value: 'many'"]),
        "bad define": (["render", CORNELL, "-o", out, "-D", "roughness"], ["-D roughness", "KEY=VALUE"]),
        "output folder missing": (["render", CORNELL, "-o", tmp / "no" / "out.png"],
                                  ["does not exist", "create it first"]),
        "output folder is a file": (["render", CORNELL, "-o", afile / "out.png"], ["is a file, not a folder"]),
        "output folder read-only": (["render", CORNELL, "-o", "/proc/out.png"], ["cannot write", "/proc"]),
        "output is a folder": (["render", CORNELL, "-o", tmp / "dir.png"], ["is a folder"]),
        "stats is a folder": (["render", CORNELL, "-o", out, "--stats", tmp / "dir.png"],
                              ["is a folder", "statistics"]),
        "no such device": (["render", CORNELL, "-o", out, "--device", "99", *SMALL], ["no EGL device #99"]),
        "bad device": (["render", CORNELL, "-o", out, "--device", "fast", *SMALL],
                       ["expected auto, cpu, gpu or a device index"]),
        "out of memory": (["render", CORNELL, "-o", out, "--width", "65536", "--height", "65536"],
                          ["65536x65536", "GiB", "--width/--height"]),
        "resume without checkpoint": (["render", CORNELL, "-o", out, "--resume"],
                                      ["out.png.ckpt", "no checkpoint", "without --resume"]),
        "no command": ([], ["required", "COMMAND"]),
    }[name]


CASES = ["missing scene", "scene is a folder", "unreadable scene", "unknown scene format",
         "unknown output format", "unknown integrator", "unknown tone curve", "unknown aov",
         "bad spp", "bad time", "bad max depth", "not a number", "bad define",
         "output folder missing", "output folder is a file", "output folder read-only",
         "output is a folder", "stats is a folder", "no such device", "bad device", "out of memory",
         "resume without checkpoint", "no command"]


@pytest.mark.parametrize("name", CASES)
def test01_error_is_one_line_with_exit_2(tmp_path, name):
    (tmp_path / "dir.png").mkdir()
    args, expected = case(tmp_path, name)
    line = one_error_line(glrender(*args, timeout=60))
    assert line.startswith("glrender") and "error:" in line, line
    for text in expected:
        assert text in line, (text, line)
    assert not list(tmp_path.glob("*.part*"))     # no temporary files left


def test02_debug_shows_the_traceback(tmp_path):
    r = glrender("render", tmp_path / "nope.toml", "-o", tmp_path / "o.png", "--debug")
    assert r.returncode == 2
    assert "Traceback" in r.stderr and r.stderr.strip().splitlines()[-1].startswith("glrender: error:")


def test03_errors_in_other_commands(tmp_path):
    line = one_error_line(glrender("sampling", "--out", tmp_path, "--samples", "10"))
    assert "--samples 10" in line
    line = one_error_line(glrender("info", "--device", "99"))
    assert "no EGL device #99" in line


def test04_environment_device(tmp_path):
    import os

    env = {**os.environ, "GLRENDER_DEVICE": "warp-drive"}
    line = one_error_line(glrender("render", CORNELL, "-o", tmp_path / "o.png", *SMALL, env=env))
    assert "GLRENDER_DEVICE" in line and "warp-drive" in line
    assert ROOT.exists()


# Each optional extra, missing: (the command, the module made unimportable, the extra).
MISSING_EXTRAS = [
    (["preview", CORNELL], "glfw", "preview"),
    (["render", CORNELL, "-o", "{tmp}/o.png", "--denoise", *SMALL], "pyoidn", "denoise"),
    (["lab", "--out", "{tmp}/lab", "--quick"], "matplotlib", "lab"),
    (["render", CORNELL, "-o", "{tmp}/o.exr", *SMALL], "OpenEXR", "exr"),
    (["render", CORNELL, "-o", "{tmp}/o.png", "--workers", "2", *SMALL], "distributed", "distributed"),
]
_WITHOUT = ("import sys; sys.modules[sys.argv[1]] = None; "     # `import NAME` raises ImportError
            "from glrender.commands.cli import main; sys.exit(main(sys.argv[2:]))")


@pytest.mark.parametrize("argv, module, extra", MISSING_EXTRAS, ids=[m for _, m, _ in MISSING_EXTRAS])
def test05_missing_extra_names_the_install_command(tmp_path, monkeypatch, argv, module, extra):
    import subprocess
    import sys

    from glrender.errors import install_command

    monkeypatch.chdir(ROOT)              # from the checkout: ".venv/bin/python ... -e '.[EXTRA]'"
    args = [str(a).replace("{tmp}", str(tmp_path)) for a in argv]
    r = subprocess.run([sys.executable, "-c", _WITHOUT, module, *args], capture_output=True,
                       text=True, timeout=60)
    line = one_error_line(r)
    assert line.startswith("glrender: error: ") and f"needs the {module}" in line, line
    assert line.endswith(f"install it with: {install_command(extra)}"), line
    assert not list(tmp_path.rglob("*.png")) and not list(tmp_path.rglob("*.exr"))
