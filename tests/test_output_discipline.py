"""Nothing lost, round 2 (issue 53): a directory output (bag, report, fleet) is built beside its target and moved
into place when complete; --force replaces only what emla wrote; one writer per output; a full or read-only
disk, a long name, a link loop, the working directory: one line, and every earlier file as it was; a command
killed at any moment leaves every output whole or absent and every earlier one intact."""
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from independent_data import EXAMPLES

from emla_cli import cli
from emla_cli.commands.staging import MARKER, SUFFIX
from emla_core.bag import read_bag

EMLA = Path(sys.executable).with_name('emla')
KILLS = 12   # make test's kill sweep; make sweep's covers every command (EMLA_KILLS, default 50)


@pytest.fixture
def work(tmp_path, monkeypatch):
    shutil.copy(EXAMPLES / 'logger.csv', tmp_path / 'run.csv')
    monkeypatch.chdir(tmp_path)
    return tmp_path


def snapshot(folder):
    """Every path under `folder` with the bytes of the regular files (None for others)."""
    return {p.relative_to(folder): p.read_bytes() if p.is_file() else None for p in Path(folder).rglob('*')}


def refused(argv, capsys, message):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and message in err, err


def no_staging(folder):
    return not [p for p in Path(folder).rglob(f'*{SUFFIX}')]


def a_user_folder(path):
    (path / 'src').mkdir(parents=True)
    (path / 'src' / 'main.c').write_text('int main(){}\n')
    (path / 'metadata.yaml').write_text('name: x\n')
    (path / 'report.md').write_text('# my notes\n')
    (path / 'fleet.yaml').write_text('mine: 1\n')


@pytest.mark.parametrize('argv', [
    ['import', 'run.csv', 'p', '--force'],
    ['simulate', '--bag', 'p', '--force'],
    ['simulate', '--fleet', 'p', '--hours', '2', '--force'],
    ['launch', '--bag', 'p', '--force'],
    ['discrepancy', 'run.csv', '--report', 'p', '--force'],
])
def test_force_never_removes_a_folder_emla_did_not_write(work, capsys, argv):
    a_user_folder(work / 'p')
    before = snapshot(work)
    refused(argv, capsys, 'p: --force replaces only an output emla wrote')
    assert snapshot(work) == before


def test_force_replaces_a_previous_bag_and_refuses_one_a_user_added_to(work, capsys):
    assert cli.main(['import', 'run.csv', 'B']) == 0
    assert (work / 'B' / MARKER).is_file() and len(read_bag('B').recording) == 3000
    assert cli.main(['import', 'run.csv', 'B', '--force']) == 0
    (work / 'B' / 'notes.txt').write_text('what I saw on the bench')
    capsys.readouterr()
    before = snapshot(work)
    refused(['import', 'run.csv', 'B', '--force'], capsys, 'BAGDIR B: holds files emla did not write (notes.txt)')
    refused(['simulate', '--bag', 'B', '--force'], capsys, '--bag B: holds files emla did not write (notes.txt)')
    refused(['discrepancy', 'run.csv', '--report', 'B', '--force'], capsys, 'holds a bag, not a discrepancy report')
    assert snapshot(work) == before and no_staging(work)


def test_the_working_directory_and_a_link_loop_are_one_line(work, capsys):
    assert cli.main(['import', 'run.csv', 'B']) == 0
    os.symlink('loop', work / 'loop')
    before = snapshot(work)
    os.chdir(work / 'B')
    refused(['import', '../run.csv', '.', '--force'], capsys, 'BAGDIR .: is or holds the working directory')
    os.chdir(work)
    refused(['import', 'run.csv', 'loop'], capsys, 'BAGDIR loop: cannot be resolved')
    refused(['identify', 'run.csv', '--json', 'loop'], capsys, '--json loop: cannot be resolved')
    assert snapshot(work) == before


def test_names_as_long_as_a_file_name_may_be(work, capsys):
    """A 250-character bag (its splits' names shortened) and a 245-character --json (its staging name hashed)."""
    bag, out = 'b' * 250, 'j' * 240 + '.json'
    assert cli.main(['import', 'run.csv', bag]) == 0
    assert len(read_bag(bag).recording) == 3000
    assert cli.main(['identify', bag, '--json', out]) == 0
    assert (work / out).stat().st_size > 0 and no_staging(work)


@pytest.fixture
def small_disk(tmp_path):
    """A 300 KiB tmpfs (root can mount one; skipped elsewhere), unmounted afterwards."""
    mount = tmp_path / 'disk'
    mount.mkdir()
    if subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=300k', 'tmpfs', str(mount)],
                      capture_output=True).returncode != 0:
        pytest.skip('cannot mount a tmpfs here (not root?)')
    yield mount
    subprocess.run(['umount', '-l', str(mount)], check=False)


def test_a_full_disk_and_a_read_only_one_keep_the_previous_bag(work, capsys, small_disk):
    bag = small_disk / 'B'
    assert cli.main(['import', 'run.csv', str(bag)]) == 0
    disk = os.statvfs(small_disk)
    (small_disk / 'filler').write_bytes(b'\0' * max(0, disk.f_bavail * disk.f_frsize - 20_000))   # no room left
    before = snapshot(small_disk)
    refused(['import', 'run.csv', str(bag), '--force'], capsys, 'cannot write: No space left on device')
    refused(['simulate', '--bag', str(bag), '--duration', '1', '--force'], capsys,
            'cannot write: No space left on device')
    assert snapshot(small_disk) == before and no_staging(small_disk)
    subprocess.run(['mount', '-o', 'remount,ro', str(small_disk)], check=True)
    refused(['import', 'run.csv', str(small_disk / 'C')], capsys, 'cannot write: Read-only file system')
    refused(['identify', 'run.csv', '--json', str(small_disk / 'i.json')], capsys, 'Read-only file system')
    assert snapshot(small_disk) == before


