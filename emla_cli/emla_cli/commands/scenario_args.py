"""The arguments `emla simulate` and `emla launch` share: which scenario, how long, which actuator."""
from emla_core.errors import InputError
from emla_core.topics import ESTIMATE_PERIOD

from .numbers import add_number


def add_arguments(parser, max_duration):
    """The scenario, --duration (from one estimate period, the first estimate, up to `max_duration` s) and
    --model-file."""
    parser.add_argument('scenario', nargs='?', default='default', help='scenario name (default: default; see above)')
    add_number(parser, '--duration', low=ESTIMATE_PERIOD, high=max_duration, unit='s', metavar='S',
               help=f"simulated time, s, {ESTIMATE_PERIOD:g} to {max_duration:g} (default: the scenario's, above)")
    parser.add_argument('--model-file', metavar='M.yaml',
                        help='run the actuator of this model file (its parameters and effects) instead')


def scenario_and_duration(args):
    """(Scenario, duration s) the arguments ask for; InputError for an unknown scenario or a bad model file."""
    from emla_bench import scenarios

    scenario = scenarios.get(args.scenario)
    if scenario.actuator != 'moving_coil':
        raise InputError(f'{scenario.name} is a {scenario.actuator} scenario: it runs in-process only, with '
                         f'`emla scenario {scenario.name}` (the ROS graph carries the moving coil\'s parameters)')
    if args.model_file:
        from emla_core.model_file import read
        scenario = scenario.with_model(read(args.model_file).require('moving_coil', args.model_file), args.model_file)
    return scenario, scenario.duration if args.duration is None else args.duration
