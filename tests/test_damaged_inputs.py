"""Damaged inputs: bags with a corrupt MCAP chunk, bags without metadata.yaml, invalid params files, and the
shared memory of a node killed in a launch. Each gives a warning and the rest of the data, or one clear line;
never a traceback."""
import functools
import json
import logging
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, IndexType, Writer
from ros_isolation import VENV_BIN, isolated_env, processes
from test_launch import children, shm_in_use

from emla_core.bag import iter_chunks, read_bag, typestore, write_recording, writer
from emla_core.bag.reader import iter_serialized
from emla_core.errors import InputError
from emla_sim.datasets import closed_loop

pytestmark = pytest.mark.timeout(300)
EMLA = str(VENV_BIN / 'emla')
CHUNK_SIZE = 32 * 1024      # bytes of records per MCAP chunk: 8 chunks of 0.12 s for 1 s of three signals
FIRST, MIDDLE, LAST = 0, 3, -1


@pytest.fixture(scope='module')
def intact(tmp_path_factory):
    """1 s of closed-loop data as a bag of several chunks, frames interleaved in time (as a launch records)."""
    path = tmp_path_factory.mktemp('bags') / 'intact'
    recording, _ = closed_loop(duration=1.0, seed=7)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writer, 'BagWriter', functools.partial(writer.BagWriter, chunk_size=CHUNK_SIZE))
        write_recording(recording, path)
    return path


