"""Helpers of the distributed tests: the command line in a subprocess, Dask processes,
an animated scene."""
from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "cli"))   # the command-line helpers of tests/cli
from cli_run import CORNELL, one_error_line  # noqa: E402,F401  (used by the tests)
from cli_run import glrender as _glrender  # noqa: E402


def glrender(*args, timeout: float = 180, env=None) -> subprocess.CompletedProcess:
    """``python -m glrender ARGS`` (a cluster's start-up included in the timeout)."""
    return _glrender(*args, timeout=timeout, env=env)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DaskProcesses:
    """``dask scheduler`` and ``dask worker`` processes on 127.0.0.1 (as users start
    them), stopped by their PIDs."""

    def __init__(self, tmp: Path, workers: int = 2, tls: dict | None = None):
        self.port = free_port()
        proto = "tls" if tls else "tcp"
        self.address = f"{proto}://127.0.0.1:{self.port}"
        env = {**os.environ, "LP_NUM_THREADS": "1"}
        sec_s, sec_w = [], []
        if tls:
            sec_s = ["--tls-ca-file", tls["ca"], "--tls-cert", tls["cert"], "--tls-key", tls["key"]]
            sec_w = sec_s
        self.procs = []
        self.logs = []
        log = open(tmp / "scheduler.log", "w")
        self.logs.append(log)
        self.procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(self.port), "--no-dashboard", *sec_s],
            stdout=log, stderr=subprocess.STDOUT, env=env))
        for i in range(workers):
            log = open(tmp / f"worker{i}.log", "w")
            self.logs.append(log)
            self.procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", self.address,
                 "--host", "127.0.0.1", "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                 *sec_w], stdout=log, stderr=subprocess.STDOUT, env=env))
        self.tmp = tmp

    def wait_for_workers(self, n: int, client_security=None, timeout: float = 60):
        from distributed import Client

        with Client(self.address, security=client_security, timeout=timeout) as c:
            c.wait_for_workers(n, timeout=timeout)

    def close(self):
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for log in self.logs:
            log.close()


def animated_cornell(folder: Path, frames=(0, 1)) -> Path:
    """The Cornell box with a moving camera and a small box that rises (keys at 0 and
    1/12 s, 24 fps)."""
    text = CORNELL.read_text()
    small = [0.28689146041870117, 0, -0.08771151304244995, 0.33500000834465027, 0,
             0.30000001192092896, 0, -0.699999988079071, 0.08771151304244995, 0,
             0.28689146041870117, 0.3799999952316284, 0, 0, 0, 1]
    text += f"""
[animation]
fps = 24
frames = [{frames[0]}, {frames[1]}]

[[animation.camera]]
time = 0.0
transform = {{ matrix = [-1, 0, 0, 0,  0, 1, 0, 0,  0, 0, -1, 3.9,  0, 0, 0, 1] }}

[[animation.camera]]
time = 0.0833333
transform = [{{ matrix = [-1, 0, 0, 0,  0, 1, 0, 0,  0, 0, -1, 3.9,  0, 0, 0, 1] }}, {{ rotate = {{ axis = [0, 1, 0], angle = 6 }} }}]

[[animation.shapes]]
shape = "small box"
keys = [{{ time = 0.0, transform = {{ matrix = {small} }} }},
        {{ time = 0.0833333, transform = [{{ matrix = {small} }}, {{ translate = [0, 0.25, 0] }}] }}]
"""
    path = folder / "animated.toml"
    path.write_text(text)
    return path
