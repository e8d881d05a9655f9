"""The identifier node counts the samples it receives, uses, loses (gaps in an input's stamps) and skips
(out-of-order or duplicate stamps) (issue 21: it once used 14085 of 19996 samples without a word): the counts
are on its /diagnostics status (WARN when any were lost or skipped) and in one warning line when the first are
lost, one with the totals at the end, and not a line per gap.

The node is built in this process (rclpy initialised in the test run's own domain, discovery on this host only)
and fed frames through its frame handling directly: nothing is spun, no other process takes part. The expected
counts are worked out by hand from the frames each test leaves out, repeats or swaps."""
import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from ros_isolation import isolated_env

from emla_core import messages
from emla_identification.nodes.identifier_node import IdentifierNode, SampleCounts

pytestmark = pytest.mark.timeout(120)

TS, STEP = 1e-4, 100_000      # s, ns
FRAME = 10                    # samples per frame
FRAMES = 200                  # 0.2 s
SUMMARY = 'samples received used'


class Published:
    """Stands in for the node's /diagnostics publisher: what it published."""

    def __init__(self):
        self.arrays = []

    def publish(self, array):
        self.arrays.append(array)

    def last(self):
        (status,) = self.arrays[-1].status
        return status, {kv.key: kv.value for kv in status.values}


@pytest.fixture
def node(monkeypatch):
    """make(**parameters): an IdentifierNode with those parameters, its /diagnostics recorded."""
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    made = []

    def make(**parameters):
        args = ['--ros-args', *(a for k, v in parameters.items() for a in ('-p', f'{k}:={v}'))]
        rclpy.init(args=args, domain_id=int(isolated_env()['ROS_DOMAIN_ID']))
        made.append(IdentifierNode())
        made[-1].diagnostics = Published()
        return made[-1]
    yield make
    for built in made:
        built.destroy_node()
    rclpy.try_shutdown()


def signals(names, seed=1):
    """{name: FRAMES * FRAME samples} of a first-order system driven by noise (any data feed the counts)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(FRAMES * FRAME)
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = 0.9 * y[k - 1] + 0.1 * u[k - 1]
    return dict(zip(names, (u, y, np.cumsum(y) * 1e-4), strict=False))


def feed(node, data, lose=(), repeat=(), swap=()):
    """Send each input's frames k = 0..FRAMES-1 (stamp k FRAME Ts, samples aligned) in order, but frames (k,
    name) in `lose` never, those in `repeat` twice and those in `swap` after the next one; then the end."""
    for name, values in data.items():
        order = list(range(FRAMES))
        for k, swapped in swap:
            if swapped == name:
                order[k], order[k + 1] = order[k + 1], order[k]
        for k in order:
            if (k, name) in lose:
                continue
            for _ in range(1 + ((k, name) in repeat)):
                node.receive(name, k * FRAME * STEP, values[k * FRAME:(k + 1) * FRAME], TS)


def done(node):
    node.on_done(messages.time_msg(FRAMES * FRAME * STEP))


def warnings(err):
    return [line for line in err.splitlines() if SUMMARY in line]


def test_arx_on_frames_with_lost_repeated_and_swapped_ones(node, capfd):
    identifier = node(model='arx')
    lose = {(50, 'voltage'), (50, 'current'), (51, 'voltage'), (51, 'current')}   # a burst lost on both
    feed(identifier, signals(('voltage', 'current')), lose=lose, repeat={(80, 'voltage')}, swap={(120, 'current')})
    first = warnings(capfd.readouterr().err)
    # voltage: 198 frames + 1 repeated received, 20 samples lost, the 10 repeated skipped; current: 198 frames,
    # the 20 samples of the burst and the 10 of frame 121 that came before 120 lost, then 120 (late) skipped
    assert len(first) == 1 and 'so far' in first[0]                      # one line at the first loss, not per gap
    done(identifier)
    status, values = identifier.diagnostics.last()
    assert values['samples_received'] == str(199 * FRAME)
    assert values['samples_lost'] == str(3 * FRAME) and values['samples_skipped'] == str(FRAME)
    # used: the instants both inputs have, none of them the burst or frame 120 of the current
    assert values['samples_used'] == str(FRAMES * FRAME - 3 * FRAME)
    assert status.level == DiagnosticStatus.WARN and 'lost' in status.message
    end = warnings(capfd.readouterr().err)
    assert len(end) == 1 and 'at the end of the run' in end[0]
    assert f'{FRAMES * FRAME - 3 * FRAME} of {199 * FRAME} {SUMMARY}' in end[0]
    assert 'current: 30 lost, 10 skipped' in end[0] and 'voltage: 20 lost, 10 skipped' in end[0]
    identifier.stop(None)                                               # unchanged since: no line at shutdown
    assert warnings(capfd.readouterr().err) == []


def test_a_clean_run_is_ok_and_says_nothing(node, capfd):
    identifier = node(model='arx')
    feed(identifier, signals(('voltage', 'current')))
    done(identifier)
    status, values = identifier.diagnostics.last()
    assert status.level == DiagnosticStatus.OK
    assert values['samples_received'] == values['samples_used'] == str(FRAMES * FRAME)
    assert values['samples_lost'] == values['samples_skipped'] == '0'
    identifier.stop(None)
    assert warnings(capfd.readouterr().err) == []


def test_grey_box_losses_without_an_end_are_told_at_shutdown(node, capfd):
    identifier = node(model='full')
    data = signals(('voltage', 'current', 'position'))
    feed(identifier, data, lose={(30, 'position')}, repeat={(60, 'current'), (61, 'current')})
    first = warnings(capfd.readouterr().err)
    assert len(first) == 1                    # the repeated frames after the lost one add no line
    identifier.measured.finish(FRAMES * FRAME * STEP)                      # the samples queued up to the end
    identifier.stop(None)
    last = warnings(capfd.readouterr().err)
    assert len(last) == 1 and 'at shutdown' in last[0]
    assert f'{FRAMES * FRAME - FRAME} of {FRAMES * FRAME + 2 * FRAME} {SUMMARY}; {FRAME} lost' in last[0]
    assert f'{2 * FRAME} skipped' in last[0]
    assert identifier.counts.totals() == {'samples_received': FRAMES * FRAME + 2 * FRAME,
                                          'samples_used': FRAMES * FRAME - FRAME,
                                          'samples_lost': FRAME, 'samples_skipped': 2 * FRAME}


@pytest.mark.parametrize('stamps, lost, skipped', [
    ([0, 1, 2, 3], 0, 0),
    ([0, 1, 3], 1, 0),            # a step of 2 periods: one sample missing
    ([0, 1, 5], 3, 0),
    ([0, 1, 1, 2], 0, 1),         # a duplicate
    ([0, 2, 1, 3], 1, 1),         # out of order: missing when its successor came, skipped when it came late
])
def test_sample_counts_of_one_sample_frames(stamps, lost, skipped):
    counts = SampleCounts(['u'], STEP)
    for k in stamps:
        counts.frame('u', k * STEP + (STEP // 10 if k % 2 else 0), 1)   # stamps a tenth of a period off are no gap
    assert counts.totals() == {'samples_received': len(stamps), 'samples_used': 0, 'samples_lost': lost,
                               'samples_skipped': skipped}
