"""`emla identify` and `emla import` through the real entry point, good and bad input (contract.md)."""
import json
import subprocess

import numpy as np
import pytest
from ros_isolation import VENV_BIN

from emla_cli.cli import main
from emla_core.bag import write_recording
from emla_core.data import read_csv
from emla_core.parameters import TABLE1
from emla_core.recording import write_csv
from emla_sim.datasets import closed_loop, force_driven

TRUTH = TABLE1.replace(load_force=5.0)
GREYBOX_KEYS = {'model', 'samples', 'sample_period', 'parameters', 'std', 'fit', 'unresolved', 'warnings', 'notes'}


def emla(*args, cwd=None):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def assert_one_line_error(out, name, command='identify'):
    assert out.returncode == 2, out
    assert out.stdout == ''
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'emla {command}: error: '), out.stderr
    assert name in lines[0] and 'Traceback' not in out.stderr


@pytest.fixture(scope='module')
def data(tmp_path_factory):
    folder = tmp_path_factory.mktemp('data')
    recording, _ = closed_loop(TRUTH, duration=0.3, dither=0.2, seed=5)
    write_csv(recording, folder / 'run.csv')
    force, _ = force_driven(duration=0.3, seed=6)
    write_csv(force, folder / 'force.csv')
    return folder


def test_csv_and_imported_bag_give_the_same_answer(data, tmp_path):
    from_csv = emla('identify', data / 'run.csv')
    assert from_csv.returncode == 0, from_csv.stderr
    result = json.loads(from_csv.stdout)
    assert set(result) == GREYBOX_KEYS and result['model'] == 'full' and result['samples'] == 3000
    assert result['sample_period'] == pytest.approx(1e-4)
    for name, value in result['parameters'].items():
        truth = TRUTH.physical()[name]
        assert abs(value - truth) < (0.1 if name == 'load_force' else 0.02 * truth), name
        assert result['std'][name] > 0

    imported = emla('import', data / 'run.csv', tmp_path / 'bag')
    assert imported.returncode == 0, imported.stderr
    assert (tmp_path / 'bag' / 'metadata.yaml').exists()
    from_bag = emla('identify', tmp_path / 'bag', '--json', tmp_path / 'out.json', '--plot', tmp_path / 'out.png')
    # the JSON in its file, a table for the person on stdout
    assert from_bag.returncode == 0 and 'one-sigma' in from_bag.stdout and 'resistance' in from_bag.stdout, \
        from_bag.stderr
    from_bag = json.loads((tmp_path / 'out.json').read_text())
    # the same answer; the plotted run sums its rows in parts (the trajectory), and the mechanical row's nearly
    # collinear normal equations carry that rounding into the 13th digit
    # (to 1e-9 in the parameters; their uncertainties, from the noise model's inverse of those equations, to 1e-5)
    for key, rel in (('parameters', 1e-9), ('std', 1e-5)):
        assert from_bag.pop(key) == pytest.approx(result.pop(key), rel=rel)
    assert from_bag.pop('fit').keys() == result.pop('fit').keys()
    assert from_bag == result
    assert (tmp_path / 'out.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['bag', 'out.json', 'out.png']  # no temporaries


def test_models_arx_and_force_data(data, tmp_path):
    electrical = json.loads(emla('identify', data / 'run.csv', '--model', 'electrical').stdout)
    assert list(electrical['parameters']) == ['resistance', 'inductance', 'emf_constant']

    arx = json.loads(emla('identify', data / 'run.csv', '--model', 'arx').stdout)
    assert set(arx) == {'model', 'orders', 'forgetting', 'a', 'b', 'poles', 'zeros', 'fit_percent', 'mse'}
    assert arx['orders'] == [2, 2, 1] and arx['forgetting'] == 1.0 and arx['a'][0] == 1.0
    assert len(arx['a']) == 3 and len(arx['b']) == 2 and len(arx['poles']) == 2
    assert arx['fit_percent'] > 90  # 2 2 1 is the exact structure of voltage -> current

    out = emla('identify', data / 'run.csv', '--model', 'arx', '--orders', '4', '3', '1', '--input', 'voltage',
               '--output', 'position', '--forgetting', '0.9999', '--plot', tmp_path / 'arx.png')
    arx = json.loads(out.stdout)
    assert arx['orders'] == [4, 3, 1] and arx['forgetting'] == 0.9999 and len(arx['a']) == 5
    assert (tmp_path / 'arx.png').exists()

    mechanical = json.loads(emla('identify', data / 'force.csv').stdout)
    assert mechanical['model'] == 'mechanical'
    assert list(mechanical['parameters']) == ['mass', 'damping', 'load_force']


def bad_inputs(folder, run_csv):
    """{name: path} of every kind of bad input the contract names."""
    lines = run_csv.read_text().splitlines()
    header, rows = lines[0], lines[1:200]
    cases = {
        'missing.csv': '\n'.join(['t,voltage,current'] + [','.join(r.split(',')[:3]) for r in rows]),
        'nan.csv': '\n'.join([header] + rows[:50] + ['0.005,nan,1,0.001'] + rows[51:]),
        'inf.csv': '\n'.join([header] + rows[:50] + ['0.005,1,inf,0.001'] + rows[51:]),
        'backwards.csv': '\n'.join([header] + rows[:50] + [rows[20]] + rows[51:]),
        'empty.csv': '',
        'header-only.csv': header,
        'text.csv': header + '\n0,a,b,c\n',
    }
    paths = {}
    for name, text in cases.items():
        paths[name] = folder / name
        paths[name].write_text(text + '\n' if text else '')
    bag = folder / 'truncated'
    write_recording(read_csv(run_csv), bag)
    split = next(bag.glob('*.mcap'))
    split.write_bytes(split.read_bytes()[:3000])
    paths['truncated'] = bag
    paths['noise.mcap'] = folder / 'noise.mcap'
    paths['noise.mcap'].write_bytes(np.random.default_rng(0).bytes(200))
    paths['plain-dir'] = folder / 'plain-dir'
    paths['plain-dir'].mkdir()
    paths['absent.csv'] = folder / 'absent.csv'
    return paths


def test_every_bad_input_is_one_line_and_no_output(data, tmp_path):
    # each its own outputs: runs at once on one output are refused as a second writer (tests/test_output_discipline)
    runs = {name: subprocess.Popen([str(VENV_BIN / 'emla'), 'identify', str(path), '--json',
                                    str(tmp_path / f'out{k}.json'), '--plot', str(tmp_path / f'out{k}.png')],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for k, (name, path) in enumerate(bad_inputs(tmp_path, data / 'run.csv').items())}
    for name, run in runs.items():
        stdout, stderr = run.communicate(timeout=120)
        assert_one_line_error(subprocess.CompletedProcess(run.args, run.returncode, stdout, stderr), name)
    assert not list(tmp_path.glob('out*')) and not list(tmp_path.glob('.out*'))


@pytest.mark.parametrize('case', ['yaml', 'tiny'])
def test_unreadable_bag_corner_cases(tmp_path, case):
    if case == 'yaml':
        path = tmp_path / 'bag'
        path.mkdir()
        (path / 'metadata.yaml').write_text('rosbag2_bagfile_information: [\n')
    else:
        path = tmp_path / 'tiny.mcap'
        path.write_bytes(b'junk\n')
    assert_one_line_error(emla('identify', path), path.name)


@pytest.mark.parametrize('args, message', [
    (['--model', 'thermal'], "--model 'thermal': choose one of"),
    (['--model', 'arx', '--orders', '2', 'x', '1'], '--orders 2 x 1: need three integers'),
    (['--model', 'arx', '--orders', '0', '0', '1'], 'NA + NB >= 1'),
    (['--model', 'arx', '--orders', '2', '-1', '1'], 'NA, NB, NK >= 0'),
    (['--orders', '2', '2', '1'], '--orders applies to --model arx only'),
    (['--model', 'arx', '--input', 'voltage'], '--input and --output go together'),
    (['--model', 'arx', '--input', 'voltage', '--output', 'speed'], 'run.csv: missing column(s) speed'),
    (['--forgetting', '0'], '--forgetting 0: must be a number in [0.5, 1]'),
    (['--forgetting', 'often'], '--forgetting often'),
    (['--model', 'electrical'], None),  # fine: a control case
])
def test_bad_options_are_one_line(data, capsys, args, message):
    status = main(['identify', str(data / 'run.csv'), *args])
    captured = capsys.readouterr()
    if message is None:
        assert status == 0 and json.loads(captured.out)['model'] == 'electrical'
        return
    assert status == 2 and captured.out == ''
    assert captured.err.count('\n') == 1 and message in captured.err, captured.err


def test_data_that_cannot_fit_the_model(data, tmp_path, capsys):
    short = tmp_path / 'short.csv'
    short.write_text('\n'.join((data / 'run.csv').read_text().splitlines()[:11]) + '\n')
    cases = [
        ([str(data / 'force.csv'), '--model', 'arx'], 'force.csv: no voltage and current columns'),
        ([str(data / 'force.csv'), '--model', 'electrical'], 'force.csv: model electrical needs voltage'),
        ([str(short)], 'short.csv: 10 samples are too few for the full model'),
        ([str(short), '--model', 'arx', '--orders', '6', '6', '1'], 'short.csv: 10 samples are too few'),
    ]
    for args, message in cases:
        assert main(['identify', *args]) == 2
        err = capsys.readouterr().err
        assert err.count('\n') == 1 and message in err, err


def test_unwritable_outputs_leave_nothing(data, tmp_path, capsys):
    json_path = tmp_path / 'out.json'
    status = main(['identify', str(data / 'run.csv'), '--json', str(json_path),
                   '--plot', str(tmp_path / 'missing-dir' / 'out.png')])
    assert status == 2 and 'out.png: its directory does not exist' in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_import_refuses_bad_csv_and_used_directory(data, tmp_path):
    bad = tmp_path / 'bad.csv'
    bad.write_text('t,voltage\n0,1\n0,2\n')
    assert_one_line_error(emla('import', bad, tmp_path / 'bag'), 'bad.csv', 'import')
    assert not (tmp_path / 'bag').exists()
    used = tmp_path / 'used'
    used.mkdir()
    (used / 'keep.txt').write_text('x')
    assert_one_line_error(emla('import', data / 'run.csv', used), 'used', 'import')
    assert [p.name for p in used.iterdir()] == ['keep.txt']


def test_arx_columns_by_the_users_own_names(tmp_path):
    """A column named u is read as the voltage (its alias); --input u still finds it. The ARX of a known
    second-order system comes out exact."""
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal(2000), np.zeros(2000)
    for k in range(2, len(y)):
        y[k] = 1.5 * y[k - 1] - 0.7 * y[k - 2] + 0.5 * u[k - 1]
    path = tmp_path / 'uy.csv'
    np.savetxt(path, np.column_stack([1e-4 * np.arange(len(y)), u, y]), delimiter=',', header='t,u,y', comments='')
    out = tmp_path / 'arx.json'
    assert main(['identify', str(path), '--model', 'arx', '--input', 'u', '--output', 'y', '--orders', '2', '1', '1',
                 '--json', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['a'] == pytest.approx([1.0, -1.5, 0.7], abs=1e-6) and result['b'] == pytest.approx([0.5], abs=1e-6)


def test_other_column_names_are_told_the_flag_that_maps_them(tmp_path):
    path = tmp_path / 'logger.csv'
    path.write_text('time,Ucoil_V,Icoil_A,stroke_mm\n0,1,0,0\n0.0001,1,0.1,0\n')
    out = emla('identify', path)
    assert_one_line_error(out, 'logger.csv')
    assert 'has Ucoil_V, Icoil_A, stroke_mm: map yours with --columns voltage=NAME' in out.stderr
