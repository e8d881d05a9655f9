"""README.md as a test (slow: about 5 minutes on 2 cores): every command block run in order, and the figures the
README states about their outputs checked within stated tolerances, so that none goes stale unseen (issue 54).

What runs. Every ```bash block of README.md, line by line (blank lines and `#` lines aside) and in the README's
order, each line by `bash -c` with a timeout of TIMEOUT s, all in one fresh working directory (tmp_path) that
holds what the README reads from the repository (LINKED, symlinked: the bundled bags, docs/examples, the scripts,
the identifier's config) and `out/`, `bags/` of its own, so the README's relative paths work and nothing is
written into the repository. `.venv/bin/` becomes the repository's .venv/bin (the commands run the packages
installed there: `make setup` installs the source tree; to run the source as it is, set PYTHONPATH to the
packages' folders, which the commands inherit). A line whose comment says "(exit 2)" must exit with status 2,
every other with 0. Every ```python block runs the same way, as `.venv/bin/python -c BLOCK`. Blocks of other
languages (yaml, bare ``` output) are not commands.

What does not run, and the rule: a block right after a line `<!-- not run: REASON -->` in README.md (its reason is
required). They are the setup itself (git clone, make setup / test / demo), the examples that need two shells at
once (`emla run` a node that runs until stopped, `emla play`, `emla echo`: tests/test_play_echo.py runs them),
the colcon build on a full ROS installation and the Slurm cluster (tests/test_workspace.py, tests/test_trend.py).

Figures. An HTML comment in README.md (invisible where it is rendered), placed after the commands whose outputs it
checks, next to the sentence or table that states the figures:

    <!-- expect: CHECK -->                   one check
    <!-- expect: a title, not checked        several, one per line
    CHECK
    -->

and it is evaluated when every block before it in the README has run (so it sees the files as they were then).
CHECK is `SOURCE [PATH] OPERATION[; a note]`:
- SOURCE: a file of the working directory (`out/trend.json`; .json, or .yaml/.yml), or `stdout(TEXT)`,
  `stderr(TEXT)`, `seconds(TEXT)` (the wall time) of the last command before the comment that is TEXT, or if none
  is, that starts with TEXT (the command without `.venv/bin/` and its comment); of a python block: whose code
  contains TEXT. A stdout is read as JSON when a PATH is given.
- PATH: keys and list indices joined by dots (`changes.0.sigma`, `recordings.-1.parameters.resistance`; a key
  with a dot in quotes: `fit_percent."out/nominal.yaml".position`), or `len(PATH)` for a length.
- OPERATION: `= NUMBER +- TOL` (TOL absolute, `P%` relative, or `A, P%`: within either), `<= NUMBER`,
  `>= NUMBER`, `== JSON` (a string, true, false, a number exactly), `contains "TEXT"` (JSON string: in the text,
  in a string value, or in any element of a list), and `table +- TOL`: the first markdown table after the comment
  in the README against the first table in the source (stdout), row by row, every number in every cell but the
  first column's (the row's label) within TOL.
Figures are checked to about their last stated digit. Timings only to an order of magnitude (`seconds(...) <=`
ten times the README's figure, a real-time factor above a tenth of it), so a loaded machine does not fail them.
"""
import json
import math
import re
import shlex
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml
from ros_isolation import isolated_env

REPO = Path(__file__).resolve().parents[1]
README = REPO / 'README.md'
VENV_BIN = REPO / '.venv' / 'bin'
TIMEOUT = 300            # s a command or python block; the longest (the fleet's 100 bags) takes about 45 s
# what the README's commands read from the repository, by the same relative paths
LINKED = ('bags/example_discrepancy', 'bags/example_unexplained', 'docs/examples', 'emla_identification/config',
          'scripts')
NOT_RUN = re.compile(r'<!--\s*not run:\s*(.*?)\s*-->\s*$')
SOURCE = re.compile(r'(stdout|stderr|seconds)\((.*?)\)(?=\s|$)')
NUMBER = r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?'


