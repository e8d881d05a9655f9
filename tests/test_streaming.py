"""Long records part by part: the streaming least-squares accumulator, the bag read in parts, the streaming grey-box
identification and `emla identify` on a record long enough to stream. Each equals its whole-record counterpart."""
import json

import numpy as np
import pytest
from mcap.writer import Writer

from emla_cli.cli import main
from emla_core.bag import BagWriter, iter_chunks, read_bag, typestore, write_recording
from emla_core.data import read_csv
from emla_core.errors import InputError
from emla_core.messages import frame_message, serialize
from emla_core.parameters import TABLE1
from emla_core.recording import Recording, write_csv
from emla_core.topics import SAMPLE_FRAME
from emla_identification import streaming
from emla_identification.greybox import identify
from emla_identification.moments import LagMoments
from emla_identification.offline import WeightedAccumulator, weighted_least_squares
from emla_identification.online import OnlineIdentifier
from emla_identification.regressors import HISTORY, RowStream, instruments, rows
from emla_identification.streaming import identify_chunks
from emla_sim.datasets import closed_loop, force_driven

UNEVEN = (1, 7, 1000, 3, 4096, 250)


def pieces(n, sizes=UNEVEN):
    """Consecutive (start, stop) covering range(n), lengths cycling through `sizes`."""
    start, j = 0, 0
    while start < n:
        stop = min(n, start + sizes[j % len(sizes)])
        yield start, stop
        start, j = stop, j + 1


def parts(recording, sizes=UNEVEN):
    ts = recording.sample_period
    for start, stop in pieces(len(recording), sizes):
        yield Recording(ts, {k: v[start:stop] for k, v in recording.signals.items()},
                        start_time=recording.start_time + start * ts, source=recording.source)


def assert_relative(actual, desired, rtol):
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert np.abs(actual - desired).max() <= rtol * np.abs(desired).max(), (actual, desired)


@pytest.mark.parametrize('lam', [1.0, 0.999, 0.98])
def test_accumulator_equals_weighted_least_squares(lam):
    rng = np.random.default_rng(1)
    Phi = rng.normal(size=(40_000, 4)) + [0.0, 1.0, 0.0, 0.5]
    Y = Phi @ [0.8, -1.5, 0.3, 2.0] + 0.05 * rng.normal(size=len(Phi))
    prior = dict(initial_theta=[1.0, 0.0, 0.0, 1.0], initial_covariance=np.diag([0.1, 1.0, 10.0, 100.0]))
    whole = weighted_least_squares(Phi, Y, forgetting=lam, **prior)
    for sizes in (UNEVEN, (30_000,)):  # a part longer than offline's overflow-safe chunk at lambda 0.98
        accumulator = WeightedAccumulator(4, forgetting=lam, **prior)
        for j, (start, stop) in enumerate(pieces(len(Y), sizes)):
            if j % 2:
                accumulator.add(Phi[start:stop], Y[start:stop])
            else:
                accumulator.add_stacked(np.column_stack((Phi[start:stop], Y[start:stop])))
        part = accumulator.estimate()
        assert part.samples == whole.samples == len(Y)
        assert_relative(part.theta, whole.theta, 1e-10)
        assert_relative(part.covariance, whole.covariance, 1e-10)
        assert part.residual_variance == pytest.approx(whole.residual_variance, rel=1e-10)
    with pytest.raises(ValueError, match='non-finite'):
        accumulator.add(Phi[:3], np.array([1.0, np.nan, 2.0]))


@pytest.mark.parametrize('lam', [1.0, 0.99])
def test_lag_moments_in_any_frames_equal_the_direct_sums(lam):
    z = np.random.default_rng(2).normal(size=(3000, 5))
    w2 = lam ** (2.0 * np.arange(len(z) - 1, -1, -1))
    padded = np.vstack((np.zeros((HISTORY, 5)), z))
    direct = [(w2[:, None] * z).T @ padded[HISTORY - d:HISTORY - d + len(z)] for d in range(HISTORY + 1)]
    moments = LagMoments(5, lam)
    for start, stop in pieces(len(z)):
        moments.update(z[start:stop])
    assert_relative(moments.moments, direct, 1e-12)
    assert moments.weight == pytest.approx(w2.sum(), rel=1e-12)


