"""Options and params files (issue 19): every numeric option that is not finite or out of its range is one line
and exit 2 before any work (some hung: `echo --timeout nan`, `play --rate 1e-9`); a params file with a typo (a
parameter or a node name) is refused by the node, naming it and the closest known name; inputs that gave
tracebacks (an import onto itself or /dev/null, a bad topic name, a deeply nested params file) are one line;
a launch whose plant is stopped fails at once (it waited a minute, then called the run stalled)."""
import importlib
import os
import signal
import subprocess
import time

import pytest
import yaml
from independent_data import EXAMPLES
from ros_isolation import REPO, VENV_BIN, processes
from test_launch import children

from emla_cli import cli
from emla_cli.launcher import SHM, remove_unused_shm, stale_shm_files
from emla_core.nodes.params_file import matches, section_names

pytestmark = pytest.mark.timeout(120)
EMLA = str(VENV_BIN / 'emla')
BAG = str(REPO / 'bags' / 'example_discrepancy')
CSV = str(EXAMPLES / 'logger.csv')
NODES = {'plant': ('emla_sim', 'plant_node'), 'sensor': ('emla_sim', 'sensor_node'),
         'identifier': ('emla_identification', 'identifier_node'), 'controller': ('emla_control', 'controller_node'),
         'recorder': ('emla_core', 'recorder_node')}


def one_line(argv, capsys, start):
    """Run `emla argv` in this process: exit 2, nothing on stdout, one line on stderr starting with `start`."""
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and captured.err.count('\n') == 1, captured
    assert captured.err.startswith(start), captured.err
    return captured.err


# (command line before the option, option, values refused)
NUMERIC = [
    (['echo', '/emla/parameters'], '--timeout', ['nan', 'inf', '-inf', '0', '-1', '1e9', 'soon']),
    (['echo', '/emla/parameters'], '--count', ['-1', '1.5', 'nan', '1e12']),
    (['echo', '/emla/parameters'], '--truncate-length', ['-1', 'inf', 'all']),
    (['play', BAG], '--rate', ['nan', 'inf', '-1', '1e-9', '0.001', '1e9']),
    (['play', BAG], '--wait', ['nan', 'inf', '-1', '1e9']),
    (['simulate', '--bag', 'new'], '--duration', ['nan', 'inf', '0', '-1', '0.005', '1e-320', '1e9', '601']),
    (['launch', '--bag', 'new'], '--duration', ['nan', 'inf', '0', '-1', '1e9', '3601']),
    (['identify', CSV], '--forgetting', ['nan', 'inf', '1e-300', '0', '0.4', '1.5', '-1']),
    (['identify', CSV], '--memory-time', ['nan', 'inf', '0', '-1', '1e9']),
    (['identify', CSV], '--sample-period', ['nan', 'inf', '0', '-1', '1e-12', '1e9']),
    (['discrepancy', CSV], '--sample-period', ['nan', '0']),
    (['compare', CSV, '--model-file', 'm.yaml'], '--sample-period', ['inf']),
    (['import', CSV, 'new'], '--sample-period', ['-1']),
]


@pytest.mark.parametrize('argv, option, value', [(argv, option, value) for argv, option, values in NUMERIC
                                                  for value in values])
def test_a_numeric_option_not_finite_or_out_of_range_is_one_line(tmp_path, monkeypatch, capsys, argv, option, value):
    monkeypatch.chdir(tmp_path)
    err = one_line([*argv, f'{option}={value}'], capsys, f'emla {argv[0]}: error: {option} {value}: must be ')
    assert ' in [' in err or ' in (' in err          # the range is said
    assert list(tmp_path.iterdir()) == []            # and nothing written


def test_the_arx_orders_are_bounded(capsys):
    err = one_line(['identify', CSV, '--model', 'arx', '--orders', '200000', '2', '1'], capsys,
                   'emla identify: error: --orders 200000 2 1: need')
    assert 'NA, NB <= 100' in err


