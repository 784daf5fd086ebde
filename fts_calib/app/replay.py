"""The ``replay`` command: send a recording as the live protocol, to test the live path without a robot."""

from __future__ import annotations

from ..sources.sender import ReplayOptions, replay
from .exit_codes import ExitCode, using_udp
from .setup import SourceOptions


def run(source: SourceOptions, options: ReplayOptions | None = None, *, to: tuple[str, int] = ("127.0.0.1", 5005)) -> int:
    """Send a recording's rows as live datagrams, numbered by ``seq``, and print what was sent (``fts-calib replay``).

    Args:
        source: The recording (CSV or CSV.gz), or ROS 2 bags (each optionally ``BAG:CONFIGURATION``:
            a bag's channel samples, with the joints synchronised at their times, as rows), with
            a bag's topics.
        options: The pacing (``speed``: 1 real time, 10 ten times faster, 0 no pacing), the joint
            messages' rate [Hz] (one per row when None), their added latency [s], the losses and
            reordering in [0, 1) and their seed (:class:`~fts_calib.sources.sender.ReplayOptions`).
        to: (host, port) to send to.

    Returns:
        0.
    """
    options = options or ReplayOptions()
    host, port = to
    paths = source.paths()
    print(f"replaying {' '.join(map(str, paths))} to udp://{host}:{port} at speed {options.speed:g}...", flush=True)
    with using_udp(host, port):
        stats = replay(paths, host, port, options, source.topics)
    numbered = stats.sent + stats.dropped  # every message has its seq, the dropped ones too: the receiver counts them as lost
    print(
        f"sent {stats.sent:,} datagrams in {stats.seconds:.1f} s, seq 0 to {numbered - 1:,} "
        f"({stats.dropped:,} dropped and {stats.reordered:,} reordered on purpose)"
    )
    return ExitCode.OK
