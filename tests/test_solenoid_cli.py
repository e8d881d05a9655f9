"""`emla simulate --actuator solenoid` and `emla identify --actuator solenoid` (in process): the run recorded as
a bag and as a CSV in the moving coil's topics and columns, identified back to the simulated truth; options that
do not apply give one clear line and exit 2."""
import json

import pytest

from emla_cli.cli import main
from emla_core.data import load
from emla_core.physics import SolenoidParameters
from emla_core.topics import MEASURED_TOPICS, PLANT_TOPICS


def one_line_error(capsys, argv, words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and 'Traceback' not in err[0], err


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('solenoid') / 'bag'
    assert main(['simulate', '--actuator', 'solenoid', '--duration', '1', '--bag', str(path)]) == 0
    return path


def test_the_bag_has_the_moving_coils_topics_and_identifies_to_the_truth(bag, capsys):
    from emla_core.bag.reader import bag_info
    topics = {t['topic_metadata']['name'] for t in bag_info(bag)['topics_with_message_count']}
    assert {*MEASURED_TOPICS.values(), *PLANT_TOPICS.values()} <= topics
    capsys.readouterr()
    assert main(['identify', str(bag), '--actuator', 'solenoid']) == 0
    result = json.loads(capsys.readouterr().out)
    assert result['model'] == 'solenoid' and result['warnings'] == []
    truth = SolenoidParameters().identified()
    for name, value in result['parameters'].items():
        assert abs(value - truth[name]) < 3 * result['std'][name] + 0.01 * abs(truth[name]), name


def test_the_csv_has_the_moving_coils_columns(tmp_path):
    path = tmp_path / 'run.csv'
    assert main(['simulate', '--actuator', 'solenoid', '--duration', '0.2', '--csv', str(path)]) == 0
    assert path.read_text().splitlines()[0] == 't,voltage,current,position'
    recording = load(path)
    assert recording.sample_period == pytest.approx(2e-4) and len(recording) == 1000


def test_options_that_do_not_apply_are_one_clear_line(bag, capsys, tmp_path):
    one_line_error(capsys, ['identify', str(bag), '--actuator', 'solenoid', '--model', 'full'], '--model')
    one_line_error(capsys, ['identify', str(bag), '--actuator', 'valve'], '--actuator')
    one_line_error(capsys, ['simulate', '--actuator', 'solenoid', '--fleet', str(tmp_path / 'f')], '--fleet')
    one_line_error(capsys, ['simulate', '--csv', str(tmp_path / 'x.csv')], '--actuator solenoid')


def test_the_moving_coil_analysis_of_a_solenoid_says_so_and_points_at_the_solenoid(tmp_path, capsys):
    from solenoid_generator import record

    from emla_core.recording import write_csv
    recording, _ = record(duration=1.0, rate=5000.0, seed=21)
    path = tmp_path / 'valve.csv'
    write_csv(recording, path, ['voltage', 'current', 'position'])
    assert main(['identify', str(path)]) == 0
    warnings = json.loads(capsys.readouterr().out)['warnings']
    assert any('does not fit' in line for line in warnings)
    assert any('--actuator solenoid' in line and 'a solenoid fits' in line for line in warnings)


def test_a_moving_coil_record_gets_no_solenoid_hint(tmp_path, capsys):
    from emla_core.recording import write_csv
    from emla_sim.datasets import closed_loop
    recording, _ = closed_loop(duration=0.3, effects=['coulomb_friction'])
    path = tmp_path / 'coil.csv'
    write_csv(recording, path, ['voltage', 'current', 'position'])
    assert main(['identify', str(path)]) == 0
    warnings = json.loads(capsys.readouterr().out)['warnings']
    assert any('does not fit' in line for line in warnings) and not any('solenoid' in line for line in warnings)
