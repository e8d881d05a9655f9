"""Simulate a scenario in-process (no ROS graph) and record it as a bag with the same topics, frames and
messages as one that `emla launch` records of the same scenario.

The run is the scenario's adaptive case (the one `emla launch` runs), with the identifier's estimate and
the controller's adaptation every 10 ms as in the graph. The bag holds, like the graph's: one SampleFrame per
signal per 1 ms control period (the sensor's measured voltage, current and position, the voltage command),
the reference and the plant's true voltage, current and position in frames of 10 ms, the parameter estimates
with their full covariance and the plant's true parameters every 10 ms, and the end time on
/emla/plant/done. So `emla play` can feed it to a live identifier, and `emla identify` re-identifies it.
The controller runs once a sample here (every 1 ms in the graph), so the two bags have the same layout, not
the same samples.
"""
import dataclasses
import sys
import time

from emla_core.errors import InputError
from emla_core.parameters import FAMILIES

from . import scenario_args
from .numbers import add_number
from .output import BAG, FLEET, check_outputs, write_output

PAPER_RISE = 0.267     # the source paper's R from 0.45 to 0.57 ohm over 100 hours
MAX_RECORDINGS = 10000

HELP = 'Simulate a scenario in-process and record it as a bag.'
SOLENOID_PERIOD = 2e-4    # s: the solenoid's record is logged at 5 kHz
SOLENOID_DURATION = 2.0   # s
MAX_DURATION = 600.0   # s: 6 M samples at 10 kHz, held in memory with the truth and the estimates
MAX_SEED = 2**32 - 1   # --seed: 32 bits are plenty (numpy takes any integer from 0); --fleet's recording k takes N + k


def description():
    from emla_bench.scenarios import catalogue
    return f"""\
Simulate a scenario in this process (no ROS graph, many times faster than real time) and record it as a
bag laid out like the one `emla launch` records: the same topics, 1 ms frames of 10 kHz samples, and
parameter estimates with their full covariance every 10 ms. `emla play` can feed it to a live identifier;
`emla identify` re-identifies it. Scenarios (the adaptive case is simulated):
{catalogue()}
"""


def add_arguments(parser):
    scenario_args.add_arguments(parser, MAX_DURATION)
    parser.add_argument('--actuator', default='moving_coil', metavar='FAMILY',
                        help='moving_coil (default: the scenario) or solenoid: a reluctance actuator (issue 24\'s '
                             'valve, docs/physics.md 9) driven open loop by voltage levels that move its armature '
                             'across the stroke at 1-3 A, logged at 5 kHz with 5 mA current noise and 1 um position '
                             'steps (default 2 s)')
    add_number(parser, '--seed', low=0, high=MAX_SEED, integer=True, metavar='N',
               help='seed of the sensor noise (of the solenoid\'s excitation too): another N gives another record '
                    'of the same run, the same N the same record (default: the scenario\'s, 0; a --fleet\'s '
                    'recording k takes N + k)')
    out = parser.add_mutually_exclusive_group(required=True)
    out.add_argument('--bag', metavar='DIR', help='bag directory to write (new or empty)')
    out.add_argument('--csv', metavar='FILE.csv',
                     help='(--actuator solenoid) a CSV of t, voltage, current, position instead of a bag')
    out.add_argument('--fleet', metavar='DIR',
                     help='a long run instead: one bag per recording (DIR/run_0000, ...; each stamped from its hour) '
                          'and DIR/fleet.yaml with each one\'s start and true parameters')
    long = parser.add_argument_group('a long run (--fleet)')
    add_number(long, '--hours', low=1e-3, high=1e6, unit='h', metavar='H', default=100.0,
               help='length of the run, hours (default 100)')
    add_number(long, '--every', low=1e-3, high=1e6, unit='h', metavar='H', default=1.0,
               help='time between recordings, hours (default 1; at most 10000 recordings)')
    add_number(long, '--resistance-rise', low=0.0, high=10.0, metavar='F', default=PAPER_RISE,
               help=f'R rises to (1 + F) R0 with the coil temperature (default {PAPER_RISE}, the paper\'s 0.45 -> '
                    f'0.57 ohm)')
    add_number(long, '--thermal-time', low=1e-3, high=1e6, open_low=False, unit='h', metavar='H', default=20.0,
               help='time constant of that rise, hours (default 20)')
    long.add_argument('--step', action='append', default=[], metavar='NAME=FACTOR@HOUR',
                      help='a parameter multiplied by FACTOR from HOUR on, e.g. damping=1.3@60 (repeatable)')
    parser.add_argument('--force', action='store_true',
                        help='replace DIR if it holds a bag (or a fleet) emla wrote, and nothing else')


