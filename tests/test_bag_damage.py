"""Damaged and hostile bags: metadata.yaml of any content, files named outside the bag, MCAP and sqlite3 files that
are not what they claim, malformed records and messages, corrupt chunks that held some signals only. Each is one
line on stderr naming the file and the problem (exit 2), or a warning naming the data lost; never a traceback, and
never the bytes of a file."""
import functools
import json
import logging
import os
import shutil

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.records import ChunkIndex
from mcap.writer import CompressionType

from emla_cli.cli import main
from emla_core.bag import iter_chunks, read_bag, write_recording, writer
from emla_core.bag.chunks import _decode_frames
from emla_core.bag.reader import chunk_data
from emla_core.errors import InputError
from emla_core.messages import frame_message, serialize
from emla_core.topics import SAMPLE_FRAME
from emla_sim.datasets import closed_loop

FRAME = 500                  # samples per SampleFrame: 10 frames of each signal in 0.5 s
SECRET = b'SECRET-CONTENT of a file that is not the bag\'s\n'
COMMANDS = ('identify', 'discrepancy', 'compare', 'import', 'play')


@pytest.fixture(scope='module')
def intact(tmp_path_factory):
    """0.5 s of closed-loop data (5000 samples) as a bag with one message per MCAP chunk."""
    path = tmp_path_factory.mktemp('bags') / 'intact'
    recording, _ = closed_loop(duration=0.5, seed=3)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writer, 'BagWriter', functools.partial(writer.BagWriter, chunk_size=1))
        write_recording(recording, path, frame_size=FRAME)
    return path


def copy(intact, folder, name='bag'):
    bag = folder / name
    shutil.copytree(intact, bag)
    return bag


def mcap_file(bag):
    (file,) = bag.glob('*.mcap')
    return file


def chunks_of(file, topic):
    """The chunk indexes of `file` that hold messages of `topic`, in file order."""
    with file.open('rb') as f:
        summary = make_reader(f).get_summary()
    (channel,) = [c.id for c in summary.channels.values() if c.topic == topic]
    return sorted((c for c in summary.chunk_indexes if channel in c.message_index_offsets),
                  key=lambda c: c.chunk_start_offset)


