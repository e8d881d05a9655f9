"""Fuzz (issue 19): seeded mutations of every kind of input the commands read - CSV and MAT files, bags (their
MCAP file or metadata.yaml), model files, params files, numeric option values - run through `emla` in this
process (each case in a child forked from it: a crash or a hang is a finding, not the end of the run). For each
one: no traceback and no exception but SystemExit, exit status 0 or 2, no input file changed, within CASE_TIMEOUT
s, in MEMORY_LIMIT bytes of address space.

EMLA_FUZZ_CASES sets the number of cases (default 2000; `make test` runs 150, `make sweep` 20000) and
EMLA_FUZZ_SEED the seed (default 0): case k of a seed is the same input and command line on every run, so a
finding is replayed by its seed and case (EMLA_FUZZ_FIRST=k EMLA_FUZZ_CASES=1). Inputs of failing cases are kept
under EMLA_FUZZ_KEEP (a directory) when it is set.
"""
import collections
import contextlib
import hashlib
import io
import json
import os
import random
import re
import resource
import select
import shutil
import signal
import traceback
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from independent_data import EXAMPLES
from ros_isolation import REPO

from emla_cli import cli
from emla_cli.commands import run_node
from emla_core.errors import InputError
from emla_core.nodes import params_file

CASES = int(os.environ.get('EMLA_FUZZ_CASES', '2000'))
SEED = int(os.environ.get('EMLA_FUZZ_SEED', '0'))
FIRST = int(os.environ.get('EMLA_FUZZ_FIRST', '0'))
KEEP = os.environ.get('EMLA_FUZZ_KEEP')
CASE_TIMEOUT = 30              # s for one case: longer is a hang
MEMORY_LIMIT = 12 * 2 ** 30    # bytes of address space: a mutation that allocates without bound fails, not the host
SHORT, LONG = 120, 500         # samples of the small record (fast to identify) and of one long enough for discrepancy
MAT_COLUMNS = ['--columns', 't=time,voltage=coil_voltage,current=coil_current,position=stroke']
pytestmark = pytest.mark.timeout(max(600, CASES))

EXTREMES = ['nan', 'NaN', 'inf', '-inf', '1e308', '-1e308', '1e-320', '0', '-0', '1e400', '9' * 30, '', ' ', '0x10',
            '1,5', '--1', 'null', '~', 'true', '1e9', '-1e9', '1e-9', '[]', '{}', '"1"']
ODD_HEADERS = ['', 't,t,t,t', 'time_ms,u_V,i_mA', 'time_ms,u_V,i_mA,x_mm,extra', '\ufefftime_ms,u_V,i_mA,x_mm',
               '"time_ms","u_V","i_mA","x_mm"', 'time [furlong],u [V],i [A],x [m]', 'a,b,c,d',
               't;voltage;current;position', 't\tvoltage\tcurrent\tposition', 'voltage,current,position,t',
               'x_mm,x_mm,x_mm,x_mm', ',,,', '1,2,3,4', 'time_ms,u_V,i_mA,x_' + 'm' * 10000,
               't,voltage,current,position,force,velocity', 't,force,position', '# comment', '"t,voltage",current']
SPECIAL_BYTES = [b'\0', b'\xff', b'\n', b'\r\n', b',', b';', b'"', b'\xef\xbb\xbf', b'\t', b'-', b'.', b'e', b'\x80',
                 b': ', b'[', b'{', b'&a ', b'*a', b'!!python/object ']


# ---- mutations: (rng, bytes) -> (bytes, what) ----

def flip_bits(rng, data):
    data = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        if data:
            k = rng.randrange(len(data))
            data[k] ^= 1 << rng.randrange(8)
    return bytes(data), 'bit flips'


def truncate(rng, data):
    cut = rng.randrange(len(data) + 1)
    return data[:cut], f'truncated at {cut}'


def insert_bytes(rng, data):
    at = rng.randrange(len(data) + 1)
    if rng.random() < 0.7:
        chunk = rng.choice(SPECIAL_BYTES) * rng.choice((1, 2, 100))
    else:
        chunk = rng.randbytes(rng.randint(1, 64))
    return data[:at] + chunk + data[at:], f'{len(chunk)} bytes inserted at {at}'


