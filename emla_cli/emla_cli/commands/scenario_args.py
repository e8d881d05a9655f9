"""The arguments `emla simulate` and `emla launch` share: which scenario, how long, which actuator."""
from emla_core.errors import InputError


def add_arguments(parser):
    parser.add_argument('scenario', nargs='?', default='default', help='scenario name (default: default; see above)')
    parser.add_argument('--duration', type=float, metavar='S', help="simulated time, s (default: the scenario's, above)")
    parser.add_argument('--model-file', metavar='M.yaml',
                        help='run the actuator of this model file (its parameters and effects) instead')


def scenario_and_duration(args):
    """(Scenario, duration s) the arguments ask for; InputError for an unknown scenario, a bad model file or
    a duration that is not positive."""
    from emla_bench import scenarios

    scenario = scenarios.get(args.scenario)
    if args.model_file:
        from emla_core.model_file import read
        scenario = scenario.with_model(read(args.model_file), args.model_file)
    duration = scenario.duration if args.duration is None else args.duration
    if not 0 < duration < 1e6:
        raise InputError(f'--duration must be positive, got {duration}')
    return scenario, duration
