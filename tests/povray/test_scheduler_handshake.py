"""``--scheduler`` at a server that is not Dask (issue 38 item 4): a mute one, one that answers another
protocol, and ``tls://`` without Dask's TLS settings are each one line within 10 s; a real scheduler
(the negative control) passes the same handshake."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import pytest

from povh3d.povray import cluster
from tests.conftest import SAMPLE
from tests.support.cli import one_error_line

pytest.importorskip("distributed")


class Server:
    """A TCP server on 127.0.0.1 that accepts and then says ``answer`` (nothing: None)."""

    def __init__(self, answer: bytes | None) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.answer, self.conns = answer, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.answer is not None:
                try:
                    conn.sendall(self.answer)
                except OSError:
                    pass

    def close(self) -> None:
        for conn in self.conns:
            conn.close()
        self.sock.close()


@pytest.fixture(params=[None, b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello", b"\x05\0\0\0\0\0\0\0hello"],
                ids=["mute", "http", "short-garbage"])
def foreign(request):
    server = Server(request.param)
    yield server
    server.close()


def test_a_server_that_is_not_dask_is_one_line_within_10_s(tmp_path: Path, cli, foreign) -> None:
    start = time.perf_counter()
    line = one_error_line(cli("render", SAMPLE, "--preset", "demo", "-q", "-o", tmp_path / "a.png",
                              "--scheduler", f"tcp://127.0.0.1:{foreign.port}"), 2)
    assert time.perf_counter() - start < 10
    assert f"127.0.0.1:{foreign.port} is not a Dask scheduler" in line
    assert not list(tmp_path.iterdir())


def test_tls_without_settings_is_one_line(tmp_path: Path, cli) -> None:
    server = Server(None)
    try:
        line = one_error_line(cli("render", SAMPLE, "--preset", "demo", "-q", "-o", tmp_path / "a.png",
                                  "--scheduler", f"tls://127.0.0.1:{server.port}"), 2)
    finally:
        server.close()
    assert "needs Dask's TLS settings" in line and "tcp://" in line


def test_a_dask_scheduler_passes_the_handshake() -> None:
    """The negative control: the probe's reading of a real scheduler's first bytes."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, protocol="tcp://", dashboard_address=None) as local:
        _, host, port = cluster.check_address(local.scheduler_address)
        assert cluster._handshake(host, port, cluster.HANDSHAKE_SECONDS) is None
    mute = Server(None)
    try:
        assert "says nothing" in cluster._handshake("127.0.0.1", mute.port, 0.5)
    finally:
        mute.close()
