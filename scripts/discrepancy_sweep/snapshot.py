"""The suite's code a sweep measures: a git commit's packages exported apart from the work tree, or .venv's."""
import os
import subprocess
import sys
from pathlib import Path

from .cases import ROOT

PACKAGES = ('emla_core', 'emla_identification', 'emla_sim')


def commit(revision):
    """The full commit id of a git revision of the repository (raises CalledProcessError if it is none)."""
    return subprocess.run(['git', 'rev-parse', '--verify', f'{revision}^{{commit}}'], cwd=ROOT, capture_output=True,
                          text=True, check=True).stdout.strip()


def code_snapshot(revision):
    """Export the suite's packages and tests/independent_plant.py at a revision, once, under out/sweep-code/COMMIT.

    Others may reinstall .venv or edit the work tree while a sweep runs, and the report names the commit it
    measured. tests/actuators.py stays the work tree's: the cases are drawn from it (before the code is chosen),
    and independent_plant reads its nominal set from the same module.

    Parameters
    ----------
    revision : str
        A git revision.

    Returns
    -------
    tuple of (str, list of str)
        The commit and the paths to put first on the import path.
    """
    import shutil
    import tarfile
    import tempfile
    sha = commit(revision)
    dest = ROOT / 'out' / 'sweep-code' / sha
    if not (dest / '.complete').exists():
        dest.parent.mkdir(parents=True, exist_ok=True)
        (dest.parent / 'COLCON_IGNORE').touch()   # copies of the packages: colcon builds the work tree's alone
        with tempfile.TemporaryDirectory(dir=dest.parent) as tmp:
            archive = Path(tmp) / 'code.tar'
            subprocess.run(['git', 'archive', '-o', str(archive), sha, *PACKAGES, 'tests/independent_plant.py'],
                           cwd=ROOT, check=True)
            with tarfile.open(archive) as tar:
                tar.extractall(Path(tmp) / 'tree', filter='data')
            (Path(tmp) / 'tree' / '.complete').write_text(sha + '\n')
            if dest.exists():
                shutil.rmtree(dest)
            (Path(tmp) / 'tree').rename(dest)
    return sha, [str(dest / p) for p in PACKAGES] + [str(dest / 'tests')]


def use_code(revision):
    """Make this process and the workers it starts import the suite at a revision.

    Parameters
    ----------
    revision : str
        A git revision, or 'installed' for the suite this process imports as it is (.venv's, or PYTHONPATH's).

    Returns
    -------
    str
        The commit, or 'installed'.
    """
    if revision == 'installed':
        os.environ['EMLA_SWEEP_CODE'] = 'installed'
        return 'installed'
    if any(name in sys.modules for name in PACKAGES + ('independent_plant',)):
        raise RuntimeError('use_code must run before the suite is imported')
    sha, paths = code_snapshot(revision)
    sys.path[0:0] = paths
    os.environ['PYTHONPATH'] = os.pathsep.join(paths + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep)
                                                        if p])
    os.environ['EMLA_SWEEP_CODE'] = sha
    return sha
