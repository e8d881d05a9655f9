"""Records in segments: a logger that drops samples (gaps), a row it wrote twice, a bag with missing frames, and
--start/--end windows. The grey-box identification takes every segment's rows, none across a gap, into one
estimate (the in-memory and the streaming path alike); the other commands name the gaps and the part to take."""
import json
import subprocess

import numpy as np
import pytest
from independent_plant import record
from ros_isolation import VENV_BIN

from emla_cli.cli import main
from emla_core.bag import BagWriter
from emla_core.data import load, read_csv
from emla_core.errors import InputError
from emla_core.messages import frame_message
from emla_core.recording import Recording
from emla_core.sampling import MAX_GAPS
from emla_core.topics import SAMPLE_FRAME
from emla_identification import streaming
from emla_identification.greybox import identify
from emla_identification.streaming import identify_chunks
from emla_sim.datasets import closed_loop

LOST = {'current': (7123, 5), 'position': (15321, 40), 'voltage': (23456, 12)}   # first sample, samples lost
REPEATED = 10001   # the data row written twice
COLUMNS = ('voltage', 'current', 'position')


def write_rows(path, time, signals, rows):
    """A CSV file of the rows `rows` (sample numbers, in file order) of t and the signals."""
    table = np.column_stack([time[rows]] + [signals[name][rows] for name in COLUMNS])
    np.savetxt(path, table, delimiter=',', header='t,' + ','.join(COLUMNS), comments='', fmt='%.10g')
    return path


def write_frames(recording, path, lost):
    """`recording` as a bag of /emla/ SampleFrames (of up to 100 samples, at their samples' times) without the
    samples `lost` {signal: (first, count)} of each signal: a recorder that missed messages."""
    ts = recording.sample_period
    frames = []
    for name, values in recording.signals.items():
        kept = np.ones(len(values), dtype=bool)
        first, count = lost.get(name, (0, 0))
        kept[first:first + count] = False
        for start in range(0, len(values), 100):
            samples = np.flatnonzero(kept[start:start + 100]) + start
            for run in np.split(samples, np.flatnonzero(np.diff(samples) > 1) + 1):
                frames.append((int(run[0]), name, values[run]))
    with BagWriter(path) as bag:
        for name in recording.signals:
            bag.add_topic(f'/emla/{name}', SAMPLE_FRAME)
        for first, name, values in sorted(frames, key=lambda f: f[:2]):
            stamp = round(first * ts * 1e9)
            bag.write_message(f'/emla/{name}', stamp, frame_message(stamp, ts, values))
    return path


@pytest.fixture(scope='module')
def data(tmp_path_factory):
    """3 s of the independent plant (a load force, so that every parameter is far from zero) as a CSV without
    gaps, the same with three gaps and a repeated row, and a bag of its samples with frames missing there."""
    folder = tmp_path_factory.mktemp('segments')
    rec, _ = record(3.0, params={'load_force': 0.2}, seed=1)
    time, n = rec.time, len(rec)
    write_rows(folder / 'whole.csv', time, rec.signals, np.arange(n))
    kept = np.ones(n, dtype=bool)
    for first, count in LOST.values():
        kept[first:first + count] = False
    rows = np.flatnonzero(kept)
    write_rows(folder / 'gapped.csv', time, rec.signals, np.insert(rows, REPEATED, rows[REPEATED - 1]))
    whole = read_csv(folder / 'whole.csv')   # the CSV's values, to the digit
    write_frames(Recording(whole.sample_period, whole.signals), folder / 'bag', LOST)
    return folder


def identify_json(*argv):
    """`emla identify ARGV --json FILE` in this process: its JSON."""
    out = f'{argv[0]}.{abs(hash(argv))}.json'
    assert main(['identify', *map(str, argv), '--json', out, '--force']) == 0
    with open(out) as f:
        return json.load(f)


def listed(result):
    """The figures of a JSON's segments and gaps, in order."""
    return [value for key in ('segments', 'gaps') for item in result[key] for value in item.values()]


