"""The parity model learnt at calibration (the ``health`` section) and the health monitor's faults."""

from __future__ import annotations

import json
import shutil
import subprocess
import time as time_module

import numpy as np
import pytest

from fts_calib.app.cli import main
from fts_calib.core.exceptions import FileFormatError
from fts_calib.model.calibration import load_calibration
from fts_calib.model.channels import channel_layout
from fts_calib.model.parity import ParityModel, chi2_isf, chi2_sf, fit_parity
from fts_calib.monitor.health import HealthMonitor
from fts_calib.robot.definition import load_robot
from fts_calib.robot.kinematics import Kinematics
from fts_calib.robot.tool import load_tool, tool_load
from fts_calib.session.calibration_run import calibrate_recording
from fts_calib.sim.sensor import load_simulated_sensor
from fts_calib.sim.service_run import inject_fault, service_wrenches

FULL_SCALE = np.array([50.0, 50.0, 50.0, 5.0, 5.0, 5.0])  # [N, N m]
NOISE = 1e-5  # [mV/V] per bridge, the simulated sensor's


@pytest.fixture(scope="module")
def sensor():
    return load_simulated_sensor("sensor")


@pytest.fixture(scope="module")
def calibrated(ur5_recording):
    """The calibration of the simulated UR5 recording (the paper's sensor and tool)."""
    return calibrate_recording(ur5_recording, Kinematics(load_robot("ur5")), load_tool("paper_tool")).calibration


@pytest.fixture(scope="module")
def parity(sensor):
    """The parity model of 20 s of simulated service with the true C, with the ADC's rails."""
    rng = np.random.default_rng(11)
    t, w = service_wrenches(20.0, 1000.0, rng)
    low, high = sensor.adc_codes
    C = sensor.C_bar @ sensor.layout.projection
    n = sensor.layout.n_channels
    resolution = np.full(n, sensor.lsb)
    return fit_parity(
        sensor.layout, C, sensor.D, sensor.channels(w, t, rng), FULL_SCALE, None, resolution, np.full(n, low), np.full(n, high)
    )


def test_the_calibration_learns_the_parity_of_the_eight_bridges(calibrated, sensor):
    model = ParityModel.from_dict(calibrated.health)
    assert model.n_parity == 2 and model.groups() == [[0, 2, 4, 6], [1, 3, 5, 7]]
    assert calibrated.health["groups"] == [[1, 3, 5, 7], [2, 4, 6, 8]]
    # each parity row has norm ~1 over bridges of noise 1e-5 mV/V: its noise is 1e-5; from about 1,100
    # kept samples the standard deviation is known to 1/sqrt(2 x 1100) = 2 %: 0.85 to 1.2 is > 7 sigma
    noise = np.array(calibrated.health["noise"]) / np.linalg.norm(model.N, axis=1)
    assert np.all((noise > 0.85 * NOISE) & (noise < 1.2 * NOISE)), noise
    # load-free: noiseless channels under loads across the full scale give the same residual to far
    # below the noise (A is fitted from the kept samples; the null content follows the wrench linearly)
    rng = np.random.default_rng(3)
    loads = rng.uniform(-1, 1, (500, 6)) * FULL_SCALE * 0.5
    r = model.residual(sensor.channels(loads))
    assert np.abs(r).max() < 3 * NOISE, np.abs(r).max()
    # the signatures: bridges 1, 3, 5, 7 on one line, 2, 4, 6, 8 on another, nearly orthogonal
    u = model.signatures / np.linalg.norm(model.signatures, axis=1, keepdims=True)
    assert abs(u[0] @ u[1]) < 0.1 and np.all(np.abs(u[[0, 2, 4, 6]] @ u[0]) > 0.99)


