"""Shared fixtures: one OpenGL context per test session, test data paths, CI rules."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"
IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")


@pytest.fixture(scope="session", autouse=True)
def glrender_cache(tmp_path_factory):
    """glrender's caches (the unit-size calibration, built BVHs and normals) in a temporary
    folder, never in the user's: the suite neither reads what other runs left nor leaves
    anything."""
    old = os.environ.get("GLRENDER_CACHE_DIR")
    os.environ["GLRENDER_CACHE_DIR"] = str(tmp_path_factory.mktemp("glrender-cache"))
    yield os.environ["GLRENDER_CACHE_DIR"]
    if old is None:
        del os.environ["GLRENDER_CACHE_DIR"]
    else:
        os.environ["GLRENDER_CACHE_DIR"] = old


@pytest.fixture(scope="session")
def gl_ctx():
    """The session's OpenGL context (the device from $GLRENDER_DEVICE, else auto)."""
    from glrender.gl.context import default_context

    return default_context()


@pytest.fixture(scope="session")
def shader_library():
    """Packaged shaders plus the test-only shaders in tests/data/shaders."""
    from glrender.gl.shaders import ShaderLibrary

    return ShaderLibrary([DATA / "shaders"])


@pytest.fixture
def chi2_dir(tmp_path, monkeypatch):
    """Chi-square failure plots go to the test's temporary folder."""
    monkeypatch.setenv("GLRENDER_CHI2_DIR", str(tmp_path))
    return tmp_path


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under CI=true a skipped test is a failure: CI installs every optional dependency."""
    outcome = yield
    report = outcome.get_result()
    if IN_CI and report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr
        report.outcome = "failed"
        report.longrepr = f"skipped under CI=true (every dependency must be installed): {reason}"


_WORKER_COMPILE_STATS: list[dict] = []   # the xdist workers' counts, gathered by the controller


def pytest_sessionfinish(session):
    """An xdist worker hands its shader compile counts to the controller."""
    output = getattr(session.config, "workeroutput", None)
    if output is not None:
        from glrender.gl.shaders import COMPILE_STATS

        output["glrender_compile_stats"] = dict(COMPILE_STATS)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    stats = getattr(node, "workeroutput", {}).get("glrender_compile_stats")
    if stats:
        _WORKER_COMPILE_STATS.append(stats)


def pytest_terminal_summary(terminalreporter):
    """Keep shader compile time visible: programs compiled by this run (every worker's) and
    the driver's time."""
    from glrender.gl.shaders import COMPILE_STATS

    total = {k: sum(s.get(k, 0) for s in [COMPILE_STATS, *_WORKER_COMPILE_STATS])
             for k in ("programs", "seconds", "first_dispatch_seconds")}
    terminalreporter.write_line(
        f"glrender: {total['programs']} shader programs compiled in "
        f"{total['seconds']:.1f} s, their first dispatches (code generation or the "
        f"disk cache) took {total['first_dispatch_seconds']:.1f} s")
