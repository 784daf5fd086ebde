"""A serial line printing one line of integers per sample (ADC sensors on a microcontroller), as channels.

``serial:///dev/ttyUSB0?baud=115200&sep=,&channels=8``: the device path, the baud rate
(115200 by default), the separator of the values (``,`` by default; ``space`` or ``tab`` for
whitespace), the channel count (the first sample's when not given) and ``scale``, the raw units
per count (1 by default: the channels are the counts; a calibration made in other units, e.g.
volts, reads ``scale=LSB``). Each line is
``v1<sep>v2<sep>...<sep>vn`` ended by a line feed (a carriage return before it is ignored); each sample is
stamped on arrival with the host's monotonic clock (:mod:`fts_calib.sources.devices`).

What does not fit is counted and skipped, never fatal (:attr:`SerialChannels.skipped`, the first
of each named in :meth:`~fts_calib.sources.devices.ChannelDevice.notes`):

- :data:`PARTIAL`: the bytes before the first line end (the port opened mid-line);
- :data:`GARBAGE`: a line that is not integers (noise, a wrong baud rate: then every line is);
- another channel count than ``channels``;
- :data:`TOO_LONG`: more than :data:`MAX_LINE` bytes without a line end.

The device vanishing (the cable pulled, the USB adapter reset) ends the reading: the live loop
ends the run with what it has and says so. ``pyserial`` is an optional extra
(``pip install 'fts-calib[serial]'``), imported when the port is opened.
"""

from __future__ import annotations

import math
import time
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..core.exceptions import ConfigError
from .devices import ChannelDevice, DeviceLost

#: Separators by name (a separator in the URL may be given as one of these words).
SEPARATORS = {"space": None, "tab": "\t", "comma": ",", "semicolon": ";"}
#: The longest line taken [bytes]: longer without a line end is garbage.
MAX_LINE = 4096
#: Reasons of what is skipped.
PARTIAL = "partial line at the start (the port opened mid-line)"
GARBAGE = "line that is not integers (noise, or a wrong baud rate)"
TOO_LONG = f"line longer than {MAX_LINE} bytes without a line end"
#: The usual baud rates (another is accepted with a note: a typo gives garbage).
BAUD_RATES = (9600, 19200, 38400, 57600, 115200, 230400, 250000, 460800, 500000, 921600, 1000000, 2000000)
EXPECTED = "serial:///dev/ttyUSB0?baud=115200&sep=,&channels=8"


def parse_serial_url(text: str) -> tuple[str, int, str | None, int | None, float]:
    """The device path, baud rate, separator (None: whitespace), channel count (None: the first line's) and scale of a ``serial://`` text.

    Raises:
        ConfigError: No device path, a baud rate or channel count that is not a positive
            integer, or an unknown parameter (the message names the text and the parameter).
    """
    parts = urlsplit(text)
    path = (parts.netloc + parts.path) if parts.netloc else parts.path
    if not path or path == "/":
        raise ConfigError("source", text, EXPECTED, message=f"{text}: no device: expected {EXPECTED}")
    query = parse_qs(parts.query, keep_blank_values=True)
    unknown = sorted(set(query) - {"baud", "sep", "channels", "scale"})
    if unknown:
        message = f"{text}: unknown parameter {unknown[0]!r}: expected baud, sep, channels and scale ({EXPECTED})"
        raise ConfigError("source", text, EXPECTED, message=message)

    def count(name: str, default: int | None) -> int | None:
        given = query.get(name, [None])[-1]
        if given is None:
            return default
        if not given.isdigit() or int(given) < 1:
            raise ConfigError("source", text, EXPECTED, message=f"{text}: {name}={given!r} is not a positive integer: expected {EXPECTED}")
        return int(given)

    baud = count("baud", 115200)
    sep = query.get("sep", [","])[-1]
    separator = SEPARATORS.get(sep.lower(), sep) if sep.strip() else None
    given = query.get("scale", ["1"])[-1]
    try:
        scale = float(given)
    except ValueError:
        scale = math.nan
    if not (math.isfinite(scale) and scale > 0):
        raise ConfigError("source", text, EXPECTED, message=f"{text}: scale={given!r} is not a number > 0 (raw units per count)")
    return path, int(baud or 115200), separator, count("channels", None), scale


class SerialChannels(ChannelDevice):
    """The channels of a serial line (see the module docstring).

    Args:
        text: ``serial://DEVICE?baud=...&sep=...&channels=...``.
        n_channels: The sensor's channel count, when the text does not give it (the sensor
            file's); a text that gives another is refused.

    Raises:
        ConfigError: A malformed text (:func:`parse_serial_url`), or a channel count other
            than the sensor's.
    """

    def __init__(self, text: str, n_channels: int | None = None):
        path, self.baud, self.separator, given, self.scale = parse_serial_url(text)
        if given is not None and n_channels is not None and given != n_channels:
            message = (
                f"{text}: channels={given} but the sensor has {n_channels} channels: give channels={n_channels} or another sensor file"
            )
            raise ConfigError("source", text, f"channels={n_channels}", message=message)
        super().__init__(text, given if given is not None else n_channels)
        self.path = path
        self.lines = 0
        self._port: Any = None
        self._buffer = b""
        self._started = False  # a first line end seen (what came before it is a partial line)

    def _open(self) -> None:
        """Open the port with pyserial.

        Raises:
            ConfigError: pyserial is not installed (the message says how to install it).
            DeviceLost: The device cannot be opened (not found, busy, not a serial port), naming it.
        """
        try:
            import serial  # type: ignore[import-untyped]
        except ImportError:
            message = f"{self.description} reads the line through pyserial, which is not installed: pip install 'fts-calib[serial]'"
            raise ConfigError("source", self.description, "pyserial installed", message=message) from None
        if self.baud not in BAUD_RATES:
            self._note(
                f"{self.description}: {self.baud} baud is not a usual rate ({', '.join(map(str, BAUD_RATES))}): a typo gives garbage"
            )
        try:
            self._port = serial.Serial(self.path, baudrate=self.baud, timeout=0.05)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceLost(f"{self.description}: cannot open {self.path}: {exc}") from None

    def _read(self) -> None:
        """Read what came (at most 50 ms of waiting), split it into lines, parse them."""
        data = self._port.read(max(1, min(self._port.in_waiting, 65536)))
        if not data:
            return
        arrival = time.monotonic()
        self._buffer += data
        *lines, self._buffer = self._buffer.split(b"\n")
        if not self._started and lines:
            first = lines.pop(0)
            self._started = True
            if first.strip():
                self._skip(PARTIAL, f"{first[:40]!r}")
        samples = [values for values in map(self._line, lines) if values is not None]
        self._add(arrival, samples)
        if len(self._buffer) > MAX_LINE:
            self._skip(TOO_LONG, f"{self._buffer[:40]!r}...")
            self._buffer = b""
            self._started = False  # what follows up to the next line end is the rest of that line

    def _line(self, raw: bytes) -> list[float] | None:
        """One line's values, or None (an empty line; garbage, counted and skipped)."""
        self.lines += 1
        text = raw.rstrip(b"\r")
        if not text.strip():
            return None
        try:
            return [int(field) * self.scale for field in text.decode("ascii").split(self.separator)]
        except (UnicodeDecodeError, ValueError):
            self._skip(GARBAGE, f"line {self.lines}: {text[:40]!r}")
            return None

    def _close(self) -> None:
        if self._port is not None:
            try:
                self._port.close()
            except OSError:
                pass
            self._port = None