@pytest.mark.parametrize('argv', [
    ['echo', '/x', '--timeout', 'nan'],
    ['play', BAG, '--rate', '1e-9', '--wait', '0'],
    ['simulate', '--duration', '1e9', '--bag', 'new'],
])
def test_the_options_that_hung_end_at_once(tmp_path, argv):
    started = time.monotonic()
    run = subprocess.run([EMLA, *argv], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 2 and run.stderr.count('\n') == 1 and 'must be' in run.stderr, run.stderr
    assert time.monotonic() - started < 30


def test_a_usage_error_is_one_line(capsys):
    one_line(['identify'], capsys, 'emla identify: error: the following arguments are required: DATA')


@pytest.mark.parametrize('argv, message', [
    (['echo', 'bad topic!!'], "'bad topic!!' is not a topic name"),
    (['import', 'run.csv', 'run.csv'], 'BAGDIR run.csv: is the input run.csv'),
    (['import', 'run.csv', '/dev/null'], 'BAGDIR /dev/null: is a device'),
])
def test_inputs_that_gave_tracebacks_are_one_line(tmp_path, monkeypatch, capsys, argv, message):
    (tmp_path / 'run.csv').write_bytes(open(CSV, 'rb').read())
    monkeypatch.chdir(tmp_path)
    assert message in one_line(argv, capsys, f'emla {argv[0]}: error: ')


# ---- params files ----

@pytest.mark.parametrize('section, node, applies', [
    ('/emla/identifier', '/emla/identifier', True),
    ('emla/identifier', '/emla/identifier', True),
    ('/**', '/emla/identifier', True),
    ('/**/identifier', '/emla/identifier', True),
    ('/emla/*', '/emla/identifier', True),
    ('/*', '/emla/identifier', False),
    ('/emla/identifer', '/emla/identifier', False),
    ('/identifier', '/emla/identifier', False),
])
def test_sections_apply_as_rcl_reads_them(section, node, applies):
    assert matches(section, node) is applies


def test_nested_sections_are_named_by_their_namespaces():
    tree = yaml.safe_load('emla:\n  identifier:\n    ros__parameters: {}\n/**:\n  ros__parameters: {}\n')
    assert section_names(tree) == ['/emla/identifier', '/**']


@pytest.mark.parametrize('node', sorted(NODES))
def test_the_packages_params_files_hold_only_declared_parameters(node):
    package, module = NODES[node]
    specs = importlib.import_module(f'{package}.nodes.{module}').SPECS
    config = yaml.safe_load((REPO / package / 'config' / f'{node}.yaml').read_text())
    assert set(config[f'/emla/{node}']['ros__parameters']) <= {spec.name for spec in specs}


@pytest.mark.parametrize('text, message', [
    ('/emla/identifier:\n  ros__parameters: {forgeting: 0.99}\n',
     "unknown parameter 'forgeting' for /emla/identifier (did you mean 'forgetting'?); "
     "its parameters: actuator, current_noise, effects"),
    ('/**:\n  ros__parameters: {modle: arx}\n',
     "unknown parameter 'modle' for /emla/identifier (did you mean 'model'?)"),
    ('/emla/identifer:\n  ros__parameters: {forgetting: 0.99}\n',
     "section '/emla/identifer' is for no node of the suite (did you mean '/emla/identifier'?); nodes: "),
    ('/emla/identifier:\n  ros__parameters: {effects: ' + '[' * 50000 + ']' * 50000 + '}\n',
     'nested too deeply to be a params file'),
    ('/emla/identifier:\n  ros__parameters: {model: arx, orders: [200000, 2, 1]}\n',
     'ARX order na must be an integer in [0, 100], got 200000'),
])
def test_a_params_file_with_a_typo_is_refused_in_one_line(tmp_path, text, message):
    path = tmp_path / 'identifier.yaml'
    path.write_text(text)
    with processes() as start:
        node = start([EMLA, 'run', 'identifier', '--params-file', str(path)])
        code = node.wait(timeout=60)
        err = node.stderr.read()
    assert code == 2 and err.count('\n') == 1 and message in err, err


def test_a_launch_whose_plant_is_stopped_fails_at_once(tmp_path):
    """A plant stopped by a signal exits 0 (as every node); the launcher sees no done signal come and says so
    within DONE_GRACE, where it waited STALL_TIMEOUT (60 s) and called the run stalled."""
    bag = tmp_path / 'bag'
    with processes() as start:
        launch = start([EMLA, 'launch', '--duration', '60', '--bag', str(bag)])
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob('.bag.emla-partial/bag/*.mcap')):          # the graph runs
            assert launch.poll() is None and time.monotonic() < deadline, launch.communicate()[1]
            time.sleep(0.1)
        plant = next(pid for pid, args in children(launch.pid).items() if args[2:4] == ['run', 'plant'])
        os.kill(plant, signal.SIGINT)
        stopped = time.monotonic()
        _, err = launch.communicate(timeout=60)
    assert launch.returncode == 1 and time.monotonic() - stopped < 20
    lines = [line for line in err.replace('\r', '\n').splitlines() if line.startswith('emla launch:')]
    assert len(lines) == 1 and f'plant (pid {plant}) exited with status 0' in lines[0], err
    assert 'it stopped before the end of the run' in lines[0]


def test_a_dead_launch_s_shared_memory_files_go_at_the_next_start():
    stale, fresh = SHM / f'fastrtps_emla_test_{os.getpid()}', SHM / f'fastrtps_emla_test_{os.getpid()}_new'
    for path in (stale, fresh):
        path.write_bytes(b'\0' * 64)
    old = time.time() - 3600
    os.utime(stale, (old, old))
    try:
        remove_unused_shm(stale_shm_files())
        assert not stale.exists() and fresh.exists()
    finally:
        for path in (stale, fresh):
            path.unlink(missing_ok=True)
