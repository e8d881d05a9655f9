"""Nothing lost (issue 19): no output of an `emla` command is written over an input, over a device or FIFO, or
over an existing file without --force; the outputs of a command appear together or not at all; stdout that
cannot take the JSON is one line and exit 2."""
import json
import os
import shutil
import stat
import subprocess
import sys

import pytest
from independent_data import EXAMPLES
from ros_isolation import REPO

from emla_cli import cli
from emla_cli.commands import identify as identify_command

MAT_COLUMNS = ('--columns', 't=time,voltage=coil_voltage,current=coil_current,position=stroke')


@pytest.fixture(scope='module')
def model(tmp_path_factory):
    """The bytes of a model file identified on the example CSV."""
    folder = tmp_path_factory.mktemp('model')
    assert cli.main(['identify', str(EXAMPLES / 'logger.csv'), '--model-out', str(folder / 'm.yaml'),
                     '--json', str(folder / 'i.json')]) == 0
    return (folder / 'm.yaml').read_bytes()


@pytest.fixture
def work(tmp_path, model, monkeypatch):
    """The working directory: copies of the example CSV and MAT file, a bag (holding a model file too, as a
    user may keep one there) and the model file."""
    shutil.copy(EXAMPLES / 'logger.csv', tmp_path)
    shutil.copy(EXAMPLES / 'scope.mat', tmp_path)
    shutil.copytree(REPO / 'bags' / 'example_discrepancy', tmp_path / 'bag')
    for path in (tmp_path / 'm.yaml', tmp_path / 'bag' / 'm.yaml'):
        path.write_bytes(model)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def snapshot(folder):
    """Every path under `folder` with the bytes of the regular files (None for others)."""
    return {p.relative_to(folder): p.read_bytes() if p.is_file() else None for p in folder.rglob('*')}


