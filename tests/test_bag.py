"""Bags: round trip, peer readers (rosbags, mcap-ros2-support), and a writer killed mid-recording."""
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages
from rosbags.highlevel import AnyReader

from emla_core.bag import BagWriter, read_bag, typestore, write_recording
from emla_core.errors import InputError
from emla_core.recording import Recording


def recording(n=5000, period=1e-4):
    k = np.arange(n)
    return Recording(period, {'voltage': np.sin(0.01 * k), 'current': np.cos(0.013 * k), 'position': 1e-6 * k},
                     start_time=2.0)


def test_round_trip_and_peer_readers(tmp_path):
    rec = recording()
    bag = tmp_path / 'run'
    write_recording(rec, bag, frame_size=128, estimates=[(2.1, {'resistance': 4.0, 'mass': 0.036})],
                    custom_data={'scenario': 'test'})
    back = read_bag(bag)
    for name, values in rec.signals.items():
        np.testing.assert_array_equal(back.recording.signals[name], values)
    assert back.recording.sample_period == rec.sample_period
    assert back.recording.start_time == pytest.approx(2.0)
    assert back.estimates[0][1] == {'resistance': 4.0, 'mass': 0.036}
    assert back.metadata == {'scenario': 'test'}

    with AnyReader([bag], default_typestore=typestore()) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        current = np.concatenate([reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()
                                  if c.topic == '/emla/current'])
    assert counts['/emla/voltage'] == int(np.ceil(5000 / 128)) and counts['/emla/parameters'] == 1
    np.testing.assert_array_equal(current, rec.signals['current'])

    peer = [m.ros_msg for f in sorted(bag.glob('*.mcap')) for m in read_ros2_messages(str(f))
            if m.channel.topic == '/emla/position']
    np.testing.assert_array_equal(np.concatenate([np.asarray(m.data) for m in peer]), rec.signals['position'])


KILLED_WRITER = r'''
import sys, time
import numpy as np
from emla_core.bag import BagWriter
from emla_core.messages import frame_message
from emla_core.topics import SAMPLE_FRAME
with BagWriter(sys.argv[1], split_size=20000) as bag:
    bag.add_topic('/emla/current', SAMPLE_FRAME)
    for k in range(10**6):
        stamp = k * 10_000_000
        bag.write_message('/emla/current', stamp, frame_message(stamp, 1e-4, np.full(100, float(k))))
        if k == 200:
            print('ready', flush=True)
        time.sleep(0.0005)
'''


def test_writer_killed_mid_recording_leaves_a_readable_bag(tmp_path):
    bag = tmp_path / 'killed'
    proc = subprocess.Popen([sys.executable, '-c', KILLED_WRITER, str(bag)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == 'ready'
        time.sleep(0.3)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    back = read_bag(bag).recording.signals['current']
    frames = back.reshape(-1, 100)[:, 0]
    assert len(frames) >= 200
    np.testing.assert_array_equal(frames, np.arange(len(frames)))   # contiguous from the start, nothing lost
    with AnyReader([bag], default_typestore=typestore()) as reader:
        assert sum(c.msgcount for c in reader.connections) == len(frames)


def test_writer_refuses_a_non_empty_directory(tmp_path):
    (tmp_path / 'x').write_text('keep me')
    with pytest.raises(InputError, match='not empty'):
        BagWriter(tmp_path)


@pytest.mark.parametrize('make, problem', [
    (lambda p: None, 'no such file'),
    (lambda p: p.mkdir(), 'no metadata.yaml'),
    (lambda p: (p.mkdir(), (p / 'metadata.yaml').write_text('{not yaml')), 'unreadable metadata'),
])
def test_unreadable_bags_are_clear_errors(tmp_path, make, problem):
    path = tmp_path / 'bag'
    make(path)
    with pytest.raises(InputError, match=problem):
        read_bag(path)


def test_truncated_mcap_is_a_clear_error(tmp_path):
    write_recording(recording(), tmp_path / 'ok')
    data = next((tmp_path / 'ok').glob('*.mcap')).read_bytes()
    broken = tmp_path / 'broken.mcap'
    broken.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match='unreadable MCAP'):
        read_bag(broken)
