"""The context factory: device choice, requirements, info, and `glrender info`."""
import json
import os
import subprocess
import sys

import pytest

from glrender.errors import DeviceError
from glrender.gl import egl
from glrender.gl.context import candidate_devices, parse_device


def run_cli(*args, env=None):
    full_env = dict(os.environ, **(env or {}))
    return subprocess.run([sys.executable, "-m", "glrender", *args], capture_output=True,
                          text=True, env=full_env, timeout=120)


def test01_parse_device(monkeypatch):
    assert parse_device("auto") == "auto"
    assert parse_device(" CPU ") == "cpu"
    assert parse_device("1") == 1
    assert parse_device(0) == 0
    monkeypatch.setenv("GLRENDER_DEVICE", "gpu")
    assert parse_device(None) == "gpu"
    monkeypatch.setenv("GLRENDER_DEVICE", "fast")
    with pytest.raises(DeviceError, match="GLRENDER_DEVICE: expected auto, cpu, gpu"):
        parse_device(None)


def test02_device_list_has_llvmpipe():
    devices = egl.list_devices()
    assert any(d.software for d in devices), devices
    assert [d.index for d in devices] == list(range(len(devices)))


def test03_candidates():
    devices = egl.list_devices()
    assert candidate_devices("cpu")[0].software
    auto = candidate_devices("auto")
    assert auto[-1].software and len(auto) == len(devices)
    with pytest.raises(DeviceError, match=f"no EGL device #{len(devices)}"):
        candidate_devices(len(devices))
    if not any(not d.software for d in devices):
        with pytest.raises(DeviceError, match="no GPU EGL device"):
            candidate_devices("gpu")


def test04_info_reports_limits(gl_ctx):
    info = gl_ctx.info()
    assert info["GL_RENDERER"]
    assert info["limits"]["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"] >= 2 ** 24
    assert info["limits"]["GL_MAX_TEXTURE_BUFFER_SIZE"] >= 2 ** 16
    assert len(info["limits"]["GL_MAX_COMPUTE_WORK_GROUP_COUNT"]) == 3
    assert info["limits"]["GL_MAX_COMPUTE_SHARED_MEMORY_SIZE"] >= 16384
    major, minor = gl_ctx.gl.version_code // 100, gl_ctx.gl.version_code // 10 % 10
    assert (major, minor) >= (4, 3)


def test05_cli_info_names_the_device():
    result = run_cli("info", "--device", "cpu")
    assert result.returncode == 0, result.stderr
    assert "llvmpipe" in result.stdout
    result = run_cli("info", "--json", "--device", "cpu")
    data = json.loads(result.stdout)
    assert data["device"]["kind"] == "cpu" and "llvmpipe" in data["GL_RENDERER"]
    assert data["devices"] and data["llvmpipe_threads"] >= 1
    # which traversal runs: llvmpipe has the subgroup ballots the cooperative one needs
    assert data["extensions"]["GL_ARB_shader_ballot"]
    assert data["traversal"].startswith("4-wide BVH, per lane") and "available" in data["traversal"]
    assert "traversal:       4-wide BVH" in run_cli("info", "--device", "cpu").stdout


def test06_unavailable_device_fails_in_one_line():
    devices = egl.list_devices()
    if any(not d.software for d in devices):  # a GPU machine: ask for a device that is not there
        choice, expected = str(len(devices)), f"glrender: error: no EGL device #{len(devices)}"
    else:
        choice, expected = "gpu", "glrender: error: no GPU EGL device"
    result = run_cli("info", env={"GLRENDER_DEVICE": choice})
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(expected), result.stderr
    assert "Traceback" not in result.stderr


def test07_bad_device_value_is_one_line():
    result = run_cli("info", "--device", "warp")
    assert result.returncode == 2
    assert result.stderr.strip() == ("glrender: error: device: expected auto, cpu, gpu or a "
                                     "device index, got 'warp'")


def test08_missing_egl_names_the_package(monkeypatch):
    egl.library_paths.cache_clear()
    monkeypatch.setattr(egl.ctypes.util, "find_library", lambda name: None)
    try:
        with pytest.raises(DeviceError, match="apt-get install libegl1"):
            egl.library_paths()
    finally:
        egl.library_paths.cache_clear()