def damaged(intact, folder, which):
    """A copy of `intact` with 4 KiB of random bytes over the middle of chunk `which` (in file order), and how
    the readers name that chunk."""
    bag = folder / f'damaged{which}'
    shutil.copytree(intact, bag)
    file = next(bag.glob('*.mcap'))
    with file.open('rb') as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) > MIDDLE + 1
    chunk = chunks[which]
    assert chunk.chunk_length > 3 * 4096
    with file.open('r+b') as f:
        f.seek(chunk.chunk_start_offset + chunk.chunk_length // 2 - 2048)
        f.write(np.random.default_rng(len(chunks) + which).bytes(4096))
    return bag, (f'corrupt chunk {chunks.index(chunk) + 1} of {len(chunks)} of {file} (messages from t = '
                 f'{chunk.message_start_time * 1e-9:.6f} to {chunk.message_end_time * 1e-9:.6f} s)')


def emla(*args, env=None):
    return subprocess.run([EMLA, *map(str, args)], capture_output=True, text=True, timeout=120, env=env)


def test_a_corrupt_chunk_inside_the_record_leaves_a_gap_its_cost_names(intact, tmp_path, caplog):
    """The chunk's messages are missing from every signal: the record is in segments (Recording.gaps), the same
    from both readers, and the warning of the data the chunk cost names the gap."""
    bag, chunk = damaged(intact, tmp_path, MIDDLE)
    whole = read_bag(intact).recording
    with caplog.at_level(logging.WARNING, logger='emla_core.bag.reader'):
        recording = read_bag(bag).recording
        warned = [r.getMessage() for r in caplog.records]
        caplog.clear()
        parts = list(iter_chunks(bag, chunk_samples=1000))
    assert [r.getMessage() for r in caplog.records] == warned
    assert len(warned) == 2 and warned[0].startswith(f'warning: skipped the {chunk}: ')
    assert 'the skipped chunks cost measured data: a gap from t = ' in warned[1] and '\n' not in warned[1]
    ((sample, missing),) = recording.gaps
    assert len(recording) + missing == len(whole) and recording.start_time == whole.start_time
    time = whole.time
    np.testing.assert_allclose(recording.time, np.r_[time[:sample], time[sample + missing:]], rtol=1e-12)
    for name, values in recording.signals.items():
        np.testing.assert_array_equal(values, np.r_[whole.signals[name][:sample],
                                                    whole.signals[name][sample + missing:]])
        np.testing.assert_array_equal(np.concatenate([p.signals[name] for p in parts]), values)


def test_a_corrupt_chunk_of_a_file_without_chunk_index_refuses_it(intact, tmp_path):
    path = tmp_path / 'unindexed.mcap'
    with path.open('wb') as f:
        out = Writer(f, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD, index_types=IndexType.NONE)
        out.start(profile='ros2', library='test')
        channels = {}
        for topic, msgtype, stamp, data in iter_serialized(intact):
            if topic not in channels:
                msgdef, _ = typestore().generate_msgdef(msgtype, ros_version=2)
                schema = out.register_schema(name=msgtype, encoding='ros2msg', data=msgdef.encode())
                channels[topic] = out.register_channel(topic=topic, message_encoding='cdr', schema_id=schema)
            out.add_message(channels[topic], log_time=stamp, publish_time=stamp, data=data)
        out.finish()
    assert len(read_bag(path).recording) == len(read_bag(intact).recording)
    data = bytearray(path.read_bytes())
    data[len(data) // 2:len(data) // 2 + 4096] = np.random.default_rng(1).bytes(4096)
    path.write_bytes(data)
    for read in (read_bag, lambda p: list(iter_chunks(p))):
        with pytest.raises(InputError, match=f'^{path}: unreadable MCAP: [^\n]+$'):
            read(path)


@pytest.mark.parametrize('which', [FIRST, LAST], ids=['first', 'last'])
def test_a_corrupt_chunk_at_an_end_is_skipped_with_a_warning(intact, tmp_path, caplog, which):
    bag, chunk = damaged(intact, tmp_path, which)
    whole = read_bag(intact).recording
    with caplog.at_level(logging.WARNING, logger='emla_core.bag.reader'):
        recording = read_bag(bag).recording
        warned = [r.getMessage() for r in caplog.records]
        caplog.clear()
        parts = list(iter_chunks(bag, chunk_samples=1000))
    assert [r.getMessage() for r in caplog.records] == warned
    assert len(warned) == 1 and warned[0].startswith(f'warning: skipped the {chunk}: ')
    assert 0.8 * len(whole) < len(recording) < len(whole)           # the rest of the record
    offset = round((recording.start_time - whole.start_time) / whole.sample_period)
    assert (offset > 0) == (which == FIRST)
    assert parts[0].start_time == recording.start_time
    for name, values in recording.signals.items():
        np.testing.assert_array_equal(values, whole.signals[name][offset:offset + len(values)])
        np.testing.assert_array_equal(np.concatenate([p.signals[name] for p in parts]), values)


@pytest.mark.parametrize('command', ['identify', 'discrepancy'])
def test_commands_on_a_bag_with_a_corrupt_chunk(intact, tmp_path, command):
    bag, chunk = damaged(intact, tmp_path, LAST)
    out = emla(command, bag, '--json', tmp_path / 'out.json')
    assert out.returncode == 0, out.stderr
    (line,) = out.stderr.strip().splitlines()
    assert line.startswith(f'warning: skipped the {chunk}: ')
    bag, chunk = damaged(intact, tmp_path, MIDDLE)   # a gap: the grey-box identification takes the segments
    out = emla(command, bag)
    skipped, cost, *error = out.stderr.strip().splitlines()
    assert skipped.startswith(f'warning: skipped the {chunk}: ') and 'a gap from t = ' in cost
    if command == 'identify':
        assert out.returncode == 0 and not error and len(json.loads(out.stdout)['gaps']) == 1
    else:
        assert out.returncode == 2 and out.stdout == '' and len(error) == 1
        assert error[0].startswith(f'emla {command}: error: {bag}: 1 gap(s) (missing samples)')
        assert '--start' in error[0]


@pytest.mark.parametrize('command', ['identify', 'discrepancy', 'play'])
@pytest.mark.parametrize('content', ['nothing', 'an mcap file'])
def test_a_directory_without_metadata_is_one_clear_line(intact, tmp_path, command, content):
    folder = tmp_path / 'folder'
    folder.mkdir()
    if content != 'nothing':
        shutil.copy(next(intact.glob('*.mcap')), folder)
    out = emla(command, folder, env=isolated_env())
    assert out.returncode == 2
    assert out.stderr.strip() == f'emla {command}: error: {folder}: not a rosbag2 directory (no metadata.yaml)'


@pytest.mark.parametrize('which', [MIDDLE, LAST], ids=['middle', 'last'])
def test_play_skips_a_corrupt_chunk_with_a_warning(intact, tmp_path, which):
    bag, chunk = damaged(intact, tmp_path, which)
    with processes() as start:
        play = start([EMLA, 'play', str(bag), '--rate', '0', '--wait', '0'])
        _, err = play.communicate(timeout=120)
    assert play.returncode == 0 and 'Traceback' not in err, err
    (warning,) = [line for line in err.splitlines() if line.startswith('warning: ')]
    assert warning.startswith(f'warning: skipped the {chunk}: ')
    played = int(err.split('emla play: ')[-1].split()[0])
    assert 0 < played < 3 * 100                                     # 100 frames of each signal, less a chunk's


@pytest.mark.parametrize('text, problem', [
    ('{not yaml', "not YAML: expected ',' or '}', but got '<stream end>' (line 1, column 10)"),
    ('- plant\n- sensor\n', 'not a ROS 2 params file'),
    ('/emla/identifier:\n  sample_period: 1.0e-4\n', 'Cannot have a value before ros__parameters at line 2'),
])
def test_an_invalid_params_file_is_one_clear_line(tmp_path, text, problem):
    params = tmp_path / 'bad.yaml'
    params.write_text(text)
    out = emla('run', 'identifier', '--params-file', params, env=isolated_env())
    assert out.returncode == 2 and out.stdout == ''
    (line,) = out.stderr.strip().splitlines()
    assert line.startswith(f'emla run: error: {params}: ') and problem in line


def shm_names(pid):
    """Names of the files in /dev/shm that process `pid` has open or mapped."""
    names = set()
    for fd in Path(f'/proc/{pid}/fd').iterdir():
        try:
            names.add(os.readlink(fd))
        except OSError:
            continue
    names.update(line.split(maxsplit=5)[-1] for line in Path(f'/proc/{pid}/maps').read_text().splitlines())
    return {Path(name).name for name in names if name.startswith('/dev/shm/')}


def test_a_launch_removes_the_shared_memory_of_a_killed_node(tmp_path):
    bag = tmp_path / 'bag'
    with processes() as start:
        launch = start([EMLA, 'launch', '--duration', '60', '--bag', str(bag)])
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob('.bag.emla-partial/bag/*.mcap')):  # frames: every node runs
            if launch.poll() is not None or time.monotonic() > deadline:
                launch.kill()
                pytest.fail(f'the launch ended or stalled before the run began: {launch.communicate()[1]}')
            time.sleep(0.1)
        time.sleep(1.0)                                     # the launcher looks at their files every 0.25 s
        pids = children(launch.pid)
        used = set().union(*(shm_names(pid) for pid in pids))
        sensor = next((pid for pid, args in pids.items() if args[2:4] == ['run', 'sensor']), None)
        assert sensor, f'no sensor among the launch\'s processes: {pids}'
        # a port file another test's nodes share (tests run side by side) is rightly kept while they use it, and
        # Fast DDS keeps port files when they end: those are not the launch's to remove
        shared = shm_in_use(exclude=set(pids) | {launch.pid})
        os.kill(sensor, signal.SIGKILL)
        _, err = launch.communicate(timeout=60)
        left = {name for name in used if name.startswith('fastrtps_') and (Path('/dev/shm') / name).exists()}
        left -= shm_in_use() | shared                       # before processes() runs `fastdds shm clean`
    assert launch.returncode == 1 and f'sensor (pid {sensor}) was killed by SIGKILL' in err
    assert any(name.startswith('fastrtps_port') for name in used) and not left
