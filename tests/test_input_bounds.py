"""Issue 53 (round 2), the inputs: model files read strictly and alike by every command, size bounds on the
documents read whole, a long run's options that overflow, and stamps past what a ROS time stamp holds. Each case
is one line on stderr and exit status 2, found before any work (a few seconds in all)."""
import json
import os
import shutil
import time
from pathlib import Path

import pytest
import yaml

from emla_cli.cli import main
from emla_core.errors import InputError
from emla_core.limits import MAX_DOCUMENT_BYTES, MAX_STAMP_NS
from emla_core.model_file import Model, read, write
from emla_core.parameters import TABLE1

EXAMPLE = Path(__file__).resolve().parents[1] / 'docs' / 'examples' / 'logger.csv'
TS = 1e-4


def one_line(capsys, argv, words):
    """`emla ARGV` in this process ends with status 2 and one stderr line holding `words`."""
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and words in err[0] and 'a bug in emla' not in err[0], (status, err)
    return err[0]


@pytest.fixture
def good(tmp_path):
    """(a complete moving coil's model file, its text, a short record)."""
    path = tmp_path / 'm.yaml'
    write(Model(TS, {k: (v, 0.01) for k, v in TABLE1.physical().items()}), path)
    data = tmp_path / 'logger.csv'
    shutil.copy(EXAMPLE, data)
    return path, path.read_text(), data


def sparse(path, size):
    """A file of `size` bytes that takes no room (os.truncate)."""
    path.touch()
    os.truncate(path, size)
    return path


# ---- 1. model files: strict YAML, and one completeness rule for every command ----

def _variants(text):
    """{name: (model file text, words of its one line)} of what a model file must not be read as."""
    lines = text.splitlines(keepends=True)
    at = next(k for k, line in enumerate(lines) if line.strip() == 'inductance:')
    duplicated = ''.join(lines[:at] + ['  resistance:\n', '    value: 40.0\n', '    std: 0.1\n'] + lines[at:])
    return {
        'duplicate key': (duplicated, "'resistance' is given twice (first on line"),
        'base-60 float': (text.replace('sample_period: 0.0001', 'sample_period: 1:30.0'), 'not a plain decimal'),
        'base-60 int': (text.replace('value: 2.0', 'value: 1:30', 1), "'1:30' is not a plain decimal number "
                                                                       '(YAML 1.1 reads it as 90)'),
        'octal': (text.replace('value: 2.0', 'value: 010', 1), "'010' is not a plain decimal number"),
        'bool version': (text.replace('emla_model: 1', 'emla_model: true'), 'emla_model must be the format version'),
        'float version': (text.replace('emla_model: 1', 'emla_model: 1.0'), 'emla_model must be the format version'),
        'resistance only': ('emla_model: 1\nsample_period: 0.0001\nparameters: {resistance: 5.0}\n',
                            'a moving_coil model needs inductance, emf_constant (a model file gives every parameter'),
        'no parameters': ('emla_model: 1\nsample_period: 0.0001\n', 'a moving_coil model needs resistance'),
        '5000-digit integer': (text.replace('value: 2.0', 'value: 1' + '0' * 5000, 1), 'a number of 5001'),
        'a date that is none': (text.replace('provenance: {}', 'provenance: {date: 2024-13-01}'), 'not a date'),
    }


def test_a_complete_model_file_reads_and_the_suite_writes_no_other(good, tmp_path):
    path, text, _ = good
    assert read(path).values() == TABLE1.physical()
    assert all(body != text for body, _ in _variants(text).values())
    with pytest.raises(InputError, match='lacks inductance'):
        write(Model(TS, {'resistance': (4.0, None)}), tmp_path / 'partial.yaml')
    assert not (tmp_path / 'partial.yaml').exists()


@pytest.mark.parametrize('variant', ['duplicate key', 'base-60 float', 'base-60 int', 'octal', 'bool version',
                                     'float version', 'resistance only', 'no parameters', '5000-digit integer',
                                     'a date that is none'])