def test_the_health_section_round_trips_and_old_files_still_load(calibrated, tmp_path):
    path = calibrated.save(tmp_path / "cal.yaml")
    again = load_calibration(path)
    a, b = ParityModel.from_dict(calibrated.health), ParityModel.from_dict(again.health)
    for name in ("N", "c", "A", "covariance", "channel_noise", "zero", "gain", "span_low", "span_high", "low", "high"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert load_calibration("paper_table1_calibration").health is None  # a file without the section
    text = path.read_text().replace("  covariance:", "  covariance_gone:")
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(FileFormatError, match=r"health\.covariance"):
        load_calibration(tmp_path / "bad.yaml")


def test_a_layout_without_spare_channels_has_no_parity(sensor):
    rng = np.random.default_rng(2)
    wrench6 = channel_layout("wrench-6")
    assert fit_parity(wrench6, np.eye(6), np.zeros(6), rng.standard_normal((200, 6)), FULL_SCALE) is None


def test_chi_square_tail_matches_the_tables():
    # tabulated 5 % points of chi-square with 1, 2, 3 degrees of freedom
    for x, dof in ((3.841458820694124, 1), (5.991464547107979, 2), (7.814727903251178, 3)):
        assert chi2_sf(x, dof) == pytest.approx(0.05, rel=1e-9)
        assert chi2_isf(0.05, dof) == pytest.approx(x, rel=1e-9)


# faults: each kind on each channel, 6 s of service, the fault at 3 s; named within 2 s
FAULTS = [("gain", -0.01, "gain"), ("jump", 2e-4, "jump"), ("frozen", 0.0, "frozen"), ("open", 0.0, "rail")]


@pytest.mark.parametrize(("fault", "size", "kind"), FAULTS)
def test_each_fault_is_found_and_named_on_every_channel(parity, sensor, fault, size, kind):
    high = sensor.adc_codes[1]
    for channel in range(1, 9):
        rng = np.random.default_rng(100 * channel + len(fault))
        t, w = service_wrenches(6.0, 1000.0, rng)
        broken = inject_fault(sensor.channels(w, t, rng), t, fault, channel, 3.0, size, rail=high)
        monitor = HealthMonitor(parity)
        monitor.update_batch(t, broken)
        assert monitor.events, f"{fault} on channel {channel} not found"
        first = monitor.events[0]
        assert (first.kind, first.channel) == (kind, channel), (fault, channel, monitor.events)
        assert 3.0 <= first.detected_s <= 5.0 and abs(first.time_s - 3.0) <= 1.0, first


def test_a_shorted_bridge_without_declared_rails_is_out_of_range(parity, sensor):
    """A bridge driven beyond what any load within the full scale gives it (no rails known) is open or shorted."""
    free = ParityModel(**{**parity.__dict__, "low": np.full(8, -np.inf), "high": np.full(8, np.inf)})
    rng = np.random.default_rng(7)
    t, w = service_wrenches(5.0, 1000.0, rng)
    for channel in (2, 7):
        broken = inject_fault(sensor.channels(w, t, rng), t, "shorted", channel, 2.5, rail=5.0)
        monitor = HealthMonitor(free)
        monitor.update_batch(t, broken)
        assert [(e.kind, e.channel) for e in monitor.events[:1]] == [("open-or-shorted", channel)]
        assert monitor.events[0].time_s == pytest.approx(2.5, abs=1e-9)


def test_clean_service_with_drifting_offsets_raises_nothing(parity, sensor):
    """60 s of clean service with the channels drifting (an offset, no fault): the budget is 1e-3 false alarms per hour."""
    rng = np.random.default_rng(5)
    t, w = service_wrenches(60.0, 1000.0, rng)
    drift = 2e-6 * t[:, None] * np.linspace(-1, 1, 8)  # [mV/V]: 2e-6 per s, 12 noise sigmas per minute
    monitor = HealthMonitor(parity)
    channels = sensor.channels(w, t, rng) + drift
    half = len(t) // 2
    for i in range(1000):  # sample by sample too: the same code as batches
        monitor.update(t[i], channels[i])
    monitor.update_batch(t[1000:half], channels[1000:half])
    monitor.update_batch(t[half:], channels[half:])
    assert monitor.events == [] and monitor.state == "ok"
    assert monitor.samples == len(t)


def _service_csv(path, time, channels) -> None:
    """A service recording: time, the channels, the tool configuration (no joints: the monitor needs none)."""
    header = "time," + ",".join(f"strain_{k + 1}" for k in range(channels.shape[1])) + ",tool"
    rows = "\n".join(f"{float(t)!r}," + ",".join(repr(float(v)) for v in row) + ",A" for t, row in zip(time, channels, strict=True))
    path.write_text(header + "\n" + rows + "\n")


def test_cli_monitor_names_the_fault_and_writes_json(parity, sensor, calibrated, tmp_path, capsys):
    from dataclasses import replace

    cal = replace(calibrated, health=parity.to_dict()).save(tmp_path / "cal.yaml")  # the true sensor's parity, rails
    rng = np.random.default_rng(21)
    t, w = service_wrenches(6.0, 1000.0, rng)
    broken = inject_fault(sensor.channels(w, t, rng), t, "frozen", 6, 2.0)
    _service_csv(tmp_path / "service.csv", t, broken)
    code = main(["monitor", "--calibration", str(cal), str(tmp_path / "service.csv"), "--json", str(tmp_path / "health.json")])
    out = capsys.readouterr().out
    assert code == 1 and "strain_6" in out and "health: 1 fault(s)" in out, out
    data = json.loads((tmp_path / "health.json").read_text())
    assert [(e["kind"], e["channel"]) for e in data["events"]] == [("frozen", 6)]
    assert abs(data["events"][0]["time_s"] - 2.0) < 1e-6 and data["samples"] == len(t) and data["health"] == "fault"
    _service_csv(tmp_path / "clean.csv", t, sensor.channels(w, t, rng))
    assert main(["monitor", "--calibration", str(cal), str(tmp_path / "clean.csv")]) == 0
    assert "health: ok, no fault found" in capsys.readouterr().out


def test_cli_monitor_refuses_a_calibration_without_health(tmp_path, capsys):
    _service_csv(tmp_path / "s.csv", np.arange(3) / 1000.0, np.zeros((3, 8)))
    assert main(["monitor", "--calibration", "paper_table1_calibration", str(tmp_path / "s.csv")]) == 3
    assert "has no health section" in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("double", [True, False])
def test_the_exported_c_parity_check_matches_python(parity, sensor, calibrated, tmp_path, double):
    from dataclasses import replace

    from fts_calib.service.exports import c_header

    cal = replace(calibrated, health=parity.to_dict())
    (tmp_path / "fts_calib.h").write_text(c_header(cal))
    rng = np.random.default_rng(4)
    t, w = service_wrenches(0.05, 1000.0, rng)
    channels = inject_fault(sensor.channels(w, t, rng), t, "jump", 3, 0.025, 1e-3)  # half the samples flagged
    baseline = np.array([0.5, -0.25])
    rows = ",\n".join("{" + ", ".join(f"{v!r}" for v in row) + "}" for row in channels.tolist())
    main_c = f"""#include <stdio.h>
#include "fts_calib.h"
static const fts_calib_real samples[{len(channels)}][8] = {{{rows}}};
int main(void) {{
    const fts_calib_real baseline[2] = {{{float(baseline[0])!r}, {float(baseline[1])!r}}};
    fts_calib_real e[2];
    for (int i = 0; i < {len(channels)}; ++i) {{
        int flag = fts_calib_parity(samples[i], baseline, e);
        printf("%.17g %.17g %d\\n", (double)e[0], (double)e[1], flag);
    }}
    return 0;
}}
"""
    (tmp_path / "main.c").write_text(main_c)
    flags = ["-DFTS_CALIB_DOUBLE"] if double else []
    build = ["cc", "-std=c99", "-Wall", "-Werror", *flags, "-o", str(tmp_path / "main"), str(tmp_path / "main.c"), "-lm"]
    subprocess.run(build, check=True, capture_output=True)
    out = subprocess.run([str(tmp_path / "main")], check=True, capture_output=True, text=True).stdout.split("\n")
    got = np.array([[float(v) for v in line.split()] for line in out if line])
    expected = [parity.check(row, baseline) for row in channels]
    e = np.array([x[0] for x in expected])
    # double: rounding of the printed constants only. float: entries of L N ~5e4 times readings ~0.05
    # summed over 8 channels, ~3e3 with a float epsilon of 6e-8: a few 1e-4 of a noise sigma
    atol = 1e-7 if double else 5e-3
    np.testing.assert_allclose(got[:, :2], e, atol=atol)
    flags_python = np.array([x[1] for x in expected])
    assert 0 < flags_python.sum() < len(flags_python)
    assert np.array_equal(got[:, 2].astype(bool), flags_python)


def test_cli_monitor_listens_to_the_live_feed(parity, sensor, calibrated, tmp_path):
    """The same faults from strain datagrams (with a malformed one, skipped): frozen bridge 4 named, then 'end'."""
    import re
    import socket
    import sys
    from dataclasses import replace

    from fts_calib.sources.udp import End as EndMessage
    from fts_calib.sources.udp import Strain, encode

    cal = replace(calibrated, health=parity.to_dict()).save(tmp_path / "cal.yaml")
    rng = np.random.default_rng(31)
    t, w = service_wrenches(3.0, 1000.0, rng)
    broken = inject_fault(sensor.channels(w, t, rng), t, "frozen", 4, 1.5)
    command = [sys.executable, "-m", "fts_calib.app.cli", "monitor", "--calibration", str(cal), "udp://127.0.0.1:0", "--quiet"]
    command += ["--json", str(tmp_path / "live.json"), "--idle-timeout", "20"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        first = process.stdout.readline()
        port = int(re.search(r"udp://127\.0\.0\.1:(\d+)", first).group(1))
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            sock.sendto(b"{not json", ("127.0.0.1", port))
            for i in range(len(t)):
                sock.sendto(encode(Strain(float(t[i]), tuple(float(v) for v in broken[i]))), ("127.0.0.1", port))
                if i % 200 == 0:
                    time_module.sleep(0.001)  # let the receiver keep up with a burst on a busy machine
            sock.sendto(encode(EndMessage()), ("127.0.0.1", port))
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 1, (first + out, err)
    data = json.loads((tmp_path / "live.json").read_text())
    assert [(e["kind"], e["channel"]) for e in data["events"]] == [("frozen", 4)], data
    assert data["skipped"] >= 1  # the malformed datagram
    assert data["region"]["samples"] == data["samples"] > 0  # every strain datagram counted, one at a time


def test_cli_monitor_tracks_the_offset_and_retares(calibrated, ur5_recording, tmp_path, capsys):
    """The calibration's own recording with every wrench shifted by 0.5 N on Fx (1 % FS): --auto-tare writes D - 0.5 N."""
    import csv

    shift = np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0])  # [N]
    shift_channels = np.linalg.pinv(calibrated.C) @ shift  # channels that read the shift as a wrench
    with open(ur5_recording, newline="") as source, open(tmp_path / "shifted.csv", "w", newline="") as target:
        reader, writer = csv.reader(source), csv.writer(target)
        header = next(reader)
        writer.writerow(header)
        columns = [header.index(f"strain_{k + 1}") for k in range(8)]
        for row in reader:
            for k, column in enumerate(columns):
                row[column] = repr(float(row[column]) + float(shift_channels[k]))
            writer.writerow(row)
    cal = calibrated.save(tmp_path / "cal.yaml")
    command = ["monitor", "--calibration", str(cal), "--robot", "ur5", "--tool", "paper_tool", str(tmp_path / "shifted.csv")]
    assert main([*command, "--auto-tare", "--json", str(tmp_path / "m.json")]) == 0
    out = capsys.readouterr().out
    assert "re-tared 1 time(s)" in out and "windows without contact" in out, out
    tared = load_calibration(cal)
    assert tared.offset_history[-1]["D"] == calibrated.D.tolist() and "re-tared by monitor" in tared.offset_history[-1]["reason"]
    # the still windows' means: noise 2 mN / sqrt(10) per window, the calibration's own fit error ~ 1 mN: 0.02 N is > 5 sigma
    np.testing.assert_allclose(tared.D, calibrated.D - shift, atol=0.02)
    assert json.loads((tmp_path / "m.json").read_text())["offset"]["tares_s"]


