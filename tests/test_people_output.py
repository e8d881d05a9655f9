"""What a person reads and types: the summary table, tables and time arrays as data, --columns without units."""
import json
import subprocess

import numpy as np
import pytest
from bench_experiments import open_loop_steps
from ros_isolation import VENV_BIN

from emla_identification.greybox import identify

EXAMPLE = 'docs/examples/logger.csv'   # time_ms, u_V, i_mA, x_mm


class Frame(dict):
    """What the suite reads of a pandas DataFrame: its columns and a column by name."""

    @property
    def columns(self):
        return list(self)


@pytest.fixture(scope='module')
def example():
    return np.loadtxt(EXAMPLE, delimiter=',', skiprows=1)


def test_a_table_of_columns_and_a_time_array_give_what_the_file_gives(example):
    a = example
    from_file = identify(EXAMPLE, points=1).parameters
    from_table = identify(Frame(time_ms=a[:, 0], u_V=a[:, 1], i_mA=a[:, 2], x_mm=a[:, 3]), points=1).parameters
    from_time = identify(time=a[:, 0] / 1e3, voltage=a[:, 1], current=a[:, 2] / 1e3, position=a[:, 3] / 1e3,
                         points=1).parameters
    for name, value in from_file.items():
        assert from_table[name] == pytest.approx(value, rel=1e-9, abs=1e-12), name
        assert from_time[name] == pytest.approx(value, rel=1e-6, abs=1e-9), name


def test_the_summary_lists_every_parameter_its_sigma_the_verdicts_and_the_notes():
    rec, _ = open_loop_steps(rate=2000.0, duration=3.0, spring=2000.0, seed=1)
    result = identify(rec, points=1)
    text = str(result)
    for name, value in result.parameters.items():
        line = next(line for line in text.splitlines() if line.startswith(name + ' '))
        assert float(line.split()[1]) == pytest.approx(value, rel=1e-5)
        assert float(line.split()[2]) == pytest.approx(result.std[name], rel=1e-2)
    assert text.count('adequate') == 2 and 'return spring' in text


def test_columns_name_a_header_without_its_unit(tmp_path, example):
    path = tmp_path / 'units.csv'
    a = example
    np.savetxt(path, np.column_stack((a[:, 0] / 1e3, a[:, 1], a[:, 2] / 1e3, a[:, 3] / 1e3)), delimiter=',',
               header='t [s],U_coil [V],I_coil [A],x_pos [m]', comments='')
    out = subprocess.run([str(VENV_BIN / 'emla'), 'identify', str(path), '--columns',
                          'voltage=U_coil,current=I_coil,position=x_pos', '--json', '-'],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)['parameters']['resistance'] == pytest.approx(
        identify(EXAMPLE, points=1).parameters['resistance'], rel=1e-6)