def emla(*argv, cwd):
    return subprocess.Popen([str(EMLA), *argv], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def test_a_second_writer_of_one_output_is_refused_in_one_line(work):
    first = emla('simulate', '--bag', 'B', '--duration', '5', cwd=work)
    try:
        deadline = time.monotonic() + 60
        while not (work / f'.B{SUFFIX}').exists():   # the first has reserved B
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.01)
        for argv in (['import', 'run.csv', 'B'], ['simulate', '--bag', 'B', '--duration', '1']):
            second = subprocess.run([str(EMLA), *argv], cwd=work, capture_output=True, text=True, timeout=60)
            assert second.returncode == 2 and second.stderr.count('\n') == 1, second.stderr
            assert f'another emla command (pid {first.pid}) is writing it' in second.stderr
        assert first.wait(timeout=120) == 0
    finally:
        first.kill()
        first.wait()
    assert len(read_bag(work / 'B').recording) == 50000 and no_staging(work)


# ---- killed at random moments ----

COMMANDS = {   # name -> (argv with OUT for the output, the kill's span in s): make test's pair
    'import': (['import', 'run.csv', 'OUT'], 1.2),
    'simulate': (['simulate', '--bag', 'OUT', '--duration', '1'], 2.5),
}
SWEEP = {      # make sweep's: every command that writes a directory or a table
    **COMMANDS,
    'launch': (['launch', '--bag', 'OUT', '--duration', '0.3', '--json', 'OUT.json'], 15.0),
    'trend': (['trend', 'run.csv', 'bag', '--workers', '1', '--table', 'OUT.csv'], 12.0),
    'discrepancy': (['discrepancy', 'run.csv', '--report', 'OUT', '--json', 'OUT.json'], 25.0),
}


def outcome(path):
    """What a whole output holds, to compare with one that ran to its end: a bag's files and samples, a report's
    files, a table's rows."""
    path = Path(path)
    if path.suffix == '.csv':
        return ('table', len(path.read_text().splitlines()))
    names = sorted(p.name.replace(path.name, 'OUT') for p in path.iterdir())
    if (path / 'metadata.yaml').is_file():
        return ('bag', names, len(read_bag(path).recording))
    return ('report', names)


def target_of(name, k):
    return f'{name}{k}' + ('.csv' if name == 'trend' else '')


def argv_of(argv, target):
    stem = target.removesuffix('.csv')
    return [a.replace('OUT.csv', target).replace('OUT', stem) for a in argv]


def run_to_the_end(argv, cwd):
    done = subprocess.run([str(EMLA), *argv], cwd=cwd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr


def kill_at_random(argv, cwd, rng, span):
    """Run `emla argv`, SIGKILL it at a random moment of `span` s (if still running); its exit status."""
    process = emla(*argv, cwd=cwd)
    try:
        process.wait(timeout=rng.uniform(0.0, span))
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGKILL)
    process.communicate(timeout=120)
    return process.returncode


def kill_sweep(work, commands, kills, seed):
    """`kills` runs of the commands, every other one with --force over an earlier output, each SIGKILLed at a
    random moment: afterwards each output is whole (as one run to its end) or absent, and each earlier one
    byte-identical or replaced by a whole one. The counts of kills and of runs that finished first."""
    rng = random.Random(seed)
    if 'trend' in commands or 'launch' in commands:
        run_to_the_end(['import', 'run.csv', 'bag'], work)
    expected = {}
    for name, (argv, _) in commands.items():
        run_to_the_end(argv_of(argv, target_of(name, 'ref')), work)
        expected[name] = outcome(work / target_of(name, 'ref'))
    counts = {'killed': 0, 'finished': 0}
    for k in range(kills):
        name = rng.choice(sorted(commands))
        argv, span = commands[name]
        target = target_of(name, k)
        force = k % 2 == 1
        if force:
            run_to_the_end(argv_of(argv, target), work)
        before = snapshot(work / target) if force and (work / target).is_dir() else \
            (work / target).read_bytes() if force else None
        status = kill_at_random(argv_of(argv, target) + (['--force'] if force else []), work, rng, span)
        counts['killed' if status == -signal.SIGKILL else 'finished'] += 1
        assert status in (0, -signal.SIGKILL), (name, k, status)
        if os.path.lexists(work / target):
            assert outcome(work / target) == expected[name], (name, k, force, status)
            if force and status != 0:
                after = snapshot(work / target) if (work / target).is_dir() else (work / target).read_bytes()
                assert after == before or outcome(work / target) == expected[name]
        else:
            assert not force and status != 0, (name, k, status)
    # what the killed ones left beside their targets goes with the next command writing there
    assert cli.main(['import', 'run.csv', 'last']) == 0
    assert no_staging(work), sorted(p.name for p in work.iterdir())
    return counts


def test_a_command_killed_at_any_moment_leaves_outputs_whole_or_absent_and_earlier_ones_intact(work):
    counts = kill_sweep(work, COMMANDS, KILLS, seed=53)
    assert counts['killed'] >= KILLS // 3, counts


@pytest.mark.slow
def test_the_kill_sweep_over_every_command_that_writes_a_directory_or_a_table(work):
    counts = kill_sweep(work, SWEEP, int(os.environ.get('EMLA_KILLS', '50')), seed=5353)
    print(f'kill sweep: {counts}')
    assert counts['killed'] >= 25, counts
