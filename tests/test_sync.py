"""The synchronizer: interpolation, reordering, gaps, latency, continuous joints."""

import math

import numpy as np

from fts_calib.sources.synchronizer import BEFORE_JOINTS, JOINT_GAP, LATE, NO_TOOL, WRONG_LENGTH, Synchronizer

NAMES = ["a", "b"]


def _joints(sync, times, f):
    for t in times:
        sync.add_joints(t, dict(zip(NAMES, f(t), strict=True)))


def test_linear_motion_is_interpolated_exactly_at_strain_times(rng):
    sync = Synchronizer(NAMES, max_gap_s=0.05)
    sync.add_tool(0.0, "A")
    motion = lambda t: (0.5 * t + 0.1, -2.0 * t)  # noqa: E731
    _joints(sync, np.arange(0, 1.0001, 0.01), motion)
    strain_t = np.sort(rng.uniform(0.0, 0.9, 200))
    for t in strain_t:
        sync.add_strain(t, [t] * 8)
    out = sync.pop()
    np.testing.assert_array_equal(out.time, strain_t)  # passed through, not computed
    np.testing.assert_allclose(out.joints, np.column_stack(motion(strain_t)), atol=1e-12)
    np.testing.assert_array_equal(out.channels[:, 0], strain_t)
    assert out.configuration.tolist() == [0] * 200 and sync.configurations == ["A"]


def test_reordered_messages_are_placed_in_time_order(rng):
    sync = Synchronizer(NAMES, max_gap_s=0.05)
    sync.add_tool(0.0, "A")
    times = np.arange(0, 1.0, 0.01)
    order = rng.permutation(len(times))
    _joints(sync, times[order], lambda t: (t, 0.0))
    strain_t = np.arange(0.005, 0.9, 0.002)
    for t in strain_t[rng.permutation(len(strain_t))]:
        sync.add_strain(t, [0.0] * 8)
    out = sync.pop()
    np.testing.assert_array_equal(out.time, strain_t)  # passed through in time order, not computed
    np.testing.assert_allclose(out.joints[:, 0], strain_t, atol=1e-12)


def test_gaps_are_refused_and_counted():
    sync = Synchronizer(NAMES, max_gap_s=0.05)
    sync.add_tool(0.0, "A")
    _joints(sync, [0.0, 0.01, 0.02, 0.2, 0.21, 0.5], lambda t: (t, t))  # a 180 ms gap
    for t in (0.015, 0.1, 0.205, -0.5):
        sync.add_strain(t, [0.0] * 8)
    out = sync.pop()
    assert out.time.tolist() == [0.015, 0.205]
    assert sync.dropped == {JOINT_GAP: 1, BEFORE_JOINTS: 1}


def test_latency_is_compensated():
    """Joint stamps 30 ms late: the synchronizer shifts them back before interpolating."""
    sync = Synchronizer(NAMES, max_gap_s=0.05, latency_s=0.03)
    sync.add_tool(0.0, "A")
    _joints(sync, np.arange(0, 1, 0.01) + 0.03, lambda t: (t - 0.03, 0.0))  # stamped late
    sync.add_strain(0.5, [0.0] * 8)
    out = sync.pop()
    np.testing.assert_allclose(out.joints[0, 0], 0.5, atol=1e-12)


def test_continuous_joints_take_the_shorter_arc():
    sync = Synchronizer(NAMES, continuous=[True, False], max_gap_s=0.05)
    sync.add_tool(0.0, "A")
    sync.add_joints(0.0, {"a": math.pi - 0.1, "b": 0.0})
    sync.add_joints(0.02, {"a": -math.pi + 0.1, "b": 0.0})  # across +-pi: 0.2 rad, not 6.08 rad
    sync.add_strain(0.01, [0.0] * 8)
    out = sync.pop(final=True)
    assert abs(math.remainder(out.joints[0, 0] - math.pi, 2 * math.pi)) < 1e-12


def test_tool_changes_and_late_strains():
    sync = Synchronizer(NAMES, max_gap_s=0.05)
    _joints(sync, np.arange(0, 2, 0.01), lambda t: (0.0, 0.0))
    sync.add_strain(0.1, [0.0] * 8)  # before any tool message
    sync.add_tool(0.5, "A")
    sync.add_tool(1.0, "B")
    sync.add_strain(0.7, [0.0] * 8)
    sync.add_strain(1.2, [0.0] * 8)
    out = sync.pop()
    assert [sync.configurations[k] for k in out.configuration] == ["A", "B"] and sync.dropped == {NO_TOOL: 1}
    sync.add_strain(0.8, [0.0] * 8)  # after 1.2 was placed
    assert sync.dropped[LATE] == 1