def test_row_stream_gives_the_rows_of_the_whole_record():
    recording, _ = closed_loop(TABLE1, duration=0.05, dither=0.2)
    stream = RowStream(('electrical', 'mechanical'), recording.sample_period)
    got = {'electrical': [], 'mechanical': []}
    for part in parts(recording):
        for kind, (phi, y, zeta) in stream.rows(part.signals).items():
            got[kind].append(np.column_stack((phi, y) if zeta is None else (phi, y, zeta)))
    assert stream.samples == len(recording)
    for kind, blocks in got.items():
        whole = rows(kind, recording.signals, recording.sample_period)
        zeta = instruments(kind, recording.signals, recording.sample_period)
        expected = np.column_stack(whole if zeta is None else (*whole, zeta))
        np.testing.assert_array_equal(np.concatenate(blocks), expected)
    assert got['electrical'][0].shape[1] == 9 and got['mechanical'][0].shape[1] == 13  # both instrumented


def assert_same_result(streamed, whole, rel=1e-10, std_rel=1e-5):
    """Parameters to `rel` (1e-10); std to `std_rel` (1e-5): the noise model inverts the mechanical regression's normal
    equations, whose free coefficients are nearly collinear at 10 kHz (regressors.FIRST_ORDER), which carries the
    rounding of different summation orders into the uncertainties."""
    assert streamed.model == whole.model and streamed.samples == whole.samples
    assert streamed.sample_period == whole.sample_period and streamed.forgetting == whole.forgetting
    assert list(streamed.parameters) == list(whole.parameters)
    for name, value in whole.parameters.items():
        assert streamed.parameters[name] == pytest.approx(value, rel=rel, abs=1e-12), name
        assert streamed.std[name] == pytest.approx(whole.std[name], rel=std_rel), name


@pytest.mark.parametrize('model, lam', [(None, 1.0), (None, 0.9995), ('electrical', 1.0), ('mechanical', 1.0)])
def test_streaming_identification_equals_the_whole_record(model, lam):
    recording, _ = closed_loop(TABLE1.replace(load_force=5.0), duration=0.4, dither=0.2, seed=2)
    whole = identify(recording, model, lam)
    streamed = identify_chunks(parts(recording, (1, 7, 100, 3, 40, 25)), model, lam, points=20)
    assert_same_result(streamed, whole)
    trajectory = streamed.trajectory
    assert 10 <= len(trajectory.time) <= 20 and np.all(np.diff(trajectory.time) > 0)
    assert trajectory.time[-1] == pytest.approx(recording.time[-1])
    for name, value in streamed.parameters.items():
        assert trajectory.parameters[name][-1] == value


def test_streaming_force_data_and_in_memory_split():
    recording, _ = force_driven(seed=3)
    assert_same_result(identify_chunks(parts(recording)), identify(recording))
    assert_same_result(identify_chunks(streaming.split(recording, 999), points=1), identify(recording))


def test_streaming_refuses_what_identify_refuses():
    recording, _ = closed_loop(TABLE1, duration=0.1)
    signals = recording.signals
    broken = dict(signals, current=signals['current'].copy())
    broken['current'][40] = np.nan
    with pytest.raises(InputError, match='x.csv: non-finite current at sample 40'):
        identify_chunks(parts(Recording(1e-4, broken, source='x.csv'), [16]))
    short = Recording(1e-4, {k: v[:12] for k, v in signals.items()}, source='short.csv')
    with pytest.raises(InputError, match='short.csv: 12 samples are too few'):
        identify_chunks(parts(short, [5]))
    still = Recording(1e-4, {k: np.zeros(500) for k in signals}, source='still.csv')
    with pytest.raises(InputError, match='still.csv: the data do not excite'):
        identify_chunks(parts(still))


