"""An ATI Net F/T box through its documented RDT protocol: its six raw counts as channels.

``netft://HOST`` (``netft://HOST:RDT_PORT?http=HTTP_PORT`` for another port than the box's
49152 and 80). ATI's Raw Data Transfer (RDT), as the Net F/T manual documents it:

- the request, one UDP datagram to port 49152: ``uint16 0x1234`` (the header),
  ``uint16 command`` (2: start real-time streaming, 0: stop), ``uint32 sample count``
  (0: without end), big-endian;
- each record, one UDP datagram of 36 bytes: ``uint32 rdt_sequence`` (one per record sent),
  ``uint32 ft_sequence`` (one per internal sample), ``uint32 status`` (0: no fault), and
  ``int32 Fx, Fy, Fz, Tx, Ty, Tz`` in counts, big-endian;
- the calibration page ``http://HOST/netftapi2.xml``: ``cfgcpf`` and ``cfgcpt``, the counts
  per force and per torque unit, and ``scfgfu``/``scfgtu``, those units.

The counts are kept as the six channels (the ``wrench-6`` layout); the box's own scale
(:attr:`NetFtChannels.calibration`) is the projection a prior can start from. Each record is
stamped on arrival with the host's monotonic clock (:mod:`fts_calib.sources.devices`).

What is counted and skipped, never fatal: :data:`FAULT` (a record whose status word is not 0:
ATI's status bits, the first named in hex), :data:`REORDERED` (a record whose ``rdt_sequence``
is not above the last one: out of order or repeated), :data:`MALFORMED` (not 36 bytes);
records lost on the way are the gaps in ``rdt_sequence`` (:attr:`NetFtChannels.lost`). A box
that sends no record for ``timeout_s`` ends the reading with a
:class:`~fts_calib.core.exceptions.FeedTimeout` naming the host and port: before any record
the run fails; later it ends with what it has.
"""

from __future__ import annotations

import math
import socket
import struct
import time
import urllib.error
import urllib.request
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..core.exceptions import ConfigError, FeedTimeout
from .devices import ChannelDevice

#: The box's RDT port and HTTP port.
RDT_PORT, HTTP_PORT = 49152, 80
#: The request header, and the commands used.
RDT_HEADER, START_STREAMING, STOP_STREAMING = 0x1234, 2, 0
#: One request: header, command, sample count (big-endian).
REQUEST = struct.Struct(">HHI")
#: One record: rdt_sequence, ft_sequence, status, Fx, Fy, Fz, Tx, Ty, Tz (big-endian).
RECORD = struct.Struct(">III6i")
#: The calibration page.
CALIBRATION_PAGE = "/netftapi2.xml"
#: How long without a record before the box is taken as silent, by default [s].
TIMEOUT_S = 2.0
#: How often the start request is repeated while no record came (UDP may lose it) [s].
RETRY_S = 0.5
FAULT = "record with a status word not 0 (a fault of the box)"
REORDERED = "record out of order or repeated (rdt_sequence not above the last)"
MALFORMED = "datagram that is not a 36-byte RDT record"
EXPECTED = "netft://HOST (or netft://HOST:RDT_PORT?http=HTTP_PORT)"
SILENT_HINT = "is the box powered, on this network, and its RDT output enabled? (its web page: Communication settings)"


@dataclass(frozen=True)
class NetFtCalibration:
    """The box's calibration page: counts per unit.

    Attributes:
        counts_per_force: Counts per force unit (``cfgcpf``).
        counts_per_torque: Counts per torque unit (``cfgcpt``).
        force_unit: The force unit (``scfgfu``, e.g. ``N``).
        torque_unit: The torque unit (``scfgtu``, e.g. ``Nm``).
    """

    counts_per_force: float
    counts_per_torque: float
    force_unit: str
    torque_unit: str

    def scale(self) -> list[float]:
        """The units per count of each channel, Fx..Tz, shape (6,) (the diagonal of the box's projection)."""
        return [1.0 / self.counts_per_force] * 3 + [1.0 / self.counts_per_torque] * 3


def parse_calibration(xml: bytes, where: str) -> NetFtCalibration:
    """The calibration of a ``netftapi2.xml`` page.

    Raises:
        ValueError: Not XML, or without positive ``cfgcpf``/``cfgcpt`` (the message names ``where``).
    """
    try:
        root = ElementTree.fromstring(xml)
    except ElementTree.ParseError as exc:
        raise ValueError(f"{where} is not XML ({exc})") from None

    def number(tag: str) -> float:
        text = root.findtext(f".//{tag}")
        try:
            value = float(text or "")
        except ValueError:
            raise ValueError(f"{where}: <{tag}> is {text!r}: expected counts per unit, a number > 0") from None
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{where}: <{tag}> is {text!r}: expected counts per unit, a number > 0")
        return value

    return NetFtCalibration(
        number("cfgcpf"), number("cfgcpt"), (root.findtext(".//scfgfu") or "").strip(), (root.findtext(".//scfgtu") or "").strip()
    )