def test_joint_messages_with_other_joints_are_refused():
    sync = Synchronizer(NAMES)
    assert not sync.add_joints(0.0, {"a": 0.0})
    assert not sync.add_joints(0.0, {"a": 0.0, "c": 1.0})
    assert sync.add_joints(0.0, {"b": 0.0, "a": 1.0})


def test_strain_messages_of_another_length_are_counted_and_named():
    sync = Synchronizer(NAMES, max_gap_s=0.05, n_channels=6)
    sync.add_tool(0.0, "A")
    _joints(sync, np.arange(0, 1, 0.01), lambda t: (0.0, 0.0))
    sync.add_strain(0.1, [1.0] * 6)
    sync.add_strain(0.2, [1.0] * 8)  # the paper's sensor sending to a 6-channel run
    sync.add_strain(0.3, [1.0] * 6)
    out = sync.pop()
    assert out.channels.shape == (2, 6)
    assert sync.dropped == {f"{WRONG_LENGTH} 6": 1}
    assert "expected 6" in next(iter(sync.dropped))


def test_without_a_length_the_first_message_sets_it():
    sync = Synchronizer(NAMES, max_gap_s=0.05)
    assert sync.pop().channels.shape == (0, 8)  # nothing yet: the paper's sensor
    sync.add_tool(0.0, "A")
    _joints(sync, np.arange(0, 1, 0.01), lambda t: (0.0, 0.0))
    sync.add_strain(0.1, [1.0] * 7)
    sync.add_strain(0.2, [1.0] * 6)
    assert sync.pop().channels.shape == (1, 7) and sync.n_channels == 7
    assert sync.dropped == {f"{WRONG_LENGTH} 7": 1}


# --- the strain stream alone (no joints expected) ----------------------------------------------------------


def _strains(sync, times):
    for t in times:
        sync.add_strain(t, [t] * 8)


def test_without_joints_a_hold_of_zero_places_each_strain_on_arrival_and_drops_the_late_ones():
    """The health monitor's stream: in arrival order, a strain at or before the newest one is late (dropped, counted)."""
    sync = Synchronizer([], hold_s=0.0)
    assert sync.strain_only
    _strains(sync, [0.0, 0.02, 0.01, 0.03, 0.03, 0.05])  # 0.01 arrives after 0.02; 0.03 twice
    out = sync.pop()
    assert out.time.tolist() == [0.0, 0.02, 0.03, 0.05] and out.joints.shape == (4, 0)
    assert out.channels[:, 0].tolist() == out.time.tolist()
    assert sync.dropped == {LATE: 2}
    assert out.configuration.tolist() == [-1] * 4  # no tool announced: unknown, not dropped


def test_without_joints_what_is_placed_does_not_depend_on_how_often_it_is_popped(rng):
    """Reordered strains with a hold of 30 ms: popped after every message, every tenth, or once, the same samples."""
    times = np.arange(0.0, 2.0, 0.001)
    order = np.argsort(times + rng.uniform(0.0, 0.04, len(times)))  # up to 40 ms late: some beyond the hold
    results = []
    for every in (1, 10, len(times)):
        sync = Synchronizer([], hold_s=0.03)
        placed = []
        for k, t in enumerate(times[order]):
            sync.add_strain(t, [t] * 8)
            if (k + 1) % every == 0:
                placed.append(sync.pop().time)
        placed.append(sync.pop(final=True).time)
        got = np.concatenate(placed)
        assert np.all(np.diff(got) > 0), "placed in time order"
        results.append((got.tolist(), dict(sync.dropped)))
    assert results[0] == results[1] == results[2] and results[0][1].get(LATE, 0) > 0, results[0][1]


def test_without_joints_an_infinite_hold_places_every_strain_at_the_end_in_time_order():
    """The tare window's stream: nothing placed (nor late) before the final pop, then all of it, sorted."""
    sync = Synchronizer([], hold_s=math.inf)
    sync.add_tool(-math.inf, "B")
    _strains(sync, [0.3, 0.1, 0.2, 0.1])
    assert len(sync.pop()) == 0
    out = sync.pop(final=True)
    assert out.time.tolist() == [0.1, 0.1, 0.2, 0.3] and not sync.dropped
    assert [sync.configurations[k] for k in out.configuration] == ["B"] * 4