def test_monitor_offsets_do_not_depend_on_how_the_feed_is_batched(calibrated, ur5_recording, tmp_path):
    """The recording shifted 0.8 N on Fx and drifting 1 N/min on Fy, fed in batches of 1, 7, 100, 1000 samples or all:
    the same windows, the same re-tares at the same times, the same tracked offset as one batch."""
    from fts_calib.app.monitor import OffsetFeed
    from fts_calib.app.setup import Setup, load_setup
    from fts_calib.monitor.offset_watch import OffsetWatch
    from fts_calib.sources.source import open_recording

    kin, payload, _ = load_setup("ur5", "paper_tool")
    with open_recording([ur5_recording], kin.joint_names, payload.names) as reader:
        chunks = list(reader)
    t, q, s, codes = (np.concatenate([getattr(c, k) for c in chunks]) for k in ("time", "joints", "channels", "configuration"))
    drift = np.array([0.8, 0.0, 0.0, 0.0, 0.0, 0.0]) + np.outer(t - t[0], [0.0, 1.0 / 60, 0.0, 0.0, 0.0, 0.0])  # [N]
    s = s + drift @ np.linalg.pinv(calibrated.C).T  # channels that read the drift as a wrench
    parity = ParityModel.from_dict(calibrated.health)
    results = {}
    for auto_tare in (False, True):
        for size in (1, 7, 100, 1000, len(t)):
            feed = OffsetFeed(
                calibrated, tmp_path / f"{size}.yaml", parity, Setup(robot_file="ur5", tool_file="paper_tool"), auto_tare, 1.0
            )
            for start in range(0, len(t), size):
                feed.add(t[start : start + size], q[start : start + size], s[start : start + size], codes[start : start + size])
            feed.finish()
            w = feed.watch
            results[auto_tare, size] = (w.block, w.updates, w.contacts, feed.tares, w.last_time, w.offset, feed.calibration.D)
        reference = results[auto_tare, len(t)]
        for size in (1, 7, 100, 1000):
            assert results[auto_tare, size][:5] == reference[:5], (auto_tare, size, results[auto_tare, size][:5], reference[:5])
            for k in (5, 6):  # equal to rounding (a matrix product over another number of rows sums in another order)
                np.testing.assert_allclose(results[auto_tare, size][k], reference[k], rtol=1e-9, atol=1e-12)
    # one batch is the watch's own windows of 0.1 s (10 samples at 100 Hz) over the whole recording, the still ones
    block, updates, contacts, *_ = results[False, len(t)]
    watch = OffsetWatch(feed.watch.noise, feed.watch.allowance, block=10)
    watch.update_batch(t, calibrated.wrench(s), tool_load(kin, payload, q, codes).static, q)
    assert (block, updates, contacts) == (10, watch.updates, watch.contacts) and updates > 100, (block, updates, contacts)
    # windows of a moving arm are refused (its dynamics, steady at a constant speed, put 0.07 N to 0.3 N in the mean):
    # what is tracked is the drift at the last update to the calibration's own error (~1 mN) and the tracker's noise
    _, _, _, _, last, offset, _ = results[False, len(t)]
    np.testing.assert_allclose(offset, drift[np.searchsorted(t, last)], atol=0.005)
    # re-tared 0.5 N (1 % FS) at a time: what the re-tares took off plus what is tracked is the drift at the last update
    _, _, _, tares, last, offset, D = results[True, len(t)]
    assert len(tares) >= 3, tares
    np.testing.assert_allclose(calibrated.D - D + offset, drift[np.searchsorted(t, last)], atol=0.02)