def delete_range(rng, data):
    at = rng.randrange(len(data) + 1)
    n = rng.randint(1, 256)
    return data[:at] + data[at + n:], f'{n} bytes deleted at {at}'


def duplicate_range(rng, data):
    at, n = rng.randrange(len(data) + 1), rng.randint(1, 4096)
    to = rng.randrange(len(data) + 1)
    return data[:to] + data[at:at + n] + data[to:], f'{n} bytes from {at} copied to {to}'


def _tokens(text):
    """Start and end of each number-like token of `text`."""
    return [m.span() for m in re.finditer(r'-?\d+(\.\d*)?([eE][-+]?\d+)?', text)]


def extreme_number(rng, data):
    text = data.decode('utf-8', 'replace')
    spans = _tokens(text)
    if not spans:
        return data, 'no number'
    for _ in range(rng.randint(1, 4)):
        start, end = rng.choice(spans)
        value = rng.choice(EXTREMES)
        text = text[:start] + value + text[end:]
        spans = _tokens(text)
        if not spans:
            break
    return text.encode(), 'extreme numbers'


def swap_fields(rng, data):
    """Two fields swapped: cells of a CSV line, or the values of two `key: value` lines of YAML."""
    lines = data.split(b'\n')
    k = rng.randrange(len(lines))
    if b',' in lines[k]:
        cells = lines[k].split(b',')
        i, j = rng.randrange(len(cells)), rng.randrange(len(cells))
        cells[i], cells[j] = cells[j], cells[i]
        lines[k] = b','.join(cells)
        return b'\n'.join(lines), f'cells {i} and {j} of line {k} swapped'
    keyed = [i for i, line in enumerate(lines) if b': ' in line]
    if len(keyed) < 2:
        return data, 'nothing to swap'
    i, j = rng.sample(keyed, 2)
    (ki, vi), (kj, vj) = lines[i].split(b': ', 1), lines[j].split(b': ', 1)
    lines[i], lines[j] = ki + b': ' + vj, kj + b': ' + vi
    return b'\n'.join(lines), f'values of lines {i} and {j} swapped'


def odd_header(rng, data):
    header = rng.choice(ODD_HEADERS)
    rest = data.split(b'\n', 1)[1] if b'\n' in data else b''
    return header.encode() + b'\n' + rest, f'header {header[:40]!r}'


def line_edit(rng, data):
    """A line deleted, duplicated, blanked or re-indented (CSV rows, YAML structure)."""
    lines = data.split(b'\n')
    k = rng.randrange(len(lines))
    how = rng.choice(('deleted', 'duplicated', 'blanked', 'indented', 'dedented'))
    if how == 'deleted':
        del lines[k]
    elif how == 'duplicated':
        lines.insert(k, lines[k])
    elif how == 'blanked':
        lines[k] = b''
    elif how == 'indented':
        lines[k] = b'  ' + lines[k]
    else:
        lines[k] = lines[k].lstrip()
    return b'\n'.join(lines), f'line {k} {how}'


def yaml_value(rng, data):
    """A YAML value replaced by a deep nesting, an alias bomb, another type or a tag."""
    lines = data.split(b'\n')
    keyed = [i for i, line in enumerate(lines) if b': ' in line]
    if not keyed:
        return data, 'no value'
    k = rng.choice(keyed)
    depth = rng.choice((10, 100, 1000, 100_000))
    value = rng.choice([b'[' * depth + b']' * depth, b'{a: ' * depth + b'1' + b'}' * depth,
                        b'*bomb', b'[1, 2, 3]', b'{x: 1}', b'!!binary AAAA', b'!!python/name:os.system',
                        b'"' + b'9' * 5000 + b'"', b'&anchor 1', b'', b'|\n  text'])
    key = lines[k].split(b': ', 1)[0]
    lines[k] = key + b': ' + value
    prefix = b''
    if value == b'*bomb':
        layers = [b'bomb0: &bomb0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]']
        layers += [b'bomb%d: &bomb%d [' % (i, i) + b', '.join([b'*bomb%d' % (i - 1)] * 10) + b']' for i in range(1, 9)]
        prefix = b'\n'.join(layers).replace(b'&bomb8', b'&bomb') + b'\n'
    return prefix + b'\n'.join(lines), f'value of line {k}: {value[:30]!r}'


