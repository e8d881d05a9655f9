"""The identifier node on a real drive's topics of standard message types (its input_topics): the final estimate
equals the offline identification of the same samples; bad messages are survived and counted; an input topic
of a type it cannot read ends it with one line. Every node refuses a parameter of the wrong type with one line, the
identifier bad ARX settings too."""
import signal
import subprocess

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile
from ros_isolation import isolated_env, processes
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from test_node_faults import DITHER, input_faults
from test_nodes import EMLA, MS, params_file, ros_node, spin_until

from emla_core import messages, topics
from emla_identification.greybox import identify
from emla_msgs.msg import ParameterEstimate, SampleFrame
from emla_sim.datasets import closed_loop

pytestmark = pytest.mark.timeout(180)

TS, STEP = 1e-4, MS // 10  # s, ns
SAMPLES = 5000  # 0.5 s
FRAME = 10  # voltage samples per SampleFrame
BLOCK = 100  # samples per publish period (10 ms): the test stays WINDOW of them ahead of the estimates
WINDOW = 4
ORIGIN = 1_000_000 * MS  # ns: the drive's clock at the first sample (a multiple of the publish period)
INPUTS = ['voltage=/drive/voltage', 'current=/drive/joint_states:effort[coil]',
          'position=/drive/joint_states:position[slider]']


@pytest.fixture(scope='module')
def signals():
    recording, _ = closed_loop(duration=SAMPLES * TS, dither=DITHER)
    return recording.signals


def drive_messages(signals, count, jitter=0.4):
    """[(topic, message)] of a drive: the voltage in SampleFrames of FRAME samples on /drive/voltage; the
    current (effort of joint coil) and the position (of joint slider) one sample per JointState on
    /drive/joint_states; each stamped up to `jitter` sample periods off its instant (rounded away by the node)."""
    offsets = np.random.default_rng(3).uniform(-jitter, jitter, count) * STEP
    out = []
    for k in range(count):
        stamp = ORIGIN + k * STEP + int(offsets[k])
        if k % FRAME == 0:
            out.append(('/drive/voltage', messages.frame_message(stamp, TS, signals['voltage'][k:k + FRAME])))
        state = JointState(name=['coil', 'slider'], position=[0.0, float(signals['position'][k])],
                           effort=[float(signals['current'][k]), 0.0])
        state.header.stamp = messages.time_msg(stamp)
        out.append(('/drive/joint_states', state))
    return out


def run_on_topics(tmp_path, drive, end, faults=None):
    """Run the identifier with INPUTS on the (topic, message) list `drive`, published in order at most WINDOW
    publish periods ahead of its estimates, until its estimate stamped `end` (and its input `faults` {kind: count}
    on /diagnostics, if given); (estimates, stderr). It must exit 0 on SIGTERM."""
    estimates, diagnostics = [], []
    with ros_node() as (node, executor), processes() as start:
        publishers = {topic: node.create_publisher(msgtype, topic, QoSProfile(depth=1000)) for topic, msgtype in
                      (('/drive/voltage', SampleFrame), ('/drive/joint_states', JointState))}
        node.create_subscription(ParameterEstimate, topics.PARAMETERS_TOPIC, estimates.append, 1000)
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS_TOPIC, diagnostics.append, 1000)
        proc = start([EMLA, 'run', 'identifier', '--params-file',
                      params_file(tmp_path, 'identifier', input_topics=INPUTS)])
        spin_until(executor, lambda: all(p.get_subscription_count() for p in publishers.values()), 60, [proc])

        def covered():
            return topics.stamp_to_ns(estimates[-1].header.stamp) if estimates else ORIGIN

        for topic, msg in drive:
            ahead = topics.stamp_to_ns(msg.header.stamp) - WINDOW * BLOCK * STEP
            spin_until(executor, lambda ahead=ahead: covered() >= ahead, 60, [proc])
            publishers[topic].publish(msg)
        spin_until(executor, lambda: covered() == end, 60, [proc])
        if faults:
            spin_until(executor, lambda: input_faults({topics.DIAGNOSTICS_TOPIC: diagnostics}, 'identifier') == faults,
                       10, [proc])
        assert proc.poll() is None, 'the identifier ended'
        proc.send_signal(signal.SIGTERM)
        code, err = proc.wait(timeout=20), proc.stderr.read()
    assert code == 0 and 'Traceback' not in err, err
    return estimates, err


