"""CSV recordings: reading, and every kind of bad input named in the contract."""
import numpy as np
import pytest

from emla_core.data import load, read_csv
from emla_core.errors import InputError
from emla_core.recording import Recording, write_csv


def test_csv_round_trip(tmp_path):
    k = np.arange(50)
    rec = Recording(1e-4, {'voltage': np.sin(k * 0.1), 'current': k * 0.5, 'position': k * 1e-6}, start_time=0.5)
    write_csv(rec, tmp_path / 'a.csv')
    back = load(tmp_path / 'a.csv')
    assert back.sample_period == pytest.approx(1e-4, rel=1e-9)
    assert back.start_time == pytest.approx(0.5)
    assert set(back.signals) == {'voltage', 'current', 'position'}
    for name in rec.signals:
        np.testing.assert_allclose(back.signals[name], rec.signals[name], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize('text, problem', [
    ('', 'empty file'),
    ('t,voltage\n', 'no data rows'),
    ('voltage,current\n1,2\n3,4\n', 'missing column t'),
    ('t,voltage\n0,1\n0.1,nan\n0.2,1\n', 'non-finite value nan in column voltage at data row 2'),
    ('t,voltage\n0,1\n0.1,inf\n', 'non-finite'),
    ('t,voltage\n0,1\n0.2,1\n0.1,1\n', 'time is not increasing at data row 3'),
    ('t,voltage\n0,1\n0.1,1\n0.3,1\n', 'not uniform'),
    ('t,voltage\n0,1\n0.1,abc\n', 'not numeric'),
    ('t,voltage\n0,1,2\n0.1,1,2\n', '3 values per row but 2 columns'),
])
def test_bad_csv_is_one_clear_error(tmp_path, text, problem):
    path = tmp_path / 'bad.csv'
    path.write_text(text)
    with pytest.raises(InputError, match=problem) as err:
        read_csv(path)
    assert str(path) in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match='no such file'):
        load(tmp_path / 'absent.csv')
