"""An ATI Net F/T box on loopback, written from ATI's documented formats (the Net F/T manual).

RDT over UDP: it waits for a 8-byte request (``uint16 0x1234``, ``uint16 command``,
``uint32 count``, big-endian); on command 2 it sends 36-byte records (``uint32 rdt_sequence``,
``uint32 ft_sequence``, ``uint32 status``, ``int32`` Fx..Tz counts) to the requester, on 0 it
stops (a start after a stop resumes the script where it stopped; a start while streaming is
ignored). The calibration page ``/netftapi2.xml`` over HTTP gives ``cfgcpf``, ``cfgcpt`` and the
units. What it sends is scripted (:class:`Script`): counts, records dropped, pairs swapped, a
status word with an error bit, silence after some records.
"""

from __future__ import annotations

import http.server
import socket
import struct
import threading
from dataclasses import dataclass, field

import numpy as np

PAGE = b"""<?xml version="1.0" encoding="ISO-8859-1"?>
<netft><setcalsel>1</setcalsel><scfgfu>N</scfgfu><scfgtu>Nm</scfgtu>
<cfgcpf>%d</cfgcpf><cfgcpt>%d</cfgcpt><runrate>7000</runrate></netft>"""


@dataclass
class Script:
    """What the box sends on a start request.

    Attributes:
        counts: The records' counts, shape (n, 6), in order of rdt_sequence (1, 2, ...).
        drop: Indices of records never sent (lost on the way).
        swap: Indices k whose record is sent after record k + 1 (reordered).
        status: Index -> status word of that record (0 otherwise).
        silent_after: Send only this many records, then nothing (the box stops answering).
        period_s: Time between two records [s].
    """

    counts: np.ndarray
    drop: set[int] = field(default_factory=set)
    swap: set[int] = field(default_factory=set)
    status: dict[int, int] = field(default_factory=dict)
    silent_after: int | None = None
    period_s: float = 0.0005


class NetFtBox:
    """The box: an RDT socket and an HTTP server on 127.0.0.1, each on a free port."""

    def __init__(self, script: Script, counts_per_force: int = 1_000_000, counts_per_torque: int = 1_000_000, serve_page: bool = True):
        self.script = script
        self.requests: list[tuple[int, int, int]] = []
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        page = PAGE % (counts_per_force, counts_per_torque)

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):  # noqa: N802 (the server's name)
                body = page if self.path == "/netftapi2.xml" else b""
                self.send_response(200 if body else 404)
                self.send_header("Content-Type", "text/xml")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):
                pass

        self.http = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler) if serve_page else None
        self.http_port = self.http.server_address[1] if self.http is not None else _closed_port()
        self._stop = threading.Event()
        self._streaming = threading.Event()
        self._sent = 0  # records of the script sent (or dropped) so far: a new start resumes there
        self._threads = [threading.Thread(target=self._serve_rdt, daemon=True)]
        if self.http is not None:
            self._threads.append(threading.Thread(target=self.http.serve_forever, daemon=True))
        for thread in self._threads:
            thread.start()

    @property
    def url(self) -> str:
        """The source text of this box."""
        return f"netft://127.0.0.1:{self.port}?http={self.http_port}"

    def _serve_rdt(self) -> None:
        while not self._stop.is_set():
            try:
                data, peer = self.sock.recvfrom(64)
            except TimeoutError:
                continue
            except OSError:
                return
            if len(data) != 8:
                continue
            header, command, count = struct.unpack(">HHI", data)
            self.requests.append((header, command, count))
            if header == 0x1234 and command == 0:
                self._streaming.clear()
            elif header == 0x1234 and command == 2 and not self._streaming.is_set():  # a start while streaming: ignored
                self._streaming.set()
                threading.Thread(target=self._stream, args=(peer,), daemon=True).start()

    def _stream(self, peer) -> None:
        """Send the script's records from where the last stream stopped, until a stop request."""
        script = self.script
        order = list(range(len(script.counts)))
        for k in sorted(script.swap):
            if k + 1 < len(order):
                order[k], order[k + 1] = order[k + 1], order[k]
        while self._sent < len(order):
            if self._stop.is_set() or (script.silent_after is not None and self._sent >= script.silent_after):
                return
            if not self._streaming.is_set():  # stopped
                return
            k = order[self._sent]
            self._sent += 1
            if k in script.drop:
                continue
            record = struct.pack(">III6i", k + 1, 16 * (k + 1), script.status.get(k, 0), *(int(c) for c in script.counts[k]))
            try:
                self.sock.sendto(record, peer)
            except OSError:
                return
            self._stop.wait(script.period_s)

    def close(self) -> None:
        """Stop serving; release both ports."""
        self._stop.set()
        if self.http is not None:
            self.http.shutdown()
            self.http.server_close()
        for thread in self._threads:
            thread.join(timeout=1.0)
        self.sock.close()


def _closed_port() -> int:
    """A loopback TCP port nobody listens on (a box with its web server off)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