def test_the_identifier_on_standard_topics_ends_where_offline_identification_does(tmp_path, signals):
    estimates, err = run_on_topics(tmp_path, drive_messages(signals, SAMPLES), ORIGIN + SAMPLES * STEP)
    assert err.startswith('identifier: ready (') and 'subscribing to /drive/voltage, /drive/joint_states' in err
    assert 'input faults' not in err
    final = estimates[-1]
    offline = identify(voltage=signals['voltage'], current=signals['current'], position=signals['position'],
                       sample_period=TS, model='full')
    assert final.samples_used == offline.samples == SAMPLES
    for name, value in offline.parameters.items():
        assert getattr(final, name) == pytest.approx(value, rel=1e-6), name
    # an estimate at every publish period of the drive's time line
    assert [topics.stamp_to_ns(e.header.stamp) for e in estimates] == \
        [ORIGIN + k * BLOCK * STEP for k in range(1, SAMPLES // BLOCK + 1)]


def test_the_identifier_survives_bad_messages_on_standard_topics(tmp_path, signals):
    count = 1000
    drive = drive_messages(signals, count)
    states = [i for i, (topic, _) in enumerate(drive) if topic == '/drive/joint_states']
    drive[states[300]][1].name = ['coil', 'arm']  # no joint slider: unreadable position, then it misses one
    drive.insert(states[600] + 1, drive[states[600]])  # a JointState twice: both its instants passed already
    estimates, err = run_on_topics(tmp_path, drive, ORIGIN + count * STEP,
                                   faults={'unreadable': 1, 'missing': 1, 'stamp_back': 2})
    assert 'input faults so far' in err
    assert estimates[-1].samples_used == count - 1


def test_an_input_topic_of_another_type_ends_the_identifier_with_one_line(tmp_path):
    with ros_node() as (node, _), processes() as start:
        node.create_publisher(String, '/drive/voltage', 10)
        proc = start([EMLA, 'run', 'identifier', '--params-file',
                      params_file(tmp_path, 'identifier', input_topics=INPUTS)])
        code, err = proc.wait(timeout=60), proc.stderr.read()
    lines = err.splitlines()
    assert code == 2 and lines[0].startswith('identifier: ready (') and len(lines) == 2, err
    assert lines[1].startswith('identifier: error: /drive/voltage is std_msgs/msg/String; an input topic is one of')


@pytest.mark.parametrize('node, name, value', [
    ('identifier', 'sample_period', []), ('identifier', 'sample_period', 'fast'), ('identifier', 'model', []),
    ('identifier', 'orders', 'fast'),
    ('plant', 'duration', []), ('sensor', 'seed', []), ('controller', 'bandwidth', []),
])
def test_a_parameter_of_the_wrong_type_ends_the_node_with_one_line(tmp_path, node, name, value):
    result = subprocess.run([EMLA, 'run', node, '--params-file', params_file(tmp_path, node, **{name: value})],
                            capture_output=True, text=True, timeout=60, env=isolated_env())
    assert result.returncode == 2 and result.stderr.count('\n') == 1, result.stderr
    assert result.stderr.startswith(f'{node}: error: ') and repr(name) in result.stderr


@pytest.mark.parametrize('arx, message', [
    ({'orders': [4, 3]}, 'orders [4, 3]: need three integers'), ({'orders': [0, 0, 1]}, 'cannot both be zero'),
    ({'input': 'force'}, "input 'force' is not one of"), ({'output': 'voltage'}, 'input and output are both voltage'),
    ({'input_topics': INPUTS}, 'input_topics maps voltage, current, position; map voltage, current'),
])
def test_bad_arx_settings_end_the_identifier_with_one_line(tmp_path, arx, message):
    result = subprocess.run([EMLA, 'run', 'identifier', '--params-file', params_file(tmp_path, 'identifier',
                                                                                    model='arx', **arx)],
                            capture_output=True, text=True, timeout=60, env=isolated_env())
    assert result.returncode == 2 and result.stderr.count('\n') == 1, result.stderr
    assert result.stderr.startswith('identifier: error: ') and message in result.stderr


@pytest.mark.parametrize('settings, message', [
    ({'effects': ['sensor_delay']}, 'cannot estimate online: sensor_delay'),
    ({'effects': ['resistance_drift']}, 'resistance_drift is followed online by forgetting'),
    ({'model_file': '/nonexistent/model.yaml'}, '/nonexistent/model.yaml'),
])
def test_effects_that_cannot_run_online_end_the_identifier_with_one_line(tmp_path, settings, message):
    result = subprocess.run([EMLA, 'run', 'identifier', '--params-file', params_file(tmp_path, 'identifier',
                                                                                    **settings)],
                            capture_output=True, text=True, timeout=60, env=isolated_env())
    assert result.returncode == 2 and result.stderr.count('\n') == 1, result.stderr
    assert result.stderr.startswith('identifier: error: ') and message in result.stderr