def frames(values, n, state):
    """(index of the first sample, samples) of the graph's frames of n samples over len(values) - 1 intervals:
    a voltage frame holds the n values applied over one control period; a state frame the n samples those
    intervals end on, after a first frame with the state at t = 0 (see emla_core.nodes)."""
    intervals = len(values) - 1
    if state:
        yield 0, values[:1]
        for k in range(0, intervals, n):
            yield k + 1, values[k + 1:min(k + n, intervals) + 1]
    else:
        for k in range(0, intervals, n):
            yield k, values[k:min(k + n, intervals)]


def write_bag(result, path, scenario, offset=0.0):
    """The LoopResult `result` as a bag at `path` (see the module doc), its stamps `offset` s later."""
    from emla_core import topics
    from emla_core.bag import BagWriter
    from emla_core.messages import effect_message, estimate_message, frame_message, time_msg
    from emla_core.parameters import PARAMETER_NAMES

    recording = result.recording
    # stamps as whole ns of the offset plus those of the run: (t + offset) in floats rounds differently at an
    # offset of hours, and the last estimate fell after the bag's end
    period, start = recording.sample_period, topics.to_ns(recording.start_time) + topics.to_ns(offset)
    step = topics.to_ns(period)
    n, n_true = round(topics.CONTROL_PERIOD / period), round(topics.ESTIMATE_PERIOD / period)
    end = start + (len(recording) - 1) * step
    signals = {**{topics.MEASURED_TOPICS[name]: (recording.signals[name], name != 'voltage', n)
                  for name in topics.SIGNALS},
               topics.PLANT_TOPICS['voltage']: (recording.signals['voltage'], False, n_true),
               topics.PLANT_TOPICS['current']: (result.truth['current'], True, n_true),
               topics.PLANT_TOPICS['position']: (result.truth['position'], True, n_true),
               topics.COMMAND_TOPIC: (recording.signals['voltage'], False, n),
               topics.REFERENCE_TOPIC: (recording.signals['reference'], False, n_true)}
    logged = [(f, topics.to_ns(t) + topics.to_ns(offset)) for f, t in enumerate(result.frame_times)
              if topics.to_ns(t) + topics.to_ns(offset) <= end]
    truth = {name: float(values[logged[-1][0]]) for name, values in result.true_parameters.items()}
    zero = dict.fromkeys(PARAMETER_NAMES, 0.0)
    with BagWriter(path, custom_data={'scenario': scenario, **{f'true_{k}': repr(v) for k, v in truth.items()}}) as bag:
        effects = [name for name in result.estimates if name not in PARAMETER_NAMES]  # estimated online, if any
        for topic, (msgtype, _) in topics.RECORDED.items():
            if topic not in topics.OPTIONAL['moving_coil'] or effects:
                bag.add_topic(topic, msgtype)
        for topic, (values, state, samples) in signals.items():
            for first, data in frames(values, samples, state):
                bag.write_message(topic, start + first * step, frame_message(start + first * step, period, data))
        bag.write_message(topics.TRUE_PARAMETERS_TOPIC, start, estimate_message(
            start, {k: v[0] for k, v in result.true_parameters.items()}, zero))
        for f, stamp in logged:
            if effects:
                bag.write_message(topics.EFFECTS_TOPIC, stamp, effect_message(
                    stamp, {k: result.estimates[k][f] for k in effects}, {k: result.std[k][f] for k in effects}))
            bag.write_message(topics.PARAMETERS_TOPIC, stamp, estimate_message(
                stamp, {k: v[f] for k, v in result.estimates.items()}, {k: v[f] for k, v in result.std.items()},
                result.covariance[f], samples=(stamp - start) // step))
            bag.write_message(topics.TRUE_PARAMETERS_TOPIC, stamp, estimate_message(
                stamp, {k: v[f] for k, v in result.true_parameters.items()}, zero))
        bag.write_message(topics.DONE_TOPIC, end, time_msg(end))


def _simulate(scenario, duration, model_file):
    """The LoopResult of the scenario's graph case over `duration` s; InputError when the actuator of the model
    file `model_file` cannot be simulated (its state diverges: the plant refuses the non-finite voltage)."""
    from emla_core.topics import ESTIMATE_PERIOD
    try:
        # One sample more than the duration: the state the last voltage interval ends on is sampled too.
        return scenario.run_case(scenario.graph_case, duration + scenario.sample_period,
                                 frame_samples=round(ESTIMATE_PERIOD / scenario.sample_period))
    except ValueError as exc:
        if model_file is None:
            raise
        raise InputError(f'{model_file}: its actuator cannot be simulated at Ts = {scenario.sample_period:g} s, '
                         f'the state diverges ({exc}); check its parameters') from None


def run(args):
    if args.actuator not in FAMILIES:
        raise InputError(f'--actuator {args.actuator!r}: choose one of {", ".join(FAMILIES)}')
    if args.actuator == 'solenoid':
        return _solenoid(args)
    if args.csv:
        raise InputError('--csv goes with --actuator solenoid; a scenario is recorded as a bag (--bag DIR)')
    if args.fleet:
        return _fleet(args)
    _no_fleet_options(args)
    check_outputs({}, [args.model_file], args.force, {'--bag': (args.bag, BAG)})
    scenario, duration = scenario_args.scenario_and_duration(args)
    scenario = _seeded(scenario, args.seed)
    started = time.monotonic()
    result = _simulate(scenario, duration, args.model_file)
    # built beside it and moved into place when complete: a run that fails leaves an earlier bag as it was
    write_output(args.bag, lambda temporary: write_bag(result, temporary, scenario.name), BAG)
    print(f'emla simulate: {scenario.name}, {duration:g} s ({len(result.recording) - 1} samples) in '
          f'{time.monotonic() - started:.1f} s; bag {args.bag}', file=sys.stderr)
    return 0


def _seeded(scenario, seed):
    """The scenario with the sensor noise of `seed`, or as it is for None: the records `emla simulate` made
    before --seed existed are made again without it."""
    return scenario if seed is None else dataclasses.replace(scenario, seed=seed)


def _solenoid(args):
    """`emla simulate --actuator solenoid`: emla_sim.solenoid.record as a bag (the measured signals' topics, the
    plant's true ones, the voltage command, the end time; the true parameters in the bag's metadata) or a CSV."""
    from emla_core.recording import write_csv
    from emla_sim.solenoid import record
    if args.scenario is not None or args.fleet:
        raise InputError('--actuator solenoid simulates its own run: no scenario or --fleet')
    _no_fleet_options(args)
    check_outputs({'--csv': args.csv}, [args.model_file], args.force, {'--bag': (args.bag, BAG)} if args.bag else None)
    params = None
    if args.model_file:   # a solenoid's model file (emla identify --actuator solenoid --model-out)
        from emla_core.model_file import read
        params = read(args.model_file).require('solenoid', args.model_file).solenoid()
    duration = SOLENOID_DURATION if args.duration is None else args.duration
    started = time.monotonic()
    seed = {} if args.seed is None else {'seed': args.seed}   # else record's own
    recording, truth = record(params, duration=duration, sample_period=SOLENOID_PERIOD, **seed)
    if args.csv:
        write_output(args.csv, lambda temporary: write_csv(recording, temporary))
    else:
        write_output(args.bag, lambda temporary: _write_solenoid_bag(recording, truth, temporary), BAG)
    print(f'emla simulate: solenoid, {duration:g} s ({len(recording)} samples at {1 / SOLENOID_PERIOD:g} Hz) in '
          f'{time.monotonic() - started:.1f} s; {"CSV" if args.csv else "bag"} {args.csv or args.bag}',
          file=sys.stderr)
    return 0


def _write_solenoid_bag(recording, truth, path):
    """The solenoid's run as a bag in the graph's frames (see `frames`)."""
    from emla_core import topics
    from emla_core.bag import BagWriter
    from emla_core.messages import frame_message, time_msg

    period, step = recording.sample_period, topics.to_ns(recording.sample_period)
    n, n_true = max(1, round(topics.CONTROL_PERIOD / period)), max(1, round(topics.ESTIMATE_PERIOD / period))
    signals = {**{topics.MEASURED_TOPICS[name]: (recording.signals[name], name != 'voltage', n)
                  for name in topics.SIGNALS},
               **{topics.PLANT_TOPICS[name]: (truth[name], name != 'voltage', n_true) for name in topics.SIGNALS},
               topics.COMMAND_TOPIC: (recording.signals['voltage'], False, n)}
    end = (len(recording) - 1) * step
    with BagWriter(path, custom_data=recording.metadata) as bag:
        for topic in (*signals, topics.DONE_TOPIC):
            bag.add_topic(topic, topics.RECORDED[topic][0])
        for topic, (values, state, samples) in signals.items():
            for first, data in frames(values, samples, state):
                bag.write_message(topic, first * step, frame_message(first * step, period, data))
        bag.write_message(topics.DONE_TOPIC, end, time_msg(end))


def _no_fleet_options(args):
    """InputError for a long run's option given without --fleet."""
    defaults = {'hours': 100.0, 'every': 1.0, 'resistance_rise': PAPER_RISE, 'thermal_time': 20.0, 'step': []}
    for name, default in defaults.items():
        if getattr(args, name) != default:
            raise InputError(f'--{name.replace("_", "-")} goes with --fleet DIR (a long run as many recordings)')


def _fleet(args):
    """`emla simulate --fleet DIR`: the scenario at each recording's hour of a long run, one bag each."""
    import yaml

    from emla_bench.fleet import long_run, parse_step
    check_outputs({}, [args.model_file], args.force, {'--fleet': (args.fleet, FLEET)})
    steps = tuple(parse_step(text) for text in args.step)
    if args.hours / args.every > MAX_RECORDINGS:
        raise InputError(f'--hours {args.hours:g} --every {args.every:g}: more than {MAX_RECORDINGS} recordings')
    scenario, duration = scenario_args.scenario_and_duration(args)
    scenario = _seeded(scenario, args.seed)
    schedule = long_run(scenario.params, args.hours, args.every, resistance_rise=args.resistance_rise,
                        thermal_time=args.thermal_time, steps=steps)
    started = time.monotonic()

    def write(directory):
        from pathlib import Path
        directory = Path(directory)
        directory.mkdir()
        manifest = []
        for k, (start, params) in enumerate(schedule):
            run = dataclasses.replace(scenario, params=params, seed=scenario.seed + k)
            result = _simulate(run, duration, args.model_file)
            name = f'run_{k:04d}'
            write_bag(result, directory / name, scenario.name, offset=start)
            manifest.append({'bag': name, 'start': start, 'hour': start / 3600.0,
                             'truth': {key: float(v) for key, v in params.physical().items()}})
        (directory / 'fleet.yaml').write_text(yaml.safe_dump(
            {'scenario': scenario.name, 'duration': duration, 'hours': args.hours, 'every': args.every,
             'resistance_rise': args.resistance_rise, 'thermal_time': args.thermal_time,
             'steps': [dataclasses.asdict(step) for step in steps], 'recordings': manifest}, sort_keys=False))
    write_output(args.fleet, write, FLEET)
    print(f'emla simulate: {scenario.name}, {len(schedule)} recordings of {duration:g} s over {args.hours:g} h in '
          f'{time.monotonic() - started:.1f} s; fleet {args.fleet}', file=sys.stderr)
    return 0