def refused(argv, capsys, message):
    """Run `emla argv` in this process: exit 2 and one line on stderr holding `message`."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith(f'emla {argv[0]}: error: ') and message in err, err


@pytest.mark.parametrize('argv, message', [
    (['identify', 'logger.csv', '--json', 'logger.csv'], '--json logger.csv: is the input logger.csv'),
    (['identify', 'logger.csv', '--plot', 'logger.csv'], '--plot logger.csv: is the input logger.csv'),
    (['identify', 'logger.csv', '--model-out', 'logger.csv'], '--model-out logger.csv: is the input logger.csv'),
    (['identify', 'scope.mat', *MAT_COLUMNS, '--json', 'scope.mat'], '--json scope.mat: is the input scope.mat'),
    (['identify', 'logger.csv', '--model-file', 'm.yaml', '--model-out', 'm.yaml', '--force'], 'is the input m.yaml'),
    (['identify', 'bag', '--json', 'bag/metadata.yaml', '--force'], 'bag/metadata.yaml: is inside the input bag'),
    (['identify', 'bag', '--plot', 'bag/new.png'], '--plot bag/new.png: is inside the input bag'),
    (['discrepancy', 'logger.csv', '--json', 'logger.csv', '--force'], '--json logger.csv: is the input'),
    (['discrepancy', 'scope.mat', *MAT_COLUMNS, '--model-out', 'scope.mat'], '--model-out scope.mat: is the input'),
    (['discrepancy', 'bag', '--report', 'bag', '--force'], '--report bag: is the input bag'),
    (['discrepancy', 'logger.csv', '--report', '.', '--force'], '--report .: contains the input logger.csv'),
    (['compare', 'logger.csv', '--model-file', 'm.yaml', '--json', 'm.yaml', '--force'], '--json m.yaml: is the input'),
    (['compare', 'logger.csv', '--model-file', 'm.yaml', '--plot', 'logger.csv'], '--plot logger.csv: is the input'),
    (['compare', 'bag', '--model-file', 'm.yaml', '--json', 'bag/example_discrepancy_0.mcap', '--force'],
     'is inside the input bag'),
    (['import', 'logger.csv', 'logger.csv'], 'BAGDIR logger.csv: is the input logger.csv'),
    (['import', 'logger.csv', '.', '--force'], 'BAGDIR .: contains the input logger.csv'),
    (['simulate', '--bag', 'bag', '--model-file', 'bag/m.yaml', '--force'], '--bag bag: contains the input bag/m.yaml'),
    (['launch', '--bag', 'bag', '--model-file', 'bag/m.yaml', '--force'], '--bag bag: contains the input bag/m.yaml'),
    (['launch', '--bag', 'new', '--model-file', 'm.yaml', '--json', 'm.yaml', '--force'], 'm.yaml: is the input'),
])
def test_an_output_on_an_input_is_refused_and_the_input_kept(work, capsys, argv, message):
    before = snapshot(work)
    refused(argv, capsys, message)
    assert snapshot(work) == before


@pytest.mark.parametrize('argv, message', [
    (['identify', 'logger.csv', '--json', 'out', '--plot', 'out'], '--plot out: is the output --json out'),
    (['discrepancy', 'logger.csv', '--json', 'r/d.json', '--report', 'r'], '--report r: contains the output --json'),
    (['compare', 'logger.csv', '--model-file', 'm.yaml', '--json', 'o', '--plot', 'bag/../o'],
     '--plot bag/../o: is the output --json o'),
    (['scenario', 'mass_rise', '--json', 'o.json', '--plot', 'o.json'], '--plot o.json: is the output --json o.json'),
    (['launch', '--bag', 'new', '--json', 'new/summary.json'], '--bag new: contains the output --json'),
])
def test_two_outputs_on_one_path_are_refused(work, capsys, argv, message):
    before = snapshot(work)
    refused(argv, capsys, message)
    assert snapshot(work) == before


@pytest.mark.parametrize('command, flag', [
    (['identify', 'logger.csv'], '--json'), (['identify', 'logger.csv'], '--plot'),
    (['identify', 'logger.csv'], '--model-out'), (['discrepancy', 'logger.csv'], '--json'),
    (['discrepancy', 'logger.csv'], '--model-out'), (['compare', 'logger.csv', '--model-file', 'm.yaml'], '--json'),
    (['compare', 'logger.csv', '--model-file', 'm.yaml'], '--plot'), (['scenario', 'mass_rise'], '--json'),
    (['scenario', 'mass_rise'], '--plot'), (['launch'], '--json'),
])
def test_an_existing_output_is_refused_without_force(work, capsys, command, flag):
    (work / 'old').write_text('mine')
    before = snapshot(work)
    refused([*command, flag, 'old'], capsys, f'{flag} old: exists; choose another path, or --force')
    assert snapshot(work) == before


def test_force_replaces_existing_outputs_all_together(work, capsys):
    for name in ('out.json', 'out.png', 'out.yaml'):
        (work / name).write_text('old')
    assert cli.main(['identify', 'logger.csv', '--json', 'out.json', '--plot', 'out.png', '--model-out', 'out.yaml',
                     '--force']) == 0
    assert json.loads((work / 'out.json').read_text())['samples'] == 3000
    assert (work / 'out.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert (work / 'out.yaml').read_text().startswith('emla_model: 1')
    assert 'one-sigma' in capsys.readouterr().out and not list(work.glob('.*'))   # the summary table


def test_a_failed_output_leaves_every_existing_one_as_it_was(work, capsys, monkeypatch):
    """The plot fails after the model file is written (to its temporary): neither the model file nor the JSON
    is replaced, and no temporary is left."""
    import emla_cli.identify_plot

    def full_disk(path, *args):
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(emla_cli.identify_plot, 'save_convergence_plot', full_disk)
    for name in ('out.json', 'out.yaml'):
        (work / name).write_text('old')
    before = snapshot(work)
    refused(['identify', 'logger.csv', '--json', 'out.json', '--plot', 'out.png', '--model-out', 'out.yaml',
             '--force'], capsys, 'out.png: cannot write: No space left on device')
    assert snapshot(work) == before


def test_force_replaces_a_previous_report_and_nothing_else(work, capsys):
    (work / 'notes').mkdir()
    (work / 'notes' / 'keep.txt').write_text('mine')
    before = snapshot(work)
    refused(['discrepancy', 'logger.csv', '--report', 'notes', '--force'], capsys,
            '--report notes: --force replaces only an output emla wrote (.emla-output in it)')
    assert snapshot(work) == before
    assert cli.main(['discrepancy', 'logger.csv', '--report', 'report', '--json', 'd.json']) == 0
    (work / 'report' / 'mine.txt').write_text('a note of the user')
    refused(['discrepancy', 'logger.csv', '--report', 'report'], capsys, '--report report: exists')
    before = snapshot(work)
    refused(['discrepancy', 'logger.csv', '--report', 'report', '--force'], capsys,
            '--report report: holds files emla did not write (mine.txt)')
    assert snapshot(work) == before
    (work / 'report' / 'mine.txt').unlink()
    assert cli.main(['discrepancy', 'logger.csv', '--report', 'report', '--json', 'd.json', '--force']) == 0
    report = sorted(p.name for p in (work / 'report').iterdir())
    assert report == ['.emla-output', 'correlation.png', 'diagnosis.json', 'disagreement.png', 'gap.png', 'report.md',
                      'residuals.png']
    assert json.loads((work / 'report' / 'diagnosis.json').read_text()) == json.loads((work / 'd.json').read_text())
    assert not list(work.glob('.*'))


def test_an_existing_bag_needs_force_and_is_the_only_directory_replaced(work, capsys):
    before = snapshot(work)
    refused(['import', 'logger.csv', 'bag'], capsys, 'BAGDIR bag: exists; choose another path, or --force')
    refused(['simulate', '--bag', '.', '--force'], capsys, '--bag .: is or holds the working directory')
    refused(['import', 'logger.csv', 'bag', '--force'], capsys, 'BAGDIR bag: --force replaces only an output emla')
    assert snapshot(work) == before


@pytest.mark.parametrize('kind', ['fifo', 'device', 'directory'])
def test_an_output_that_is_no_regular_file_is_refused_even_with_force(work, capsys, kind):
    if kind == 'fifo':
        target = work / 'pipe'
        os.mkfifo(target)
    elif kind == 'device':
        target = '/dev/null'
    else:
        target = work / 'bag'
    mode = os.stat(target).st_mode
    before = snapshot(work)
    refused(['identify', 'logger.csv', '--json', str(target), '--force'], capsys, f'--json {target}: is a ')
    refused(['import', 'logger.csv', '/dev/null', '--force'], capsys, 'BAGDIR /dev/null: is a device')
    assert os.stat(target).st_mode == mode and stat.S_ISCHR(os.stat('/dev/null').st_mode)
    assert snapshot(work) == before


@pytest.mark.parametrize('stdout', ['/dev/full', 'closed pipe'])
def test_stdout_that_cannot_take_the_json_is_one_line_and_exit_2(stdout):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    if stdout == '/dev/full':
        sink = open('/dev/full', 'wb')
    else:
        read, write = os.pipe()
        os.close(read)
        sink = os.fdopen(write, 'wb')
    with sink:
        out = subprocess.run([sys.executable, '-m', 'emla_cli.cli', 'identify', str(EXAMPLES / 'logger.csv')],
                             stdout=sink, stderr=subprocess.PIPE, text=True, env=env, timeout=120)
    reason = 'No space left on device' if stdout == '/dev/full' else 'Broken pipe'
    assert out.returncode == 2
    assert out.stderr == f'emla identify: error: cannot write to stdout: {reason}\n'


@pytest.mark.parametrize('error', [MemoryError, RecursionError])
def test_memory_and_recursion_errors_are_one_line_as_a_last_resort(monkeypatch, capsys, error):
    def fail(args):
        raise error()

    monkeypatch.setattr(identify_command, 'run', fail)
    assert cli.main(['identify', 'x.csv']) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and f'({error.__name__}); a bug in emla' in err, err
