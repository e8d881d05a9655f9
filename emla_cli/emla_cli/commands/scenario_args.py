"""The arguments `emla simulate` and `emla launch` share: which scenario, how long, which actuator."""
from emla_core.errors import InputError
from emla_core.topics import ESTIMATE_PERIOD

from .numbers import add_number


def add_arguments(parser, max_duration):
    """The scenario, --duration (from one estimate period, the first estimate, up to `max_duration` s) and
    --model-file."""
    parser.add_argument('scenario', nargs='?', help='scenario name (default: default; see above)')
    add_number(parser, '--duration', low=ESTIMATE_PERIOD, high=max_duration, unit='s', metavar='S',
               help=f"simulated time, s, {ESTIMATE_PERIOD:g} to {max_duration:g} (default: the scenario's, above)")
    parser.add_argument('--model-file', metavar='M.yaml',
                        help='run the actuator of this model file (its parameters and effects) instead')


def scenario_and_duration(args, actuator=None, families=('moving_coil',)):
    """(Scenario, duration s) the arguments ask for: a scenario of the family `actuator` (None: any; without a
    scenario, that family's default, DEFAULT_SCENARIOS), which must be of `families`; InputError for an unknown
    or unfitting scenario or a bad model file."""
    from emla_bench import scenarios

    scenario = scenarios.get(args.scenario or scenarios.DEFAULT_SCENARIOS[actuator or 'moving_coil'])
    if actuator is not None and scenario.actuator != actuator:
        raise InputError(f'{scenario.name} is a {scenario.actuator} scenario, not a {actuator} one (that is '
                         f'{scenarios.DEFAULT_SCENARIOS[actuator]})')
    if scenario.actuator not in families:
        raise InputError(f'{scenario.name} is a {scenario.actuator} scenario: it runs with `emla scenario '
                         f'{scenario.name}` and `emla launch {scenario.name}`')
    if args.model_file:
        from emla_core.model_file import read
        model = read(args.model_file).require(scenario.actuator, args.model_file, whole=True)
        scenario = scenario.with_model(model, args.model_file)
    return scenario, scenario.duration if args.duration is None else args.duration
