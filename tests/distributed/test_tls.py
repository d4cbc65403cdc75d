"""A TLS scheduler and worker on 127.0.0.1 with generated test certificates."""
from __future__ import annotations

import subprocess

import pytest

from dist_run import CORNELL, DaskProcesses, glrender as run, one_error_line

SMALL = ["--width", 32, "--height", 24, "--spp", 8, "--seed", 2]


def make_ca(folder, name):
    key, cert = folder / f"{name}-ca.key", folder / f"{name}-ca.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
                    "-subj", f"/CN={name} test CA", "-keyout", key, "-out", cert],
                   check=True, capture_output=True)
    return key, cert


def make_cert(folder, name, ca_key, ca_cert):
    """A certificate for 127.0.0.1 signed by the CA: (cert, key)."""
    key, csr, cert = folder / f"{name}.key", folder / f"{name}.csr", folder / f"{name}.pem"
    ext = folder / f"{name}.ext"
    ext.write_text("subjectAltName = IP:127.0.0.1, DNS:localhost\n"
                   "extendedKeyUsage = serverAuth, clientAuth\n")
    subprocess.run(["openssl", "req", "-newkey", "rsa:2048", "-nodes", "-subj", f"/CN={name}",
                    "-keyout", key, "-out", csr], check=True, capture_output=True)
    subprocess.run(["openssl", "x509", "-req", "-in", csr, "-CA", ca_cert, "-CAkey", ca_key,
                    "-CAcreateserial", "-days", "2", "-extfile", ext, "-out", cert],
                   check=True, capture_output=True)
    return cert, key


@pytest.mark.slow
def test01_tls_cluster_renders_and_refuses_strangers(tmp_path):
    ca_key, ca = make_ca(tmp_path, "cluster")
    cert, key = make_cert(tmp_path, "node", ca_key, ca)
    client_cert, client_key = make_cert(tmp_path, "client", ca_key, ca)
    other_key, other_ca = make_ca(tmp_path, "other")
    stranger_cert, stranger_key = make_cert(tmp_path, "stranger", other_key, other_ca)

    from distributed.security import Security

    cluster = DaskProcesses(tmp_path, workers=1, tls={"ca": ca, "cert": cert, "key": key})
    try:
        cluster.wait_for_workers(1, client_security=Security(
            tls_ca_file=str(ca), tls_client_cert=str(cert), tls_client_key=str(key),
            require_encryption=True))
        out = tmp_path / "tls.exr"
        r = run("render", CORNELL, *SMALL, "-o", out, "--scheduler", cluster.address,
                "--tls-ca", ca, "--tls-cert", client_cert, "--tls-key", client_key)
        assert r.returncode == 0, r.stderr
        # a client whose certificate the cluster's CA did not sign is refused
        refused = tmp_path / "refused.exr"
        r = run("render", CORNELL, *SMALL, "-o", refused, "--scheduler", cluster.address,
                "--tls-ca", other_ca, "--tls-cert", stranger_cert, "--tls-key", stranger_key)
        assert "cannot reach the scheduler" in one_error_line(r)
        # and so is one without TLS
        r = run("render", CORNELL, *SMALL, "-o", refused, "--scheduler",
                cluster.address.replace("tls://", "tcp://"))
        assert "cannot reach the scheduler" in one_error_line(r)
        assert not refused.exists()
    finally:
        cluster.close()
    single = tmp_path / "single.exr"
    r = run("render", CORNELL, *SMALL, "-o", single, "--quiet")
    assert r.returncode == 0, r.stderr
    assert out.read_bytes() == single.read_bytes()
