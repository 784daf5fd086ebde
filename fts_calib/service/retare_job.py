"""Re-tare: new offsets D for a calibration, from a short recording or live window.

The frequent use the paper stresses: offsets drift, C does not, so before use the sensor is
held still a moment and D is estimated again (:func:`fts_calib.model.retare.estimate_offsets`)
with C_bar kept. With nothing mounted, the known load is zero; with a known tool
configuration on, it is that configuration's weight at the orientation the kinematics give
(paper eqs 17-18), and only the quasi-static samples count. The window goes through the filter
chain of every job (:func:`fts_calib.filters.chain.filter_chain`, quasi-static whatever the
pipeline's ``filter.mode``): the checks refuse and count bad samples and those with a channel at
its rail (declared, or detected in the window: :mod:`fts_calib.model.channel_limits`), and the
filter's rules judge the rest. The calibration keeps its
previous offsets, and when and why they were replaced, in ``offset_history``; the result
also says how far the offsets drifted since the calibration run (against the offsets it
ended with, the first of the history) and over how long (from the calibration's time).

Two checks come before any result (:func:`check_window`), and a window that fails either is
refused with :class:`~fts_calib.core.exceptions.ResultRefused`, so that no file is touched:

1. *still*: at least :data:`MIN_STILL_FRACTION` of the window's samples pass the
   quasi-static filter's rules 1-3 (joint speed, joint acceleration, strain stationary:
   :mod:`fts_calib.filters.quasi_static`, the rules of the calibration itself);
2. *the assumed load fits*: the residual ``W_known - C Delta`` (whose mean is the new D)
   scatters about its mean by at most :data:`fts_calib.session.fit.MAX_RATIO` times the
   noise expected on each axis: the strain noise through C (the filter's noise floor of the
   window, as the fit check computes it), the calibration's own expected residual
   (``quality.fit.expected_residual``) or the sample-to-sample scatter of the residual,
   whichever is largest. A tool still mounted while "nothing mounted" is assumed, another
   configuration than the one named, or an arm that moved, make the load change with the
   orientation and the residual scatter by newtons where the noise is millinewtons.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import arrays as validation
from ..core.exceptions import ConfigError, InsufficientExcitation, ResultRefused
from ..filters.chain import FilterChain, filter_chain
from ..filters.quasi_static import RULES, StillSamples, sample_period
from ..filters.settings import QUASI_STATIC, PipelineConfig
from ..model.calibration import Calibration
from ..model.channel_limits import ChannelLimits, detect_limits
from ..model.channels import CALIBRATION_HINT, WRENCH_AXES, WRENCH_UNITS, ChannelLayout, check_channels
from ..model.retare import OffsetEstimate, estimate_offsets
from ..robot.kinematics import Kinematics
from ..robot.tool import Tool
from ..session.fit import MAX_RATIO
from ..sources.batch import SampleBatch
from ..sources.live_feed import LiveFeed, StreamEnd
from ..sources.source import open_recording
from ..sources.synchronizer import Synchronizer
from ..sources.udp import UdpReceiver


@dataclass(frozen=True)
class TareResult:
    """A re-tare.

    Attributes:
        calibration: The calibration with the new offsets (the old ones in its history).
        estimate: The offsets and their standard errors.
        previous: The offsets before, [N, N, N, N m, N m, N m]. Shape (6,).
        samples_seen: Samples read.
        since_calibration: The new offsets minus those at the end of the calibration run,
            [N, N, N, N m, N m, N m]. Shape (6,).
        elapsed_s: Time since the calibration run [s] (from its provenance time), or None
            when the file does not say.
        rails: One line per channel whose samples were refused at its rail
            (:meth:`fts_calib.filters.sample_checks.RailTally.lines`).
    """

    calibration: Calibration
    estimate: OffsetEstimate
    previous: np.ndarray
    samples_seen: int
    since_calibration: np.ndarray = field(default_factory=lambda: np.zeros(6))
    elapsed_s: float | None = None
    rails: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Window:
    """A tare window through the filter chain (quasi-static): what its checks and rules said.

    Attributes:
        chain: The chain it went through (its filter's counts by rule and noise floor).
        checked: The samples that passed the checks (no channel at its rail, declared or detected in the window).
        still: The filter's decisions over them (rules 1-3; with a mounted tool, rule 4 and its load).
        rails: One line per channel whose samples were refused at its rail.
    """

    chain: FilterChain
    checked: SampleBatch
    still: StillSamples
    rails: tuple[str, ...]


def _through_chain(
    window: SampleBatch,
    kin: Kinematics | None,
    tool: Tool | None,
    settings: PipelineConfig,
    limits: ChannelLimits | None,
    names: list[str],
    layout: ChannelLayout,
) -> _Window:
    """The window through the quasi-static filter chain; the rails not declared in ``limits`` are detected in the window.

    Args:
        window: The samples, in time order; ``configuration`` indexes ``names`` (the mounted one's index with a tool).
        kin: Kinematics, or None for the strains alone.
        tool: The mounted tool (its load judged by rule 4 and kept), or None for nothing mounted.
        settings: Pipeline settings (the filter's thresholds).
        limits: The channels' declared resolution and rails.
        names: The configuration names ``window.configuration`` indexes, for the rails' lines.
        layout: The calibration's channel layout.
    """
    finite = np.all(np.isfinite(window.channels), axis=1)
    if kin is not None:
        finite &= np.all(np.isfinite(window.joints), axis=1)
    found = detect_limits(window.channels[finite], limits) if finite.any() else limits
    n_joints = window.joints.shape[1]
    chain = filter_chain(settings.with_limits(found).with_filter_mode(QUASI_STATIC), kin, layout=layout, n_joints=n_joints)
    step = chain.samples(window, tool, final=True)
    rails = () if chain.checks.rails is None else tuple(chain.checks.rails.lines(names))
    return _Window(chain, step.checked, step.still, rails)


#: Smallest share of a tare window's samples that must pass the quasi-static rules 1-3.
MIN_STILL_FRACTION = 0.5


def check_window(calibration: Calibration, window: _Window) -> np.ndarray:
    """Check that a tare window is still (see the module docstring); returns the strain noise it shows.

    Args:
        calibration: The calibration being re-tared (its C maps the noise to wrenches).
        window: The window through the filter chain (:func:`_through_chain`).

    Returns:
        The expected noise of each wrench axis, [N, N, N, N m, N m, N m], shape (6,): the
        strain noise floor of the window through C, at least the calibration's expected
        residual.

    Raises:
        ResultRefused: Fewer than :data:`MIN_STILL_FRACTION` of the samples are still; the
            message gives the share and what each rule rejected.
    """
    if not len(window.checked):  # nothing to judge: the estimate says there is no sample
        return np.zeros(6)
    still = window.still.keep if window.still.still is None else window.still.still  # rules 1-3
    share = float(np.mean(still)) if len(still) else 0.0
    filter_ = window.chain.filter
    rejected = {} if filter_ is None else filter_.rejected
    if share < MIN_STILL_FRACTION:
        counts = ", ".join(f"{rule}: {rejected[rule]:,}" for rule in RULES[:3] if rejected.get(rule))
        windows = "" if filter_ is None else f"; {filter_.settings.windows(sample_period(window.checked.time)).text()}"
        raise ResultRefused(
            f"refused to re-tare (nothing written): the window is not still: {100 * share:.0f} % of its {len(still):,} samples "
            f"pass the quasi-static rules (rejected by {counts or 'none'}), at least {100 * MIN_STILL_FRACTION:.0f} % must: "
            f"record a few seconds with the arm at rest (a calibration recording is no tare window){windows}"
        )
    noise_floor = window.chain.noise_floor
    floor = np.zeros(calibration.layout.n_channels) if noise_floor is None else noise_floor
    sigma = np.sqrt(np.maximum(np.einsum("ij,j,ij->i", calibration.C, floor * floor, calibration.C), 0.0))
    fit = calibration.quality.fit if calibration.quality is not None else None
    recorded = fit.get("expected_residual") if isinstance(fit, dict) else None
    if isinstance(recorded, list) and len(recorded) == 6:
        sigma = np.maximum(sigma, np.abs(np.asarray(recorded, dtype=float)))
    return sigma


def check_load(residual: np.ndarray, noise: np.ndarray, what: str) -> None:
    """Check that the residual ``W_known - C Delta`` of a tare window is noise about its mean (see the module docstring).

    Args:
        residual: The residual per sample, [N, N, N, N m, N m, N m]. Shape (N, 6).
        noise: The expected noise per axis (:func:`check_window`), same units. Shape (6,).
        what: The load assumed, in words ('nothing mounted', "'paper_tool' configuration B mounted").

    Raises:
        ResultRefused: The residual of some axis scatters more than ``MAX_RATIO`` times
            its noise; the message names the worst axis, its scatter and the noise.
    """
    if len(residual) < 2:
        return
    scatter = residual.std(axis=0)
    # white noise shows in the differences of successive samples too (a slow change of the load does not): their
    # mean magnitude is 2 sigma / sqrt(pi), and a few steps between still poses hardly move it (a standard deviation would)
    successive = np.mean(np.abs(np.diff(residual, axis=0)), axis=0) * np.sqrt(np.pi) / 2.0
    expected = np.maximum.reduce([noise, successive, np.full(6, 1e-12)])
    ratio = scatter / expected
    worst = int(np.argmax(ratio))
    if ratio[worst] > MAX_RATIO:
        unit = WRENCH_UNITS[worst]
        raise ResultRefused(
            f"refused to re-tare (nothing written): the load does not fit '{what}': the residual of "
            f"{WRENCH_AXES[worst]} scatters by {scatter[worst]:.3g} {unit} (RMS about its mean), {ratio[worst]:.3g} times the "
            f"noise expected ({expected[worst]:.2g} {unit}; at most {MAX_RATIO:g} times): the load on the sensor changed "
            "during the window. Is a tool mounted (then --robot ROBOT --tool TOOL --configuration NAME), "
            "another configuration than the one named, or did the arm move?"
        )


def _mounted(kin: Kinematics | None, tool: Tool | None, configuration: str | None) -> int | None:
    """The index of the mounted configuration (None: nothing mounted), after checking what its load needs.

    Raises:
        ConfigError: A tool without its configuration or without the kinematics.
        UnknownToolConfiguration: A configuration the tool does not have.
    """
    if tool is None:
        return None
    if configuration is None:
        message = f"tool '{tool.name}' is mounted: give its configuration, one of {tool.names}"
        raise ConfigError("configuration", None, f"one of {tool.names}", message=message)
    index = tool.names.index(tool.configuration(configuration).name)  # UnknownToolConfiguration lists the names
    if kin is None:
        message = f"tool '{tool.name}' is mounted: its load depends on the orientation, so give the kinematics"
        raise ConfigError("kin", None, "the robot's kinematics", message=message)
    return index


def _known_load(window: _Window, mounted: bool) -> tuple[np.ndarray, np.ndarray]:
    """The strains to use and the load on the sensor for each.

    With nothing mounted every checked sample, at zero load; with a tool the quasi-static ones, at its weight.
    """
    if not mounted:
        return window.checked.channels, np.zeros((len(window.checked), 6))
    still = window.still
    return still.samples.channels, still.w_sensor if still.w_sensor is not None else np.zeros((0, 6))


def _apply(
    calibration: Calibration, strain: np.ndarray, load: np.ndarray, reason: str, seen: int, noise: np.ndarray, what: str, rails=()
) -> TareResult:
    if not len(strain):
        if rails:  # holding still would not help: a channel is beyond its range at this load
            railed = "; ".join(rails)
            raise InsufficientExcitation(0, 1, f"no sample to re-tare from: a channel is at its rail ({railed}); check the sensor's zero")
        raise InsufficientExcitation(0, 1, "no still sample to re-tare from: hold the arm still while recording")
    check_load(load - (strain @ calibration.C.T if calibration.model is None else calibration.model.wrench(strain)), noise, what)
    estimate = estimate_offsets(calibration.C_bar, strain, load, calibration.layout, calibration.model)
    what = f"{reason} ({estimate.samples_used:,} samples)"
    history = calibration.offset_history
    at_calibration = np.asarray(history[0]["D"], dtype=float) if history else calibration.D
    elapsed = None
    stamp = calibration.provenance.get("time")
    if isinstance(stamp, str):
        try:
            then = datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00"))
            if then.tzinfo is None:
                then = then.replace(tzinfo=datetime.timezone.utc)  # a time without a zone: UTC, as fts-calib writes it
            elapsed = (datetime.datetime.now(datetime.timezone.utc) - then).total_seconds()
        except ValueError:
            elapsed = None  # a hand-written time: the drift is still reported, without its rate
    updated = calibration.with_offsets(estimate.D, what)
    return TareResult(updated, estimate, calibration.D.copy(), seen, estimate.D - at_calibration, elapsed)


def _what(tool: Tool | None, configuration: str | None) -> str:
    return "nothing mounted" if tool is None else f"'{tool.name}' configuration {configuration} mounted"


def tare_recording(
    calibration: Calibration,
    path: str | Path,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    settings: PipelineConfig | None = None,
    limits: ChannelLimits | None = None,
) -> TareResult:
    """Re-tare from a recording (see the module docstring).

    Args:
        calibration: The calibration to update.
        path: Recording (CSV, or a ROS 2 bag: :mod:`fts_calib.sources.source`) with the sensor still.
        kin: Kinematics (needed with a tool; with nothing mounted the joints are not used).
        tool: The mounted tool, or None for nothing mounted.
        configuration: The mounted configuration of ``tool``.
        settings: Pipeline settings (filter thresholds).
        limits: The channels' declared resolution and rails; what is not declared is detected.

    Raises:
        RecordingError: The recording cannot be read.
        InsufficientExcitation: No usable sample.
        ResultRefused: The window is not still, or its load does not fit the one assumed
            (see the module docstring).
    """
    settings = settings or PipelineConfig()
    joint_names = None if kin is None else kin.joint_names
    with open_recording(path, joint_names, None) as reader:
        chunks = list(reader)
    seen = reader.rows_read
    if not chunks:
        raise InsufficientExcitation(0, 1, f"{path} has no usable row")
    samples = SampleBatch.concatenate(chunks)
    check_channels(calibration.layout, samples.channels.shape[1], str(path), CALIBRATION_HINT)
    index = _mounted(kin, tool, configuration)  # a wrong argument is said before the data are judged
    names = reader.tool_names or ["(none)"]
    if index is not None and tool is not None:  # mounted throughout, whatever the recording's tool column says
        samples, names = dataclasses.replace(samples, configuration=np.full(len(samples), index)), tool.names
    window = _through_chain(samples, kin, tool if index is not None else None, settings, limits, names, calibration.layout)
    noise = check_window(calibration, window)
    strain, load = _known_load(window, index is not None)
    what = _what(tool, configuration)
    result = _apply(calibration, strain, load, f"re-tare from {Path(path).name}, {what}", seen, noise, what, window.rails)
    return dataclasses.replace(result, rails=window.rails)


def tare_live(
    calibration: Calibration,
    host: str,
    port: int,
    seconds: float,
    kin: Kinematics | None = None,
    tool: Tool | None = None,
    configuration: str | None = None,
    settings: PipelineConfig | None = None,
    on_listening: Callable[[tuple[str, int]], None] | None = None,
    limits: ChannelLimits | None = None,
    device: str | None = None,
) -> TareResult:
    """Re-tare from a live window of ``seconds`` [s] (> 0) on the UDP protocol (:mod:`fts_calib.sources.live_feed`).

    With ``device`` (``serial://...``, ``netft://...``) the channels come from that device and
    the datagrams on ``host:port`` give only the joints (with ``kin``; without, no socket).

    The window ends early on the sender's ``end``, Ctrl-C or SIGTERM (what came is used).
    With ``kin`` the strains are paired with the joints; without, the strains alone are
    taken (joint datagrams are counted and ignored). Every sample is placed when the window
    ends, in time order (datagrams arrive out of order).

    ``on_listening`` is called with the bound (host, port) once the socket listens (port 0
    picks a free one), before the window starts. ``limits``: the channels' declared
    resolution and rails; what is not declared is detected in the window.
    """
    validation.positive("seconds", seconds, "s")
    settings = settings or PipelineConfig()
    joint_names = [] if kin is None else kin.joint_names  # none: the strains alone
    continuous = None if kin is None else kin.continuous
    # an infinite hold: nothing is placed (nor dropped as late) before the window ends
    sync = Synchronizer(joint_names, continuous, settings.live.max_gap_s, settings.live.latency_s, hold_s=math.inf)
    if kin is not None and configuration is not None:  # mounted throughout: the sender need not announce it
        sync.add_tool(-math.inf, configuration)
    feed: LiveFeed
    if device is None:
        feed = LiveFeed(UdpReceiver(host, port), sync, end=StreamEnd(duration_s=seconds), on_listening=on_listening)
    else:
        from ..sources.source import open_source

        opened = open_source(
            device,
            joint_names,
            None,
            continuous=continuous,
            max_gap_s=settings.live.max_gap_s,
            latency_s=settings.live.latency_s,
            n_channels=calibration.layout.n_channels,
            configuration=configuration if kin is not None else None,
            hold_s=math.inf,
            end=StreamEnd(duration_s=seconds),
            on_listening=on_listening,
            joints=None if kin is None else f"udp://{host}:{port}",
        )
        assert isinstance(opened, LiveFeed)  # a device's name opens a live feed
        feed = opened
    with feed:
        batches = list(feed)
    stats = feed.stats
    reason = f"re-tare from a live window of {seconds:g} s on {feed.description}, {_what(tool, configuration)}"
    if not stats.strain:
        heard = f"{stats.received:,} datagrams, none of them strain" if stats.received else "no datagram at all"
        raise InsufficientExcitation(0, 1, f"{heard} on {feed.description} in {seconds:g} s: is the sender running, to this port?")
    what = _what(tool, configuration)
    index = _mounted(kin, tool, configuration)
    synced = SampleBatch.concatenate(batches) if batches else SampleBatch.empty(len(joint_names), calibration.layout.n_channels)
    # one load throughout (nothing, or the configuration mounted): the sender need not announce it
    window = dataclasses.replace(synced, configuration=np.full(len(synced), 0 if index is None else index, dtype=np.int64))
    if kin is None:  # the strains alone
        window = dataclasses.replace(window, temperature=None)
    mounted, names = (None, ["(none)"]) if index is None or tool is None else (tool, tool.names)
    through = _through_chain(window, kin, mounted, settings, limits, names, calibration.layout)
    noise = check_window(calibration, through)
    strain, load = _known_load(through, index is not None)
    return dataclasses.replace(_apply(calibration, strain, load, reason, stats.strain, noise, what, through.rails), rails=through.rails)