BINARY = (flip_bits, truncate, insert_bytes, delete_range, duplicate_range)
TEXT = BINARY + (extreme_number, extreme_number, swap_fields, line_edit)
MUTATIONS = {'csv': TEXT + (odd_header, odd_header), 'mat': BINARY, 'mcap': BINARY,
             'yaml': TEXT + (yaml_value, yaml_value)}


def mutate(rng, data, kind):
    """`data` changed by one to three mutations of its kind; (bytes, what was done)."""
    done = []
    for _ in range(rng.choice((1, 1, 2, 3))):
        data, what = rng.choice(MUTATIONS[kind])(rng, data)
        done.append(what)
    return data, '; '.join(done)


# ---- the seeds: one of each input, made by the suite's own commands ----

def quiet(argv):
    """`emla argv` in this process with its output discarded; asserts it succeeds."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
        assert cli.main([str(a) for a in argv]) == 0, err.getvalue()


def write_si_csv(path, rows):
    """The example logger's first `rows` samples as a CSV of the suite's names in SI units."""
    data = np.loadtxt(EXAMPLES / 'logger.csv', delimiter=',', skiprows=1, max_rows=rows)
    si = np.column_stack((data[:, 0] * 1e-3, data[:, 1], data[:, 2] * 1e-3, data[:, 3] * 1e-3))
    np.savetxt(path, si, delimiter=',', header='t,voltage,current,position', comments='', fmt='%.9g')
    return si


@pytest.fixture(scope='module')
def seeds(tmp_path_factory):
    """{name: path} of the unmutated inputs."""
    folder = tmp_path_factory.mktemp('seeds')
    si = write_si_csv(folder / 'short.csv', SHORT)
    write_si_csv(folder / 'long.csv', LONG)
    (folder / 'logger.csv').write_bytes(b'\n'.join((EXAMPLES / 'logger.csv').read_bytes().split(b'\n')[:SHORT + 1]))
    columns = dict(zip(('time', 'coil_voltage', 'coil_current', 'stroke'), si.T, strict=True))
    scipy.io.savemat(folder / 'scope.mat', columns)
    scipy.io.savemat(folder / 'zipped.mat', columns, do_compression=True)
    quiet(['simulate', '--duration', SHORT * 1e-4, '--bag', folder / 'simulated'])
    quiet(['import', folder / 'short.csv', folder / 'imported'])
    quiet(['identify', folder / 'long.csv', '--model-out', folder / 'nominal.yaml', '--json', folder / 'i.json'])
    shutil.copytree(REPO / 'bags' / 'example_discrepancy', folder / 'discrepancy')
    quiet(['discrepancy', folder / 'discrepancy', '--model-out', folder / 'friction.yaml', '--json', folder / 'd.json'])
    for node, package in (('identifier', 'emla_identification'), ('plant', 'emla_sim')):
        shutil.copy(REPO / package / 'config' / f'{node}.yaml', folder / f'{node}.yaml')
    paths = {path.stem: path for path in folder.iterdir()}
    warm_up(paths, tmp_path_factory.mktemp('warm'))
    return paths


def warm_up(seeds, out):
    """Run each command's path once here, so that the forked cases find its modules loaded and compiled (a child's
    compilation is lost with it), and without tqdm's monitor thread (a lock it holds at a fork would hang the
    child)."""
    import tqdm
    tqdm.tqdm.monitor_interval = 0
    for argv in (['identify', seeds['short']], ['identify', seeds['short'], '--model', 'electrical'],
                 ['identify', seeds['short'], '--model', 'arx'], ['identify', seeds['scope'], *MAT_COLUMNS],
                 ['identify', seeds['long'], '--model-file', seeds['friction']],
                 ['compare', seeds['long'], '--model-file', seeds['friction']],
                 ['simulate', '--duration', '0.01', '--bag', out / 'bag', '--model-file', seeds['friction']]):
        quiet(argv)


# ---- the cases ----

def commands(rng, kind, path, seeds, out):
    """The command lines that read `path`, an input of `kind`; outputs go under `out`."""
    model = seeds[rng.choice(('nominal', 'friction'))]
    if kind == 'csv':
        return [['identify', path], ['identify', path, '--model', 'electrical'], ['identify', path, '--model', 'arx'],
                ['identify', path, '--json', out / 'r.json', '--model-out', out / 'm.yaml'],
                ['import', path, out / 'bag'], ['compare', path, '--model-file', model], ['discrepancy', path]]
    if kind == 'mat':
        return [['identify', path, *MAT_COLUMNS], ['import', path, out / 'bag', *MAT_COLUMNS],
                ['identify', path, '--columns', 'voltage=coil_voltage,current=coil_current,position=stroke',
                 '--sample-period', '1e-4']]
    if kind == 'bag':
        return [['identify', path], ['import', path, out / 'bag'], ['compare', path, '--model-file', model]]
    return [['identify', seeds['long'], '--model-file', path], ['compare', seeds['long'], '--model-file', path],
            ['simulate', '--duration', '0.01', '--bag', out / 'bag', '--model-file', path]]


OPTIONS = [('identify', '--forgetting'), ('identify', '--memory-time'), ('identify', '--sample-period'),
           ('import', '--sample-period'), ('simulate', '--duration'), ('compare', '--sample-period'),
           ('identify', '--units'), ('identify', '--orders')]


def option_case(rng, seeds, out):
    """A command line with an extreme value of an option (no input mutated)."""
    command, option = rng.choice(OPTIONS)
    value = rng.choice(EXTREMES)
    if option == '--units':
        value = f'{rng.choice(("t", "current", "position", "voltage"))}={value}'
    argv = {'identify': ['identify', seeds['short']], 'import': ['import', seeds['short'], out / 'bag'],
            'simulate': ['simulate', '--bag', out / 'bag'],
            'compare': ['compare', seeds['long'], '--model-file', seeds['nominal']]}[command]
    if option == '--orders':
        return [*argv, '--model', 'arx', '--orders', *(rng.choice(EXTREMES + ['2', '300']) for _ in range(3))]
    return [*argv, f'{option}={value}']


def make_case(k, seeds, folder):
    """Case k: (kind, what was mutated, command line or None for a params file, the input paths, the params
    file)."""
    rng = random.Random(f'{SEED}:{k}')
    out = folder / 'out'
    out.mkdir()
    kind = rng.choices(('csv', 'mat', 'bag', 'model', 'params', 'option'), weights=(30, 12, 20, 15, 13, 10))[0]
    if kind == 'option':
        argv = option_case(rng, seeds, out)
        return kind, f'option {argv[-1]!r}', argv, [], None
    if kind == 'bag':
        seed = seeds[rng.choice(('simulated', 'imported'))]
        path = folder / seed.name
        shutil.copytree(seed, path)
        target = rng.choice(sorted(path.iterdir()))
        data, what = mutate(rng, target.read_bytes(), 'yaml' if target.suffix == '.yaml' else 'mcap')
        target.write_bytes(data)
        what = f'{seed.name}/{target.name}: {what}'
    else:
        seed = seeds[rng.choice({'csv': ('short', 'logger', 'long'), 'mat': ('scope', 'zipped'),
                                 'model': ('nominal', 'friction'), 'params': ('identifier', 'plant')}[kind])]
        path = folder / seed.name
        data, what = mutate(rng, seed.read_bytes(), {'model': 'yaml', 'params': 'yaml'}.get(kind, kind))
        path.write_bytes(data)
        what = f'{seed.name}: {what}'
    if kind == 'params':
        return kind, what, None, [path], path
    return kind, what, rng.choice(commands(rng, kind, path, seeds, out)), [path], None


def digest(paths):
    """A hash of every file under `paths` (files or directories)."""
    h = hashlib.sha256()
    for path in paths:
        for file in sorted([path] if path.is_file() else path.rglob('*')):
            h.update(str(file).encode())
            if file.is_file():
                h.update(file.read_bytes())
    return h.hexdigest()


def check_params_file(path):
    """What `emla run` and a node check of a params file before ROS starts, in this process; InputError is the
    one-line refusal."""
    run_node._check_params_file(str(path), ['--ros-args', '--params-file', str(path)])
    for name, tree in params_file.read_params_files(['--params-file', str(path)]).items():
        params_file.check_sections(name, tree, f'/emla/{Path(path).stem}')


def _outcome(argv, params):
    """(exit status, stderr, the traceback of an exception other than SystemExit or None) of a case run here: the
    command line `argv`, or the checks of the params file `params`."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            if params is None:
                return cli.main([str(a) for a in argv]), err.getvalue(), None
            try:
                check_params_file(params)
            except InputError as exc:
                return 2, f'error: {exc}\n', None
            return 0, '', None
    except SystemExit as exc:
        return exc.code, err.getvalue(), None
    except BaseException:  # noqa: BLE001 - what the fuzz looks for
        return None, err.getvalue(), traceback.format_exc()