def parse_netft_url(text: str) -> tuple[str, int, int]:
    """The host, RDT port and HTTP port of a ``netft://`` text.

    Raises:
        ConfigError: No host, a port that is not a number from 0 to 65535, or another
            parameter than ``http`` (the message names the text).
    """
    parts = urlsplit(text)
    query = parse_qs(parts.query, keep_blank_values=True)
    if parts.path not in ("", "/") or set(query) - {"http"} or parts.fragment:
        raise ConfigError("source", text, EXPECTED, message=f"{text}: expected {EXPECTED}")
    if not parts.hostname:
        raise ConfigError("source", text, EXPECTED, message=f"{text}: no host: expected {EXPECTED}")
    try:
        port = parts.port
    except ValueError:
        port = -1
    http = query.get("http", [str(HTTP_PORT)])[-1]
    if port == -1 or not http.isdigit() or int(http) > 65535:
        raise ConfigError("source", text, EXPECTED, message=f"{text}: a port is not a number from 0 to 65535: expected {EXPECTED}")
    return parts.hostname, RDT_PORT if port is None else port, int(http)


class NetFtChannels(ChannelDevice):
    """The six raw counts of an ATI Net F/T box (see the module docstring).

    Args:
        text: ``netft://HOST[:RDT_PORT][?http=HTTP_PORT]``.
        timeout_s: The longest wait for a record (and for the calibration page) [s].

    Attributes:
        calibration: The box's calibration page (:class:`NetFtCalibration`), None when it
            could not be read (noted: the counts are kept all the same).
        lost: Records lost on the way (gaps in ``rdt_sequence``).
        first_status: The first fault status word, or None.
    """

    def __init__(self, text: str, timeout_s: float = TIMEOUT_S):
        self.host, self.port, self.http_port = parse_netft_url(text)
        super().__init__(text, 6)
        if not (math.isfinite(timeout_s) and timeout_s > 0):
            raise ConfigError("timeout_s", timeout_s, "a finite number of seconds > 0", "s")
        self.timeout_s = float(timeout_s)
        self.calibration: NetFtCalibration | None = None
        self.lost = 0
        self.first_status: int | None = None
        self._last_sequence: int | None = None
        self._sock: socket.socket | None = None
        self._last_record = self._last_request = 0.0

    @property
    def where(self) -> str:
        """The box's RDT address in words."""
        return f"the Net F/T at {self.host}:{self.port} (RDT over UDP)"

    def read_calibration(self) -> NetFtCalibration | None:
        """Read the calibration page (noted, and None, when it cannot be)."""
        url = f"http://{self.host}:{self.http_port}{CALIBRATION_PAGE}"
        try:
            with urllib.request.urlopen(url, timeout=self.timeout_s) as answer:  # noqa: S310 (an http:// URL built here)
                return parse_calibration(answer.read(1 << 20), url)
        except (urllib.error.URLError, OSError, ValueError) as exc:
            reason = getattr(exc, "reason", exc)
            self._note(f"{url}: the calibration page could not be read ({reason}): the counts are kept, without the box's scale")
            return None

    def _open(self) -> None:
        self.calibration = self.read_calibration()
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.settimeout(0.05)
        try:
            self._sock.connect((self.host, self.port))
        except OSError as exc:
            self._sock.close()
            raise ConnectionError(f"cannot reach {self.where}: {exc.strerror or exc}") from None
        self._last_record = self._last_request = time.monotonic()
        self._send(START_STREAMING)

    def _send(self, command: int) -> None:
        if self._sock is not None:
            try:
                self._sock.send(REQUEST.pack(RDT_HEADER, command, 0))
            except OSError:
                pass  # an unreachable port answers with ICMP: seen as silence, named by the timeout

    def _check_silence(self, now: float) -> None:
        """End the reading with a :class:`FeedTimeout` when no record came for ``timeout_s`` (``now``: host monotonic [s])."""
        if now - self._last_record >= self.timeout_s:
            what = f"an RDT record from {self.where}" + (" (it had been streaming)" if self.samples else "")
            raise FeedTimeout(what, self.timeout_s, SILENT_HINT)

    def _read(self) -> None:
        """Receive one record (at most 50 ms of waiting); a silence of ``timeout_s`` ends the reading."""
        assert self._sock is not None
        now = time.monotonic()
        self._check_silence(now)
        if not self.samples and now - self._last_request >= RETRY_S:
            self._last_request = now
            self._send(START_STREAMING)
        try:
            data = self._sock.recv(2048)
        except (TimeoutError, ConnectionRefusedError):  # refused: the ICMP answer to a request to a closed port
            return
        arrival = time.monotonic()
        self._last_record = arrival
        if len(data) != RECORD.size:
            self._skip(MALFORMED, f"{len(data)} bytes")
            return
        sequence, _, status, *counts = RECORD.unpack(data)
        if self._last_sequence is not None and sequence <= self._last_sequence:
            if sequence < self._last_sequence and self.lost:  # a late record: not lost after all, but out of order
                self.lost -= 1
            self._skip(REORDERED, f"rdt_sequence {sequence} after {self._last_sequence}")
            return
        if self._last_sequence is not None:
            self.lost += sequence - self._last_sequence - 1
        self._last_sequence = sequence
        if status:
            self.first_status = self.first_status if self.first_status is not None else status
            self._skip(FAULT, f"status 0x{status:08x} at rdt_sequence {sequence}")
            return
        self._add(arrival, [[float(c) for c in counts]])

    def notes(self) -> list[str]:
        """The first problems, the records lost, and why the reading stopped."""
        lost = [f"{self.where}: {self.lost:,} records lost on the way (gaps in rdt_sequence)"] if self.lost else []
        return self._notes + lost + ([] if self.error is None else [str(self.error)])

    def _close(self) -> None:
        if self._sock is not None:
            self._send(STOP_STREAMING)
            self._sock.close()
            self._sock = None