def test_online_values_agree_with_the_estimate():
    """values() weighs the coefficients as if the rows' errors were white (no noise model): a less efficient fit
    of the same parameters, within two of estimate()'s standard deviations of it."""
    recording, _ = closed_loop(TABLE1.replace(load_force=5.0), duration=0.2, dither=0.2)
    online = OnlineIdentifier(recording.sample_period)
    for start, stop in pieces(len(recording), [100]):
        online.update(**{k: v[start:stop] for k, v in recording.signals.items()})
    values, std = online.estimate()
    for name, value in online.values().items():
        assert abs(value - values[name]) < 2.0 * std[name], name


def staggered_bag(path, n=3000, frame=10, split_size=2 * 2**20):
    """A bag laid out like the ROS graph records: voltage frames at k Tc, state frames at k Tc + Ts after a
    one-sample frame at 0, and a reference that starts late and ends early (so read_bag cuts all to its span)."""
    ts, rng = 1e-4, np.random.default_rng(4)
    data = {name: rng.normal(size=n) for name in ('voltage', 'current', 'position', 'reference')}
    layout = {'voltage': [(k, k + frame) for k in range(0, n, frame)],
              'current': [(0, 1)] + [(k + 1, k + 1 + frame) for k in range(0, n - 1 - frame, frame)],
              'reference': [(k, k + frame) for k in range(50, n - 200, frame)]}
    layout['position'] = layout['current']
    stamp = 1_700_000_000 * 10**9  # seconds since the epoch in the stamps: sec takes 31 bits
    with BagWriter(path, split_size=split_size, custom_data={'true_resistance': '4.0'}) as bag:
        for name in data:
            bag.add_topic(f'/emla/{name}', SAMPLE_FRAME)
        for k in range(0, n, frame):
            for name, frames in layout.items():
                for a, b in frames:
                    if k <= a < k + frame:
                        at = stamp + round(a * ts * 1e9)
                        bag.write_message(f'/emla/{name}', at, frame_message(at, ts, data[name][a:b], 'frame'))
    return path


@pytest.mark.parametrize('split_size', [2 * 2**20, 20_000], ids=['one-file', 'split'])
def test_bag_parts_are_read_bags_signals(tmp_path, split_size):
    bag = staggered_bag(tmp_path / 'bag', split_size=split_size)
    whole = read_bag(bag).recording
    assert len(whole) < 3000  # cut to the reference's span
    for size in (1, 7, 1000, 1 << 15):
        got = list(iter_chunks(bag, chunk_samples=size))
        assert all(len(p) == size for p in got[:-1]) and 0 < len(got[-1]) <= size
        first = got[0]
        assert (first.sample_period, first.start_time, first.source, first.metadata) == \
            (whole.sample_period, whole.start_time, whole.source, whole.metadata)
        assert list(first.signals) == sorted(whole.signals)
        for name, values in whole.signals.items():
            np.testing.assert_array_equal(np.concatenate([p.signals[name] for p in got]), values)
    subset = list(iter_chunks(bag, signals=('current', 'position', 'absent')))
    assert set(subset[0].signals) == {'current', 'position'}
    np.testing.assert_array_equal(np.concatenate([p.signals['current'] for p in subset]), whole.signals['current'])


def current_frames(path, starts):
    """A bag of /emla/current frames of 10 samples (value: the sample's number) at the samples `starts` (0.1 ms)."""
    with BagWriter(path) as writer:
        writer.add_topic('/emla/current', SAMPLE_FRAME)
        for k in starts:
            writer.write_message('/emla/current', k * 10**5, frame_message(k * 10**5, 1e-4, np.arange(k, k + 10.0)))
    return path