class Worker:
    """A child process forked from this one (its modules loaded and compiled already) that runs the cases it is
    sent one after another, its address space limited to MEMORY_LIMIT: a crash (scipy's MAT reader has
    segfaulted), a hang or a runaway allocation ends the worker, not the fuzz; a new one takes the next case."""

    def __init__(self):
        requests, self._to_worker = os.pipe()
        self._from_worker, replies = os.pipe()
        self.pid = os.fork()
        if self.pid == 0:
            os.close(self._to_worker)
            os.close(self._from_worker)
            resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, resource.getrlimit(resource.RLIMIT_AS)[1]))
            with os.fdopen(requests) as cases, os.fdopen(replies, 'w') as outcomes:
                for line in cases:
                    status, err, exception = _outcome(*json.loads(line))
                    outcomes.write(json.dumps([status, err[-10_000:], exception]) + '\n')
                    outcomes.flush()
            os._exit(0)  # without pytest's clean-up
        os.close(requests)
        os.close(replies)
        self._requests, self._replies = os.fdopen(self._to_worker, 'w'), os.fdopen(self._from_worker)

    def run(self, argv, params):
        """_outcome() of a case, or (None, '', what ended the worker): then the worker is gone (see stop)."""
        self._requests.write(json.dumps([argv and [str(a) for a in argv], params and str(params)]) + '\n')
        self._requests.flush()
        answered = select.select([self._replies], [], [], CASE_TIMEOUT)[0]
        line = self._replies.readline() if answered else ''
        if line.endswith('\n'):
            return tuple(json.loads(line))
        if not answered:
            os.kill(self.pid, signal.SIGKILL)
        status = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
        self.pid = None
        return None, '', (f'hung: more than {CASE_TIMEOUT} s' if not answered else
                          f'the process died: {f"signal {-status}" if status < 0 else f"status {status}"}')

    def alive(self):
        return self.pid is not None

    def stop(self):
        """End the worker (it leaves at the end of its requests) and close the pipes."""
        self._requests.close()
        self._replies.close()
        if self.pid is not None:
            os.waitpid(self.pid, 0)