def one_line_error(argv, capsys):
    """`emla ARGV` in this process: exit 2, nothing on stdout, one error line on stderr (returned)."""
    assert main([str(a) for a in argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and captured.err.count('\n') == 1, captured
    assert captured.err.startswith(f'emla {argv[0]}: error: ') and 'Traceback' not in captured.err
    return captured.err


def test_a_logger_that_drops_samples_is_identified_in_segments(data, capsys):
    """Three gaps and a repeated row: exit 0, the segments and gaps listed, the row dropped with a warning, and
    every parameter within 0.5 % (of its value) and within one sigma of the estimate from the record without
    gaps."""
    whole, gapped = identify_json(data / 'whole.csv'), identify_json(data / 'gapped.csv')
    err = capsys.readouterr().err
    (warning,) = [w for w in gapped['warnings'] if 'repeated' in w]
    assert f'emla identify: warning: {warning}' in err and f'data row {REPEATED + 1}' in warning
    firsts = sorted(first for first, _ in LOST.values())
    assert [s['samples'] for s in gapped['segments']] == [7123, 15321 - 7128, 23456 - 15361, 30000 - 23468]
    assert [g['missing'] for g in gapped['gaps']] == [5, 40, 12]
    assert [g['start'] for g in gapped['gaps']] == pytest.approx([1e-4 * k for k in firsts])
    assert gapped['samples'] == 30000 - 57 and 'segments' not in whole
    for name, value in whole['parameters'].items():
        change = gapped['parameters'][name] - value
        assert abs(change) <= 5e-3 * abs(value) and abs(change) <= gapped['std'][name], name
    assert all(fit['adequate'] for fit in gapped['fit'].values())


def test_the_streaming_path_and_a_bag_with_missing_frames_agree(data, monkeypatch):
    """The bag whose topics each miss frames where the CSV misses rows gives the CSV's segments and estimate;
    read and identified part by part (as a long record is), both give it too."""
    csv = identify_json(data / 'gapped.csv')
    results, streamed = [identify_json(data / 'bag')], []
    monkeypatch.setattr(streaming, 'LONG_SAMPLES', 1000)
    monkeypatch.setattr(streaming, 'identify_chunks', lambda *a, **k: streamed.append(1) or identify_chunks(*a, **k))
    results += [identify_json(data / 'bag'), identify_json(data / 'gapped.csv')]
    assert len(streamed) == 2
    for result in results:
        assert result['samples'] == csv['samples'] and listed(result) == pytest.approx(listed(csv))
        for name, value in csv['parameters'].items():
            assert result['parameters'][name] == pytest.approx(value, rel=1e-9), name
            # (the CSV holds 10 digits, the bag every bit: the noise model's fit, converged to its tolerance,
            # moves a one-sigma by up to some 1e-5 of itself between the two)
            assert result['std'][name] == pytest.approx(csv['std'][name], rel=1e-4), name


def test_start_and_end_are_the_csv_cut_by_hand(data, tmp_path):
    """A window over two of the gaps gives what the CSV's rows from t = 0.5 s to before 2.2 s give as a file of
    their own (the bag's window the same estimate)."""
    lines = (data / 'gapped.csv').read_text().splitlines()
    cut = [line for line in lines[1:] if 0.5 <= float(line.split(',')[0]) < 2.2]
    (tmp_path / 'cut.csv').write_text('\n'.join([lines[0], *cut]) + '\n')
    by_hand = identify_json(tmp_path / 'cut.csv')
    window = identify_json(data / 'gapped.csv', '--start', '0.5', '--end', '2.2')
    assert len(window['gaps']) == 2 and window['samples'] == len(cut) - 1   # (the repeated row dropped)
    for key in ('samples', 'parameters', 'std', 'fit', 'segments', 'gaps'):
        assert window[key] == by_hand[key], key
    bag = identify_json(data / 'bag', '--start', '0.5', '--end', '2.2')
    assert listed(bag) == pytest.approx(listed(window)) and bag['samples'] == window['samples']
    for name, value in window['parameters'].items():
        assert bag['parameters'][name] == pytest.approx(value, rel=1e-9), name


def test_a_time_repeated_with_other_values_is_one_line(data, tmp_path):
    lines = (data / 'whole.csv').read_text().splitlines()
    t, *values = lines[1001].split(',')
    lines.insert(1002, ','.join([t, *values[:-1], '0.5']))   # data row 1002 again, at another position
    (tmp_path / 'repeated.csv').write_text('\n'.join(lines) + '\n')
    out = subprocess.run([str(VENV_BIN / 'emla'), 'identify', str(tmp_path / 'repeated.csv')], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 2 and out.stdout == '' and 'Traceback' not in out.stderr
    assert out.stderr.count('\n') == 1 and out.stderr.startswith('emla identify: error: ')
    assert 'time is not increasing at data row 1002' in out.stderr and 'with other values' in out.stderr


@pytest.mark.parametrize('window, problem', [
    (('--start', '4'), '--start 4 s is after the end of the record'),
    (('--end', '-1'), '--end -1 s is not after the start of the record'),
    (('--start', '1.5325', '--end', '1.5355'), 'no samples from t = 1.5325 to 1.5355 s: they fall in a gap'),
    (('--start', '2', '--end', '1'), '--start 2 s must be before --end 1 s'),
    (('--start', 'nan'), '--start nan'),
], ids=['after', 'before', 'in a gap', 'reversed', 'nan'])
def test_a_window_outside_the_record_or_empty_is_one_line(data, capsys, window, problem):
    for path in (data / 'gapped.csv', data / 'bag'):
        assert problem in one_line_error(['identify', path, *window], capsys)


def test_commands_that_take_no_gaps_name_the_part_to_take(data, capsys):
    """discrepancy (and ARX, which would bridge a gap) refuse the record in one line that names the longest
    part without gaps; that part is taken."""
    for argv in (['discrepancy', data / 'gapped.csv'], ['identify', data / 'gapped.csv', '--model', 'arx']):
        line = one_line_error(argv, capsys)
        assert '3 gap(s) (missing samples), the first after t = 0.7122 s (5 sample(s) missing)' in line
        start, end = line.split('(the longest: ')[1].rstrip(')\n').split()[1::2]
        assert float(start) < 0.7128 and 1.5321 - 1e-4 < float(end) < 1.5321
    arx = identify_json(data / 'gapped.csv', '--model', 'arx', '--start', start, '--end', end)
    assert arx['model'] == 'arx'


def csv_of(path, recording, rows):
    return write_rows(path, recording.time, recording.signals, rows)


def test_segments_too_short_for_a_row_are_dropped_and_gaps_are_bounded(tmp_path):
    """A segment of fewer samples than a row spans gives none, with a note; too many gaps, or one longer than
    the record, is one clear line."""
    rec, _ = closed_loop(duration=0.2, dither=0.2, seed=3)
    n = len(rec)
    short = load(csv_of(tmp_path / 'short.csv', rec, np.r_[0:900, 910:913, 920:n]), gaps=True)
    assert short.gaps == ((900, 10), (903, 7)) and len(short.segments()[1]) == 3
    result = identify(short)
    assert result.samples == n - 17
    assert result.notes == ['1 segment(s) shorter than a regression row (6 samples) are not used: t = 0.091 s '
                            '(3 samples)']
    many = np.delete(np.arange(n), np.arange(10, 10 * (MAX_GAPS + 2), 10))
    with pytest.raises(InputError, match=f'{MAX_GAPS + 1} gaps .missing samples., more than the {MAX_GAPS}'):
        load(csv_of(tmp_path / 'many.csv', rec, many), gaps=True)
    apart = csv_of(tmp_path / 'apart.csv', rec, np.arange(n))
    lines = apart.read_text().splitlines()
    lines[n // 2 + 1:] = [f'{float(line.split(",")[0]) + 10:.10g},{line.split(",", 1)[1]}' for line in
                          lines[n // 2 + 1:]]
    apart.write_text('\n'.join(lines) + '\n')
    with pytest.raises(InputError, match='100000 samples are missing after t = 0.0999 s, more than the 2000 the '
                                         'record holds: these are separate records'):
        load(apart, gaps=True)