def test_bag_parts_have_read_bags_gaps_and_refuse_its_overlaps(tmp_path):
    """A missing frame is a gap of the record in both readers (no part spans it); a frame that begins inside the
    one before is refused by both alike."""
    bag = current_frames(tmp_path / 'gap', (0, 10, 30))
    whole = read_bag(bag).recording
    assert whole.gaps == ((20, 10),)
    np.testing.assert_array_equal(whole.time, np.r_[0:20, 30:40] * 1e-4)
    got = list(iter_chunks(bag, chunk_samples=7))
    assert [len(p) for p in got] == [7, 7, 6, 7, 3]
    assert [p.start_time for p in got] == pytest.approx(np.array([0, 7, 14, 30, 37]) * 1e-4)
    np.testing.assert_array_equal(np.concatenate([p.signals['current'] for p in got]), whole.signals['current'])
    overlap = current_frames(tmp_path / 'overlap', (0, 10, 15))
    with pytest.raises(InputError) as whole:
        read_bag(overlap)
    with pytest.raises(InputError) as streamed:
        list(iter_chunks(overlap))
    assert str(streamed.value) == str(whole.value) and 'has an overlap at t = 0.001500 s' in str(whole.value)


def test_a_bare_mcap_without_chunks_is_read_whole(tmp_path):
    path = tmp_path / 'bare.mcap'
    msgdef, _ = typestore().generate_msgdef(SAMPLE_FRAME, ros_version=2)
    with path.open('wb') as f:
        writer = Writer(f, use_chunking=False)
        writer.start(profile='ros2', library='test')
        schema = writer.register_schema(name=SAMPLE_FRAME, encoding='ros2msg', data=msgdef.encode())
        channel = writer.register_channel(topic='/emla/current', message_encoding='cdr', schema_id=schema)
        for k in range(5):
            frame = frame_message(k * 10**6, 1e-4, np.full(10, float(k)))
            writer.add_message(channel, log_time=k * 10**6, publish_time=k * 10**6, data=serialize(frame))
        writer.finish()
    (part,) = iter_chunks(path, chunk_samples=7)
    np.testing.assert_array_equal(part.signals['current'], read_bag(path).recording.signals['current'])


@pytest.fixture(scope='module')
def run_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp('long')
    recording, _ = closed_loop(TABLE1.replace(load_force=5.0), duration=0.3, dither=0.2, seed=5)
    write_csv(recording, folder / 'run.csv')
    write_recording(read_csv(folder / 'run.csv'), folder / 'bag')  # the same values as the CSV (as emla import)
    return folder


def identify_json(path, *args):
    out = path.parent / f'{path.name}.{len(args)}.json'
    assert main(['identify', str(path), '--json', str(out), *args]) == 0
    return json.loads(out.read_text())


def test_emla_identify_streams_a_long_record_to_the_same_answer(run_bag, monkeypatch, tmp_path):
    short_csv, short_bag = identify_json(run_bag / 'run.csv'), identify_json(run_bag / 'bag')
    assert short_bag == short_csv  # under LONG_SAMPLES: the whole-record path, unchanged
    streamed = []
    monkeypatch.setattr(streaming, 'LONG_SAMPLES', 1000)
    monkeypatch.setattr(streaming, 'identify_chunks',
                        lambda *a, **k: streamed.append(1) or identify_chunks(*a, **k))
    for path in (run_bag / 'bag', run_bag / 'run.csv'):
        result = identify_json(path, '--plot', str(tmp_path / 'plot.png'), '--force')   # one plot, drawn twice
        assert set(result) == set(short_csv) and result['samples'] == short_csv['samples'] == 3000
        assert result['sample_period'] == short_csv['sample_period']
        for name, value in short_csv['parameters'].items():
            assert result['parameters'][name] == pytest.approx(value, rel=1e-10), name
            assert result['std'][name] == pytest.approx(short_csv['std'][name], rel=1e-5), name
    assert len(streamed) == 2 and (tmp_path / 'plot.png').exists()