def pynetft_installed() -> bool:
    """Whether the optional client ``pynetft`` (the ``netft`` extra) can be imported."""
    try:
        import pynetft  # noqa: F401
    except ImportError:
        return False
    return True


def open_netft(text: str, timeout_s: float = TIMEOUT_S) -> NetFtChannels:
    """The reader of ``netft://`` ``text``: through ``pynetft`` when it is installed, else ATI's RDT read directly.

    Args:
        text: ``netft://HOST[:RDT_PORT][?http=HTTP_PORT]``.
        timeout_s: The longest silence of the box [s].
    """
    reader = PyNetFtChannels if pynetft_installed() else NetFtChannels
    return reader(text, timeout_s)


class PyNetFtChannels(NetFtChannels):
    """The same six raw counts read through ``pynetft`` (the ``netft`` extra), used when it is installed.

    ``pynetft`` discovers the calibration page, streams RDT and reconnects after a fault (a status
    word with an error bit: it stops and restarts the stream). Its counts (``raw_wrench``) are the
    channels, stamped with its arrival time (``received_at_ns``, the host's monotonic clock).
    Records it drops as late are counted in :data:`REORDERED`, those it counts lost in
    :attr:`lost`. Unlike the direct reader, without the calibration page it gives no record (it
    keeps retrying): the silence ends the reading with the same :class:`FeedTimeout`.
    """

    _client: Any = None

    def _open(self) -> None:
        import pynetft

        config = pynetft.Config(
            sensor_host=self.host,
            rdt_port=self.port,
            http_port=self.http_port,
            receive_timeout=min(self.timeout_s, 0.5),
            configuration_timeout=self.timeout_s,
            deliver_samples_with_error_status=True,
            recovery_policy=pynetft.RecoveryPolicy.RECONNECT,
        )
        try:
            self._client = pynetft.Client(config, queue_size=1 << 16)
            self._client.start()
        except (pynetft.NetFTError, OSError) as exc:
            raise ConnectionError(f"cannot reach {self.where}: {exc}") from None
        self._last_record = time.monotonic()

    def _read(self) -> None:
        """Take one record from ``pynetft`` (at most 50 ms of waiting); a silence of ``timeout_s`` ends the reading."""
        self._check_silence(time.monotonic())
        try:
            sample = next(self._client.samples(timeout=0.05))
        except (TimeoutError, StopIteration):
            return
        self._last_record = time.monotonic()
        if sample.status:
            self.first_status = self.first_status if self.first_status is not None else sample.status
            self._skip(FAULT, f"status 0x{sample.status:08x} at rdt_sequence {sample.rdt_sequence}")
            return
        self._add(sample.received_at_ns * 1e-9, [[float(c) for c in sample.raw_wrench]])

    def _close(self) -> None:
        client = self._client
        if client is None:
            return
        health = client.health()
        client.stop()
        self._client = None
        if health.last_error and not self.samples:  # e.g. the calibration page could not be read
            self._note(f"{self.where}: pynetft: {health.last_error}")
        self.lost = max(health.lost_count - health.out_of_order_count, 0)  # a late record was first counted lost
        if health.out_of_order_count:
            self.skipped[REORDERED] += health.out_of_order_count
        configuration = health.sensor_configuration
        if configuration is not None:
            calibration = configuration.calibration
            self.calibration = NetFtCalibration(
                calibration.counts_per_force_unit,
                calibration.counts_per_torque_unit,
                calibration.force_unit.value,
                calibration.torque_unit.value,
            )