def test_cli_monitor_listens_with_joints_and_tracks_the_offset(calibrated, ur5_recording, tmp_path):
    """Joint, tool and strain datagrams of the calibration's own recording: paired, no fault, the offset error near 0."""
    import csv
    import re
    import socket
    import sys

    from fts_calib.sources.udp import End, Joints, Strain, ToolChange, encode

    cal = calibrated.save(tmp_path / "cal.yaml")
    command = [sys.executable, "-m", "fts_calib.app.cli", "monitor", "--calibration", str(cal), "udp://127.0.0.1:0"]
    command += ["--robot", "ur5", "--tool", "paper_tool", "--quiet", "--json", str(tmp_path / "m.json"), "--idle-timeout", "20"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        port = int(re.search(r"udp://127\.0\.0\.1:(\d+)", process.stdout.readline()).group(1))
        with open(ur5_recording, newline="") as source, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            reader = csv.reader(source)
            header = next(reader)
            joints = [name for name in header if name not in ("time", "tool") and not name.startswith("strain_")]
            tool = None
            for i, row in enumerate(reader):
                values = dict(zip(header, row, strict=True))
                t = float(values["time"])
                if values["tool"] != tool:
                    tool = values["tool"]
                    sock.sendto(encode(ToolChange(t - 1e-3, tool)), ("127.0.0.1", port))
                sock.sendto(encode(Joints(t, {name: float(values[name]) for name in joints})), ("127.0.0.1", port))
                sock.sendto(encode(Strain(t, tuple(float(values[f"strain_{k + 1}"]) for k in range(8)))), ("127.0.0.1", port))
                if i % 10 == 0:
                    time_module.sleep(0.001)  # paced: a burst overflows the receiver on a busy machine (datagrams lost)
            sock.sendto(encode(End()), ("127.0.0.1", port))
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 0, (out, err)
    data = json.loads((tmp_path / "m.json").read_text())
    assert data["events"] == [] and data["samples"] > 8000, data["samples"]
    # the recording the calibration came from: its still windows read the payload to the calibration's own error.
    # However the datagrams were batched on arrival, the live path judges the windows the recording's file gives
    # (130 accepted, 770 refused) when every datagram arrived. A lost strain datagram re-phases the windows after
    # it: a loss re-phases them: then only more than half.
    assert main(["monitor", "--calibration", str(cal), str(ur5_recording), "--robot", "ur5", "--json", str(tmp_path / "f.json")]) == 0
    recorded = json.loads((tmp_path / "f.json").read_text())
    assert recorded["offset"]["windows_without_contact"] > 100, recorded["offset"]
    if data["samples"] == recorded["samples"] and data["skipped"] == 0:
        assert data["offset"]["windows_without_contact"] == recorded["offset"]["windows_without_contact"], (data, recorded)
        assert data["offset"]["windows_refused"] == recorded["offset"]["windows_refused"], (data, recorded)
    else:
        assert data["offset"]["windows_without_contact"] > recorded["offset"]["windows_without_contact"] // 2, (data, recorded)
    assert np.all(np.abs(data["offset"]["error"][:3]) < 0.02) and np.all(np.abs(data["offset"]["error"][3:]) < 0.002), data["offset"]


def test_cli_monitor_counts_the_samples_outside_the_calibrated_load_region(calibrated, sensor, tmp_path, capsys):
    """A 1 kg payload turned through random orientations for 2 s, then a 3 kg one: the calibration tool weighs 2 kg."""
    from dataclasses import replace

    rng = np.random.default_rng(41)
    light, heavy = service_wrenches(2.0, 1000.0, rng), service_wrenches(2.0, 1000.0, rng, mass=3.0)
    t, w = np.concatenate([light[0], heavy[0] + 2.0]), np.vstack([light[1], heavy[1]])
    channels = sensor.channels(w, t, rng)
    _service_csv(tmp_path / "service.csv", t, channels)
    cal = calibrated.save(tmp_path / "cal.yaml")
    assert main(["monitor", "--calibration", str(cal), str(tmp_path / "service.csv"), "--json", str(tmp_path / "m.json")]) == 0
    out = capsys.readouterr().out
    # the count, computed here from C and D directly (the calibration is linear)
    outside = int(np.count_nonzero(~calibrated.region.contains(channels @ calibrated.C.T + calibrated.D)))
    # every 3 kg sample is outside (|F| = 29.4 N > 19.62 N + 0.87 N), the 1 kg ones in the box here
    assert len(heavy[0]) <= outside < len(t)
    assert f"{outside:,} of {len(t):,} samples ({100 * outside / len(t):.3g} %) outside the calibrated load region" in out, out
    assert json.loads((tmp_path / "m.json").read_text())["region"] == {"outside": outside, "samples": len(t)}
    bare = replace(calibrated, region=None).save(tmp_path / "bare.yaml")
    assert main(["monitor", "--calibration", str(bare), str(tmp_path / "service.csv"), "--json", str(tmp_path / "b.json")]) == 0
    assert "load region: the calibration records none" in capsys.readouterr().out
    assert json.loads((tmp_path / "b.json").read_text())["region"] is None


def test_cli_monitor_watches_a_serial_line_until_the_cable_is_pulled(parity, sensor, calibrated, tmp_path, capsys):
    """The frozen bridge 4 found from a serial line of integer counts (a pseudo-terminal), the run ended by the cable pulled."""
    import os
    import threading
    from dataclasses import replace

    from fts_calib.app.cli import main

    cal = replace(calibrated, health=parity.to_dict()).save(tmp_path / "cal.yaml")
    rng = np.random.default_rng(31)
    t, w = service_wrenches(3.0, 1000.0, rng)
    broken = np.round(inject_fault(sensor.channels(w, t, rng), t, "frozen", 4, 1.5) / sensor.lsb).astype(np.int64)  # ADC codes
    master, slave = os.openpty()
    lines = [b",".join(b"%d" % v for v in row) + b"\n" for row in broken]

    def write() -> None:
        time_module.sleep(0.3)
        os.write(master, b"\n")
        for k in range(0, len(lines), 20):  # 20 samples every 20 ms: 1 kHz
            os.write(master, b"".join(lines[k : k + 20]))
            time_module.sleep(0.02)
        time_module.sleep(0.1)
        os.close(master)

    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    try:
        code = main(
            [
                "monitor",
                "--calibration",
                str(cal),
                f"serial://{os.ttyname(slave)}?channels=8&scale={sensor.lsb!r}",
                "--quiet",
                "--json",
                str(tmp_path / "s.json"),
            ]
        )
    finally:
        writer.join()
        os.close(slave)
    captured = capsys.readouterr()
    assert code == 1, captured
    data = json.loads((tmp_path / "s.json").read_text())
    assert [(e["kind"], e["channel"]) for e in data["events"]] == [("frozen", 4)], data
    assert data["samples"] >= len(t) - 1  # the first line may come cut (pyserial empties the input on opening)


def test_the_parity_covariance_is_at_least_the_sample_and_the_floor_and_positive_definite(rng):
    """The matrix order's maximum of a near-singular sample covariance (the 16-bit still run's,
    seed 1, that stopped a calibration) and a floor of rank 1 (one channel's step known): each
    difference positive semidefinite, the result positive definite; a sample above the floor stays."""
    from fts_calib.model.parity import covariance_floored

    sample = np.array([[1.1568688483422668e-09, 6.977219320422668e-11], [6.977219320422668e-11, 4.2080473957819465e-12]])
    v = np.array([0.3, -0.5])
    floor = np.outer(v, v) * (2.0**-22 * 1000) ** 2 / 12
    got = covariance_floored(sample, floor)
    scale = np.trace(got)
    assert np.linalg.eigvalsh(got - sample).min() >= -1e-12 * scale
    assert np.linalg.eigvalsh(got - floor).min() >= -1e-12 * scale
    assert np.linalg.eigvalsh(got).min() > 1e-7 * scale
    np.linalg.cholesky(got)
    above = rng.standard_normal((50, 2))
    above = above.T @ above / 50 * 1e-8
    np.testing.assert_allclose(covariance_floored(above, 1e-3 * above), above, rtol=1e-9, atol=1e-6 * np.trace(above))
    assert covariance_floored(np.zeros((2, 2)), np.zeros((2, 2))) is None