def test_a_model_file_yaml_misreads_or_that_lacks_a_parameter_is_refused_by_every_command(good, tmp_path, capsys,
                                                                                           variant):
    """simulate (filled R = 40 or Table 1 in), compare, identify --model-file, trend --model-file and launch
    (through simulate's scenario arguments) refuse the same file in the same line."""
    _, text, data = good
    body, words = _variants(text)[variant]
    bad = tmp_path / 'bad.yaml'
    bad.write_text(body)
    with pytest.raises(InputError, match='bad.yaml: ') as refused:
        read(bad)
    assert words in str(refused.value) and '\n' not in str(refused.value)
    lines = {one_line(capsys, argv, words) for argv in (
        ['simulate', '--model-file', bad, '--duration', '0.01', '--bag', tmp_path / 'B'],
        ['compare', data, '--model-file', bad],
        ['identify', data, '--model-file', bad],
        ['trend', data, '--model-file', bad])}
    assert len({line.split(': error: ', 1)[1] for line in lines}) == 1, lines   # alike
    assert not (tmp_path / 'B').exists()


# ---- 2. size bounds on the documents read whole, and their nesting ----

def test_oversized_documents_are_refused_before_they_are_read(good, tmp_path, capsys):
    """A 5 GiB sparse model file, --observer-from JSON and params file: refused from os.stat at once (a 3 GiB
    one took 22 s, an 8 GiB one ran out of memory)."""
    _, _, data = good
    from emla_core.nodes.params_file import read_params_files
    start = time.monotonic()
    huge = sparse(tmp_path / 'huge.yaml', 5 << 30)
    with pytest.raises(InputError, match='more than the 4 MiB a model file may have'):
        read(huge)
    one_line(capsys, ['simulate', '--model-file', huge, '--bag', tmp_path / 'B'], 'a model file may have')
    one_line(capsys, ['identify', data, '--actuator', 'solenoid', '--observer-from',
                      sparse(tmp_path / 'f.json', 5 << 30), '--position-out', tmp_path / 'p.csv'],
             'a JSON file may have')
    with pytest.raises(InputError, match='a params file may have'):
        read_params_files(['emla-plant', '--ros-args', '--params-file', str(sparse(tmp_path / 'p.yaml', 5 << 30))])
    assert time.monotonic() - start < 20
    just = tmp_path / 'just.yaml'   # the bound itself is no refusal of size
    just.write_text('emla_model: 1\n' + ' ' * (MAX_DOCUMENT_BYTES - 14))
    with pytest.raises(InputError, match='sample_period must be a finite number'):
        read(just)


def test_deeply_nested_documents_are_one_clear_line(good, tmp_path, capsys):
    _, _, data = good
    deep = tmp_path / 'deep.json'
    deep.write_text('[' * 100000)
    one_line(capsys, ['identify', data, '--actuator', 'solenoid', '--observer-from', deep,
                      '--position-out', tmp_path / 'p.csv'], 'cannot read it as JSON (nested too deeply)')
    big = tmp_path / 'big.json'
    big.write_text(json.dumps({'model': 'solenoid', 'parameters': {'resistance': 10 ** 4000}}).replace(
        '1' + '0' * 4000, '1' + '0' * 5000))
    one_line(capsys, ['identify', data, '--actuator', 'solenoid', '--observer-from', big,
                      '--position-out', tmp_path / 'p.csv'], 'solenoid')
    model = tmp_path / 'deep.yaml'
    model.write_text('emla_model: 1\nprovenance: ' + '[' * 100000 + '\n')
    with pytest.raises(InputError, match='nested too deeply to be a model file'):
        read(model)
    assert not (tmp_path / 'p.csv').exists()


# ---- 3. a long run's options that overflow ----

@pytest.mark.parametrize('options, words', [
    (['--hours', '2', '--step', 'damping=1e308@1'], 'damping would be inf N s/m at hour 1, outside [0, 1e+09]'),
    (['--hours', '2', '--step', 'mass=1e-300@0'], 'mass would be'),
    (['--hours', '1e6', '--every', '2.5e5', '--duration', '0.01'], 'past the 2147483648 s (2038-01-19 03:14:08 UTC)'),
])
def test_a_long_run_that_overflows_is_one_line(tmp_path, capsys, options, words):
    one_line(capsys, ['simulate', '--fleet', tmp_path / 'F', *options], words)
    assert not (tmp_path / 'F').exists()