@dataclass
class Block:
    line: int                    # of the opening fence, 1-based
    language: str
    lines: list                  # (line number, text)
    not_run: str = ''            # the reason, if a `not run` marker precedes the block


@dataclass
class Expect:
    line: int
    checks: list                 # (line number, text)


@dataclass
class Run:
    line: int
    text: str                    # the command without .venv/bin/ and its comment (for a python block: the code)
    python: bool
    raw: str = ''                # the line as the README writes it
    returncode: int | None = None
    stdout: str = ''
    stderr: str = ''
    seconds: float = math.nan
    problems: list = field(default_factory=list)


def parse(text):
    """README.md's blocks and expect comments, in order."""
    items, lines, i, reason = [], text.splitlines(), 0, None
    while i < len(lines):
        line, number = lines[i], i + 1
        if line.startswith('```'):
            j = i + 1
            while j < len(lines) and not lines[j].startswith('```'):
                j += 1
            assert j < len(lines), f'README.md:{number}: a block that never closes'
            items.append(Block(number, line[3:].strip(), [(k + 1, lines[k]) for k in range(i + 1, j)], reason or ''))
            reason, i = None, j + 1
            continue
        if reason is not None and line.strip():
            raise AssertionError(f'README.md:{number}: a `not run` marker must be followed by the block it skips')
        if (marker := NOT_RUN.match(line.strip())):
            assert marker.group(1), f'README.md:{number}: `not run` needs its reason'
            reason = marker.group(1)
        elif line.lstrip().startswith('<!-- expect:'):
            first = line.split('<!-- expect:', 1)[1]
            if '-->' in first:                      # one check on one line
                items.append(Expect(number, [(number, first.split('-->')[0].strip())]))
            else:                                   # a title, then a check a line until -->
                checks, j = [], i + 1
                while j < len(lines) and '-->' not in lines[j]:
                    if lines[j].strip():
                        checks.append((j + 1, lines[j].strip()))
                    j += 1
                assert j < len(lines) and lines[j].strip() == '-->', f'README.md:{number}: an unclosed expect'
                items.append(Expect(number, checks))
                i = j
        i += 1
    return items


def command_text(line):
    """The command as expects name it: without .venv/bin/, without its comment, spaces normalised."""
    return ' '.join(shlex.split(line.replace('.venv/bin/', ''), comments=True))


def commands(block):
    """The command lines of a bash block: (line number, line), blank and comment-only lines left out."""
    return [(n, line) for n, line in block.lines if line.strip() and not line.lstrip().startswith('#')]


def runnable(items):
    """The runs the README's blocks make, not run yet, and the expects, in the README's order."""
    out = []
    for item in items:
        if isinstance(item, Expect):
            out.append(item)
        elif item.not_run or item.language not in ('bash', 'python'):
            continue
        elif item.language == 'bash':
            out += [Run(n, command_text(line), False, raw=line) for n, line in commands(item)]
        else:
            out.append(Run(item.line, '\n'.join(text for _, text in item.lines), True))
    return out


def find_run(runs, text):
    """The last run before the expect that is TEXT, or else starts with TEXT (a python block: contains it)."""
    exact = [r for r in runs if (text in r.text if r.python else r.text == text)]
    prefix = [r for r in runs if not r.python and r.text.startswith(text)]
    if not (exact or prefix):
        raise LookupError(f'no command or python block before it matches {text!r}')
    return (exact or prefix)[-1]


def lookup(value, path):
    """The value at PATH (dotted keys and indices, quoted keys, len(PATH))."""
    length = re.fullmatch(r'len\((.*)\)', path)
    for key in re.findall(r'"[^"]*"|[^.]+', length.group(1) if length else path):
        key = key.strip('"')
        if isinstance(value, list):
            value = value[int(key)]
        elif isinstance(value, dict) and key in value:
            value = value[key]
        else:
            raise LookupError(f'no {key!r} at {path!r}')
    return len(value) if length else value


