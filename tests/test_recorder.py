"""The recorder node: everything recorded at 1 ms frames, custom data, a clean stop and a SIGKILL mid-run."""
import signal
import sys
import time

import numpy as np
import pytest
import yaml
from ros_isolation import VENV_BIN, processes
from rosbags.highlevel import AnyReader

from emla_core.bag import read_bag, typestore

pytestmark = pytest.mark.timeout(120)

# Publishes `frames` 1 ms frames of 10 samples (value k in frame k) on four frame topics at real-time pace,
# and the true parameters once, with the graph's QoS. Like the plant, it starts once /emla/position has a
# subscriber: the recorder (hold_start) subscribes to it once it matched a publisher of every other topic.
PUBLISHER = r'''
import sys, time
import rclpy
from emla_core import messages, topics
from emla_core.messages import message_class
from emla_core.nodes.qos import qos_profile
from emla_core.topics import RECORDED
frames = int(sys.argv[1])
rclpy.init()
node = rclpy.create_node('test_publisher')
every = {topic: node.create_publisher(message_class(msgtype), topic, qos_profile(kind))
         for topic, (msgtype, kind) in RECORDED.items()}
frame_topics = ('/emla/plant/current', '/emla/voltage', '/emla/current', '/emla/position')
publishers = {topic: every[topic] for topic in frame_topics}
truth = every[topics.TRUE_PARAMETERS_TOPIC]
while not every[topics.START_TOPIC].get_subscription_count():
    time.sleep(0.01)
truth.publish(messages.estimate_message(0, {'resistance': 4.5, 'mass': 0.036}))
print('publishing', flush=True)
start = time.monotonic()
for k in range(frames):
    for publisher in publishers.values():
        publisher.publish(messages.frame_message(k * 1_000_000, 1e-4, [float(k)] * 10))
    time.sleep(max(0.0, start + (k + 1) * 1e-3 - time.monotonic()))
for p in publishers.values():
    p.wait_for_all_acked(rclpy.duration.Duration(seconds=10))
print('published', flush=True)
'''


def start_recorder(start, tmp_path, bag, env):
    params = tmp_path / 'recorder.yaml'
    params.write_text(yaml.safe_dump({'/emla/recorder': {'ros__parameters': {
        'bag': str(bag), 'scenario': 'test', 'split_size': 32 * 1024, 'hold_start': True}}}))
    return start([str(VENV_BIN / 'emla'), 'run', 'recorder', '--params-file', str(params)], env=env)


def frame_values(bag, topic):
    """The first sample of each frame of `topic`, read with rosbags."""
    with AnyReader([bag], default_typestore=typestore()) as reader:
        return np.array([reader.deserialize(raw, c.msgtype).data[0]
                         for c, _, raw in reader.messages([c for c in reader.connections if c.topic == topic])])


def test_clean_stop_keeps_every_frame_and_the_true_parameters(tmp_path, ros_env):
    bag = tmp_path / 'bag'
    with processes() as start:
        recorder = start_recorder(start, tmp_path, bag, ros_env)
        publisher = start([sys.executable, '-c', PUBLISHER, '1500'], env=ros_env)
        assert publisher.wait(timeout=60) == 0, publisher.stderr.read()
        recorder.send_signal(signal.SIGINT)
        assert recorder.wait(timeout=20) == 0, recorder.stderr.read()
    contents = read_bag(bag)
    for name in ('plant/current', 'voltage', 'current', 'position'):
        np.testing.assert_array_equal(contents.recording.signals[name], np.repeat(np.arange(1500.0), 10))
    assert contents.metadata['scenario'] == 'test'
    assert float(contents.metadata['true_resistance']) == 4.5
    assert contents.truth[0][1] == {'resistance': 4.5, 'mass': 0.036}
    assert len(list(bag.glob('*.mcap'))) > 3          # split as it went
    np.testing.assert_array_equal(frame_values(bag, '/emla/current'), np.arange(1500.0))


def test_sigkill_leaves_a_readable_bag(tmp_path, ros_env):
    bag = tmp_path / 'bag'
    with processes() as start:
        recorder = start_recorder(start, tmp_path, bag, ros_env)
        publisher = start([sys.executable, '-c', PUBLISHER, '5000'], env=ros_env)
        assert publisher.stdout.readline().strip() == 'publishing'
        time.sleep(1.5)
        recorder.send_signal(signal.SIGKILL)
        recorder.wait(timeout=10)
    values = frame_values(bag, '/emla/current')
    assert len(values) >= 500           # most of the 1.5 s before the kill
    np.testing.assert_array_equal(values, np.arange(len(values)))      # from the start, nothing missing
    current = read_bag(bag).recording.signals['current']
    np.testing.assert_array_equal(current.reshape(-1, 10)[:, 0], np.arange(len(current) // 10))