def test_the_long_run_checks_its_parameters_and_its_last_start():
    from emla_bench.fleet import HOUR, long_run, parse_step
    with pytest.raises(InputError, match='damping would be inf'):
        long_run(TABLE1, 2, 1, steps=(parse_step('damping=1e308@1'),))
    last = (2**31 - 1) // HOUR   # the last whole hour a stamp holds
    assert long_run(TABLE1, last + 1, last)[-1][0] == last * HOUR
    with pytest.raises(InputError, match='--hours'):
        long_run(TABLE1, last + 2, last + 1)


# ---- 4. stamps past 2^31 s ----

def test_a_stamp_past_what_a_ros_time_holds_is_refused_and_the_last_one_is_stored_right():
    from emla_core.messages import frame_cdr, frame_message, read_frame_cdr, time_msg
    stamp = time_msg(MAX_STAMP_NS)
    assert (stamp.sec, stamp.nanosec) == (2**31 - 1, 999_999_999)
    assert read_frame_cdr(frame_cdr(MAX_STAMP_NS, TS, [1.0]))[0] == MAX_STAMP_NS
    for build in (time_msg, lambda ns: frame_message(ns, TS, [1.0]), lambda ns: frame_cdr(ns, TS, [1.0])):
        for ns in (MAX_STAMP_NS + 1, int(2.2e18), -1):
            with pytest.raises(InputError, match=r'a ROS time stamp holds 0 to 2147483648 s \(2038-01-19'):
                build(ns)


def test_a_csv_whose_time_runs_past_2038_is_not_imported_with_wrapped_stamps(tmp_path, capsys):
    """It imported with exit 0 and sec = -2094967296."""
    late = tmp_path / 'late.csv'
    late.write_text('time,voltage,current,position\n' + ''.join(
        f'{2.2e9 + k * 1e-3!r},1.0,0.1,0.0\n' for k in range(50)))
    one_line(capsys, ['import', late, tmp_path / 'B'], 'the data run to t = 2200000000')
    assert not (tmp_path / 'B').exists()
    early = tmp_path / 'early.csv'   # within the limit: stamped as it is
    early.write_text('time,voltage,current,position\n' + ''.join(
        f'{2.1e9 + k * 1e-3!r},1.0,0.1,0.0\n' for k in range(50)))
    assert main(['import', str(early), str(tmp_path / 'C')]) == 0
    capsys.readouterr()
    from emla_core.bag import read_bag
    assert read_bag(tmp_path / 'C').recording.start_time == pytest.approx(2.1e9)


def test_the_strict_loader_leaves_plain_yaml_as_it_was():
    from emla_core.model_file import StrictLoader
    text = 'a: 1\nb: -2.5e-3\nc: .inf\nd: 1e-4\ne: [x, 0]\nf: {g: true}\n'
    assert yaml.load(text, Loader=StrictLoader) == yaml.safe_load(text)
    assert yaml.safe_load('a: 1:30') == {'a': 90}   # SafeLoader itself is left alone


def test_a_model_file_of_one_equation_is_read_but_not_simulated(tmp_path, capsys):
    """What `identify --model electrical --model-out` writes is a model file compare and identify read; a plant
    needs every parameter, so simulate refuses it in one line (no value filled in from Table 1)."""
    electrical = tmp_path / 'e.yaml'
    electrical.write_text('emla_model: 1\nsample_period: 0.0001\n'
                          'parameters: {resistance: 4.0, inductance: 0.002, emf_constant: 10.0}\n')
    assert read(electrical).missing() == [] and read(electrical).missing(whole=True) == ['mass', 'damping',
                                                                                         'load_force']
    assert main(['simulate', '--bag', str(tmp_path / 'b'), '--model-file', str(electrical)]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'simulating it needs every parameter, and it lacks mass, damping' in err
    assert not (tmp_path / 'b').exists()