def tolerance(text):
    """`A`, `P%` or `A, P%` to (absolute, relative)."""
    absolute, relative = 0.0, 0.0
    for part in text.split(','):
        part = part.strip()
        if part.endswith('%'):
            relative = float(part[:-1]) / 100
        else:
            absolute = float(part)
    return absolute, relative


def near(actual, expected, tol):
    absolute, relative = tol
    return abs(actual - expected) <= max(absolute, relative * abs(expected)) * (1 + 1e-9) + 1e-300


def table_after(readme_lines, line):
    """The first markdown table of README.md after line `line` (1-based), as rows of cells."""
    rows = []
    for text in readme_lines[line:]:
        if text.startswith('|'):
            rows.append(text)
        elif rows:
            break
    return rows


def cells(row):
    return [cell.strip() for cell in row.strip().strip('|').split('|')]


def compare_tables(stated, printed, tol):
    """Differences between the README's table and the printed one: every number but the first column's."""
    printed = [row for row in printed.splitlines() if row.startswith('|')]
    if len(stated) != len(printed):
        return [f'{len(stated)} rows in the README, {len(printed)} printed']
    differences = []
    for stated_row, printed_row in zip(stated[2:], printed[2:]):          # the header and the |---| line aside
        a, b = cells(stated_row), cells(printed_row)
        if len(a) != len(b):
            differences.append(f'{stated_row!r}: {len(a)} columns, printed {len(b)}')
            continue
        for column, (x, y) in enumerate(zip(a[1:], b[1:]), 1):
            xs, ys = [float(v) for v in re.findall(NUMBER, x)], [float(v) for v in re.findall(NUMBER, y)]
            if len(xs) != len(ys) or not all(near(p, s, tol) for s, p in zip(xs, ys)):
                differences.append(f'row {a[0]!r}, column {column + 1}: README {x!r}, printed {y!r}')
    return differences


OPERATION = re.compile(r'(=|<=|>=|==|contains|table)(?:\s|$)')


def parse_check(text):
    """CHECK to (kind: stdout, stderr, seconds or file; its command's TEXT or the file; PATH or None; op; argument)."""
    text = re.sub(r';[^"]*$', '', text).strip()      # the note
    if (source := SOURCE.match(text)):
        kind, name, rest = source.group(1), source.group(2), text[source.end():].strip()
    else:
        kind, (name, _, rest) = 'file', text.partition(' ')
    path = None
    if not OPERATION.match(rest):
        path, _, rest = rest.partition(' ')
    operation = OPERATION.match(rest)
    if not operation:
        raise ValueError(f'no operation (=, <=, >=, ==, contains, table) in {text!r}')
    return kind, name, path, operation.group(1), rest[operation.end():].strip()


def check(text, runs, work, readme_lines, line):
    """One CHECK; returns a problem (str) or None."""
    kind, name, path, op, argument = parse_check(text)
    if kind == 'file':
        file = work / name
        if not file.is_file():
            return f'{name}: no such file'
        data = yaml.safe_load(file.read_text()) if file.suffix in ('.yaml', '.yml') else json.loads(file.read_text())
    else:
        run = find_run(runs, name)
        if run.returncode is None:
            return f'{name!r} did not finish'
        data = {'stdout': run.stdout, 'stderr': run.stderr, 'seconds': run.seconds}[kind]
        if path is not None:
            data = json.loads(data)
    if op == 'table':
        differences = compare_tables(table_after(readme_lines, line), data, tolerance(argument.lstrip('+-')))
        return '; '.join(differences) or None
    value = lookup(data, path) if path else data
    if op == 'contains':
        wanted = json.loads(argument)
        found = any(wanted in str(v) for v in value) if isinstance(value, list) else wanted in str(value)
        return None if found else f'{value!r} does not contain {wanted!r}'
    if op == '==':
        return None if value == json.loads(argument) else f'{value!r}, not {argument}'
    number = re.fullmatch(rf'({NUMBER})(?:\s*\+-\s*(.*))?', argument)
    if not number:
        raise ValueError(f'not a number: {argument!r}')
    expected = float(number.group(1))
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        return f'{value!r} is not a finite number'
    if op == '=':
        tol = tolerance(number.group(2) or '0')
        return None if near(value, expected, tol) else f'{value:.6g}, not {argument}'
    good = value <= expected if op == '<=' else value >= expected
    return None if good else f'{value:.6g}, not {op} {expected:g}'