def finding(status, err, exception, changed):
    """What is wrong with a case's outcome, or None."""
    if exception:   # the exception and where it was raised
        lines = exception.strip().splitlines()
        where = [line.strip() for line in lines if line.strip().startswith('File ')]
        return f'{lines[-1]} ({where[-1] if where else "?"})'
    if changed:
        return 'an input file changed'
    if status not in (0, 2):
        return f'exit status {status}'
    if 'Traceback' in err:
        return 'a traceback on stderr'
    if 'a bug in emla' in err:
        return err.strip().splitlines()[-1]
    return None


def test_mutated_inputs_give_one_line_or_a_result_and_change_no_input(seeds, tmp_path):
    findings, outcomes = [], collections.Counter()
    untouched = digest(seeds.values())   # the unmutated inputs some commands read besides the mutated one
    worker = Worker()
    try:
        for k in range(FIRST, FIRST + CASES):
            folder = tmp_path / f'case{k}'
            folder.mkdir()
            kind, what, argv, inputs, params = make_case(k, seeds, folder)
            before = digest(inputs)
            if not worker.alive():   # the last case ended it
                worker.stop()
                worker = Worker()
            status, err, exception = worker.run(argv, params)
            problem = finding(status, err, exception, digest(inputs) != before)
            outcomes[kind, status] += 1
            if problem:
                findings.append(f'case {k} ({what}; {" ".join(map(str, argv or ["params file"]))}): {problem}')
                if KEEP:
                    shutil.copytree(folder, Path(KEEP) / f'seed{SEED}-case{k}', dirs_exist_ok=True)
            shutil.rmtree(folder)
    finally:
        worker.stop()
    print(f'fuzz: {CASES} cases (seed {SEED}), {len(findings)} findings; (input, exit status): cases',
          dict(sorted(outcomes.items(), key=str)))
    assert not findings, '\n'.join(findings[:50])
    assert digest(seeds.values()) == untouched