def corrupt(file, chunk):
    """Random bytes over the middle of a chunk's compressed data."""
    with file.open('r+b') as f:
        f.seek(chunk.chunk_start_offset + chunk.chunk_length // 2 - 32)
        f.write(np.random.default_rng(chunk.chunk_start_offset).bytes(64))


def emla(capsys, *args):
    """(exit status, stdout, stderr) of `emla ARGS` run in this process."""
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def command_line(command, bag, folder):
    """`emla COMMAND` on `bag` (play without waiting; compare with a model file it never gets to)."""
    extra = {'import': [folder / 'imported'], 'compare': ['--model-file', folder / 'model.yaml'],
             'play': ['--wait', '0', '--rate', '0']}
    return [command, bag, *extra.get(command, [])]


def assert_one_line(capsys, command, bag, folder, expected):
    status, out, err = emla(capsys, *command_line(command, bag, folder))
    assert (status, out) == (2, '')
    assert err == f'emla {command}: error: {expected}\n'
    assert not (folder / 'imported').exists()


def metadata(bag, text):
    (bag / 'metadata.yaml').write_bytes(text if isinstance(text, bytes) else text.encode())


def edited(bag, old, new):
    text = (bag / 'metadata.yaml').read_text()
    assert old in text
    metadata(bag, text.replace(old, new, 1))


HOSTILE_METADATA = {
    'binary': (lambda bag: metadata(bag, b'rosbag2\xff\x00\x89'), 'not UTF-8 text (byte 7)'),
    'an integer': (lambda bag: metadata(bag, '7\n'), 'no rosbag2_bagfile_information mapping'),
    'a list': (lambda bag: metadata(bag, '- rosbag2_bagfile_information\n'), 'no rosbag2_bagfile_information mapping'),
    'information an integer': (lambda bag: metadata(bag, 'rosbag2_bagfile_information: 3\n'),
                               'no rosbag2_bagfile_information mapping'),
    'no storage': (lambda bag: metadata(bag, 'rosbag2_bagfile_information: {}\n'),
                   'storage_identifier is missing or not a name'),
    'files not a list': (lambda bag: edited(bag, 'relative_file_paths:\n  - intact_0.mcap', 'relative_file_paths: 5'),
                         'relative_file_paths is missing or not a list of file names'),
    'custom data a list': (lambda bag: edited(bag, 'custom_data:\n', 'custom_data: [1, 2]\n  former_custom_data:\n'),
                           'custom_data is not a mapping of names to plain values'),
    'topics without names': (lambda bag: edited(bag, 'name: /emla/voltage', 'nom: /emla/voltage'),
                             'topics_with_message_count is not a list of topics with a name and type'),
    'not YAML': (lambda bag: metadata(bag, 'rosbag2_bagfile_information: {storage: [\n'),
                 'not YAML: did not find expected node content (line 2, column 1)'),
    'deeply nested': (lambda bag: metadata(bag, '[' * 100_000 + ']' * 100_000),
                      'nested more than 16 levels deep'),
}


@pytest.mark.parametrize('command', COMMANDS)
@pytest.mark.parametrize('case', HOSTILE_METADATA)
def test_hostile_metadata_is_one_line(intact, tmp_path, capsys, command, case):
    bag = copy(intact, tmp_path)
    make, problem = HOSTILE_METADATA[case]
    make(bag)
    assert_one_line(capsys, command, bag, tmp_path, f'{bag}/metadata.yaml: unreadable metadata: {problem}')


def test_huge_metadata_is_refused_unread(intact, tmp_path, capsys):
    bag = copy(intact, tmp_path)
    with (bag / 'metadata.yaml').open('r+b') as f:
        f.truncate(9 << 20)     # sparse: refused by its size, never parsed
    assert_one_line(capsys, 'identify', bag, tmp_path, f'{bag}/metadata.yaml: 9.0 MiB is more than the 8 MiB a bag '
                                                       f'metadata file may have')


@pytest.mark.parametrize('command', COMMANDS)
@pytest.mark.parametrize('name', ['outside', '../outside', 'sub/../../outside', 'absolute'])
def test_files_named_outside_the_bag_are_refused_unopened(intact, tmp_path, capsys, command, name):
    outside = tmp_path / 'outside'
    outside.write_bytes(SECRET)
    bag = copy(intact, tmp_path / 'in')
    name = str(outside) if name == 'absolute' else name
    edited(bag, '- intact_0.mcap', f'- {name}')
    expected = (f'{bag}/outside: no such file' if name == 'outside'   # (a name is quoted to its first 80 characters)
                else f"{bag}/metadata.yaml: relative_file_paths names {name[:80]!r}, outside the bag directory")
    assert_one_line(capsys, command, bag, tmp_path, expected)


@pytest.mark.parametrize('command', ['identify', 'import', 'play'])
def test_a_fifo_or_device_in_a_bag_is_refused_unread(intact, tmp_path, capsys, command):
    bag = copy(intact, tmp_path)
    file = mcap_file(bag)
    file.unlink()
    file.symlink_to('/dev/zero')
    assert_one_line(capsys, command, bag, tmp_path,
                    f'{file}: is a device; the suite reads a bag file only from a regular file')
    (bag / 'metadata.yaml').unlink()
    os.mkfifo(bag / 'metadata.yaml')
    assert_one_line(capsys, command, bag, tmp_path,
                    f'{bag}/metadata.yaml: is a FIFO; the suite reads a bag metadata file only from a regular file')


@pytest.mark.parametrize('command', COMMANDS)
def test_damaged_files_of_a_bag_are_one_line(intact, tmp_path, capsys, command):
    bag = copy(intact, tmp_path)
    file = mcap_file(bag)
    data = file.read_bytes()
    file.write_bytes(data[:len(data) // 2])
    assert_one_line(capsys, command, bag, tmp_path,
                    f'{file}: unreadable MCAP: cut short (no MCAP magic at its end: its writer did not finish it)')
    file.write_bytes(SECRET * 4)
    assert_one_line(capsys, command, bag, tmp_path,
                    f'{file}: unreadable MCAP: not an MCAP file (it does not begin with the MCAP magic)')
    file.unlink()
    assert_one_line(capsys, command, bag, tmp_path, f'{file}: no such file')
    empty = tmp_path / 'empty'
    empty.mkdir(exist_ok=True)
    assert_one_line(capsys, command, empty, tmp_path, f'{empty}: not a rosbag2 directory (no metadata.yaml)')


@pytest.mark.parametrize('command', COMMANDS)
def test_a_sqlite3_bag_whose_database_is_not_sqlite_is_one_line(intact, tmp_path, capsys, command):
    bag = copy(intact, tmp_path)
    edited(bag, 'storage_identifier: mcap', 'storage_identifier: sqlite3')
    edited(bag, '- intact_0.mcap', '- intact_0.db3')
    (bag / 'intact_0.db3').write_bytes(SECRET * 4)
    status, out, err = emla(capsys, *command_line(command, bag, tmp_path))
    assert (status, out, err.count('\n')) == (2, '', 1)
    assert err.startswith(f'emla {command}: error: {bag}') and 'file is not a database' in err
    assert b'SECRET' not in err.encode()


def test_a_channel_name_that_is_not_utf8_is_one_line(intact, tmp_path, capsys):
    bag = copy(intact, tmp_path)
    file = mcap_file(bag)
    file.write_bytes(file.read_bytes().replace(b'/emla/voltage', b'/emla/\xffoltage'))
    status, out, err = emla(capsys, 'identify', bag)
    assert (status, out) == (2, '')
    assert err.startswith(f'emla identify: error: {file}: unreadable MCAP: ') and err.count('\n') == 1


@pytest.fixture(scope='module')
def truncated_frame(tmp_path_factory):
    """A bag whose last voltage frame is cut short (its CDR ends inside the data)."""
    path = tmp_path_factory.mktemp('bags') / 'truncated'
    with writer.BagWriter(path) as bag:
        for name in ('voltage', 'current', 'position'):
            bag.add_topic(f'/emla/{name}', SAMPLE_FRAME)
        for k in range(4):
            for name in ('voltage', 'current', 'position'):
                data = bytes(serialize(frame_message(k * 10_000_000, 1e-4, np.full(100, float(k)))))
                bag.write(f'/emla/{name}', k * 10_000_000, data[:-20] if (k, name) == (3, 'voltage') else data)
    return path


def test_a_message_cut_short_is_one_line(truncated_frame, capsys):
    with pytest.raises(InputError, match=r'^\S+truncated: unreadable emla_msgs/msg/SampleFrame on /emla/voltage '
                                         r'\(logged at 0\.030000 s\): [^\n]+$'):
        read_bag(truncated_frame)
    with pytest.raises(InputError, match=r'unreadable MCAP: malformed record or SampleFrame in the chunks before '
                                         r'byte \d+$'):
        list(iter_chunks(truncated_frame))
    for command, problem in (('identify', 'unreadable MCAP: malformed record'), ('import', 'unreadable emla_msgs')):
        status, out, err = emla(capsys, *command_line(command, truncated_frame, truncated_frame.parent))
        assert (status, out) == (2, '') and err.count('\n') == 1 and problem in err


def test_a_chunk_index_pointing_outside_the_file_skips_the_chunk(intact):
    file = mcap_file(intact)
    size = file.stat().st_size
    hostile = [ChunkIndex(message_start_time=5, message_end_time=6, chunk_start_offset=8, chunk_length=length,
                          message_index_offsets={}, message_index_length=0, compression='zstd', compressed_size=10,
                          uncompressed_size=10) for length in (2**63, 0, size)]
    skipped = []
    with file.open('rb') as f:
        assert [chunk_data(f, file, hostile, k, skipped.append) for k in range(3)] == [None] * 3
    assert [c.problem for c in skipped] == [
        f'the chunk index gives it {length} bytes from byte 8, not within the file' for length in (2**63, 0, size)]


def test_compiled_decoding_refuses_a_record_longer_than_the_data():
    slots = np.full(2, -1, dtype=np.int64)
    for length in (2**63 - 1, 2**63 + 5, 2**64 - 1, 1000):
        record = bytes([0x05]) + length.to_bytes(8, 'little') + bytes(40)
        *_, bad = _decode_frames(np.frombuffer(record, np.uint8), slots, 1)
        assert bad == 0


# The LZ4 data of a chunk record start after its opcode, length, times, uncompressed size, CRC, 'lz4' and records length
LZ4_FRAME = 1 + 8 + 8 + 8 + 8 + 4 + (4 + 3) + 8


class Lz4Writer(writer.Writer):
    def __init__(self, stream, **options):
        super().__init__(stream, **{**options, 'compression': CompressionType.LZ4})


def test_a_corrupt_lz4_chunk_is_skipped_with_a_warning(tmp_path, caplog):
    recording, _ = closed_loop(duration=0.05, seed=1)
    bag = tmp_path / 'lz4'
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writer, 'BagWriter', functools.partial(writer.BagWriter, chunk_size=1))
        patch.setattr(writer, 'Writer', Lz4Writer)
        write_recording(recording, bag, frame_size=100)
    file = mcap_file(bag)
    last = chunks_of(file, '/emla/position')[-1]
    with file.open('r+b') as f:   # the LZ4 frame's descriptor: lz4 fails (RuntimeError) before any CRC is checked
        f.seek(last.chunk_start_offset + LZ4_FRAME + 4)
        f.write(b'\xff\xff\xff')
    with caplog.at_level(logging.WARNING, logger='emla_core.bag'):
        assert len(read_bag(bag).recording) == len(recording) - 100
    skip = caplog.records[0].getMessage()
    assert skip.startswith(f'warning: skipped the corrupt chunk {len(recording) // 100 * 3} ') and 'LZ4F_' in skip


def stamps(recording, sample):
    return f'{recording.start_time + sample * recording.sample_period:.6f}'


@pytest.mark.parametrize('which', [0, -1], ids=['first', 'last'])
def test_a_lost_chunk_of_one_signal_names_the_data_it_cost(intact, tmp_path, capsys, caplog, which):
    whole = read_bag(intact).recording
    assert len(whole) == 5000
    bag = copy(intact, tmp_path)
    corrupt(mcap_file(bag), chunks_of(mcap_file(bag), '/emla/voltage')[which])
    lost = (0, FRAME) if which == 0 else (len(whole) - FRAME, len(whole))
    span = f'from t = {stamps(whole, lost[0])} to {stamps(whole, lost[1])} s ({FRAME} samples)'
    cost = (f'{bag}: the skipped chunks cost measured data: current cut {span}; position cut {span}; voltage lost '
            f'{span} (lost: not read; cut: read, but outside the time span all signals share)')
    for read in (lambda: read_bag(bag).recording, lambda: list(iter_chunks(bag, chunk_samples=10_000))[0]):
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger='emla_core.bag'):
            recording = read()
        skip, cut = [r.getMessage() for r in caplog.records]
        assert skip.startswith('warning: skipped the corrupt chunk ') and cut == f'warning: {cost}'
        assert len(recording) == len(whole) - FRAME
        np.testing.assert_array_equal(recording.signals['current'], whole.signals['current'][
            FRAME if which == 0 else 0:][:len(recording)])
    status, out, err = emla(capsys, 'identify', bag)
    assert status == 0
    assert json.loads(out)['warnings'][:2] == [skip.removeprefix('warning: '), cost]
    assert err.splitlines()[:2] == [skip, f'warning: {cost}']


def test_import_refuses_a_bag_that_lost_a_measured_signal(intact, tmp_path, capsys, caplog):
    bag = copy(intact, tmp_path)
    for chunk in chunks_of(mcap_file(bag), '/emla/voltage'):
        corrupt(mcap_file(bag), chunk)
    with caplog.at_level(logging.WARNING, logger='emla_core.bag'):
        assert set(read_bag(bag).recording.signals) == {'current', 'position'}
    assert caplog.records[-1].getMessage() == (f'warning: {bag}: the skipped chunks cost measured data: voltage lost '
                                               f'entirely (lost: not read; cut: read, but outside the time span all '
                                               f'signals share)')
    assert_one_line(capsys, 'import', bag, tmp_path, f'{bag}: no measured voltage, current and position (or force '
                                                     f'and position) to import; it has current, position')