def workspace(tmp_path):
    """A working directory where the README's relative paths read the repository's files."""
    for name in LINKED:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).symlink_to(REPO / name)
    return tmp_path


def execute(run, work, env):
    """Run one command line or python block; record what it did."""
    if run.python:
        argv = [str(VENV_BIN / 'python'), '-c', run.text]
    else:
        argv = ['bash', '-c', re.sub(r'(?<![\w./-])\.venv/bin/', f'{VENV_BIN}/', run.raw)]
    start = time.monotonic()
    try:
        done = subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        run.problems.append(f'took more than {TIMEOUT} s')
        return
    run.seconds, run.returncode, run.stdout, run.stderr = time.monotonic() - start, done.returncode, done.stdout, \
        done.stderr
    wanted = 2 if '(exit 2)' in run.raw else 0
    if done.returncode != wanted:
        tail = '\n    '.join(done.stderr.strip().splitlines()[-5:])
        run.problems.append(f'exit status {done.returncode}, not {wanted}:\n    {tail}')


@pytest.mark.slow
def test_every_block_runs_or_says_why_not_and_every_expect_names_a_command():
    """The rules hold before anything runs: a skipped block has its reason, an expect a command before it."""
    items = parse(README.read_text())
    blocks = [item for item in items if isinstance(item, Block)]
    skipped = [b for b in blocks if b.not_run]
    assert all(b.language in ('bash', 'python') for b in skipped)
    run_count = sum(len(commands(b)) for b in blocks if b.language == 'bash' and not b.not_run)
    assert run_count >= 40 and len(skipped) <= 6, (run_count, [b.line for b in skipped])
    runs = []
    for item in runnable(items):
        if isinstance(item, Run):
            runs.append(item)
            continue
        assert item.checks, f'README.md:{item.line}: an expect without checks'
        for line, text in item.checks:
            kind, name, _, op, argument = parse_check(text)
            if kind != 'file':
                find_run(runs, name)                    # raises if no command before it matches
            if op in ('contains', '=='):
                json.loads(argument)
            elif op == 'table':
                assert table_after(README.read_text().splitlines(), line), f'README.md:{line}: no table after it'


@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_the_readme_runs_word_for_word_and_states_what_its_commands_give(tmp_path):
    readme = README.read_text()
    readme_lines = readme.splitlines()
    work = workspace(tmp_path / 'readme')
    env = isolated_env()
    problems, runs, checked = [], [], 0
    started = time.monotonic()
    for item in runnable(parse(readme)):
        if isinstance(item, Run):
            execute(item, work, env)
            print(f'README.md:{item.line} {item.seconds:6.1f} s  {item.text.splitlines()[0][:100]}')
            problems += [f'README.md:{item.line}: {item.text.splitlines()[0][:120]}: {p}' for p in item.problems]
            runs.append(item)
            continue
        for line, text in item.checks:
            checked += 1
            try:
                problem = check(text, runs, work, readme_lines, line)
            except (LookupError, ValueError, IndexError, TypeError) as error:
                problem = f'{type(error).__name__}: {error}'
            if problem:
                problems.append(f'README.md:{line}: {text}\n    {problem}')
    print(f'{len(runs)} commands and python blocks, {checked} figures checked, {time.monotonic() - started:.0f} s')
    assert not problems, '\n'.join(problems)
