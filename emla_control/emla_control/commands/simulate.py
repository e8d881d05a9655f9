"""Simulate a scenario in-process (no DDS) and record it as a bag laid out like the ones `emla launch` records.

The run is the scenario's case the graph runs (emla_control.launcher.graph_case). Frames follow the graph
(emla_sim.nodes.common): voltage-like signals in frames over [k Tc, (k+1) Tc), state signals in frames of the
samples those intervals end on, after a first frame with the state at t = 0; so `emla play` can feed the bag
to a live identifier, and emla_sim.bag.read_bag gives back the loop's signals. The state the last interval
ends on is not sampled by the loop, so the bag holds one interval less than the run.
"""
import sys
import time

from emla_sim.bag import (PARAMETER_ESTIMATE, PARAMETERS_TOPIC, SAMPLE_FRAME, TRUTH_TOPIC, BagWriter,
                          parameter_estimate, sample_frame)
from emla_sim.errors import InputError

HELP = 'Simulate a scenario in-process and record it as a bag.'
FRAME_SAMPLES = 100      # samples per frame (10 ms at 10 kHz)
# topic -> (LoopResult attribute, signal, state frame?)
SIGNAL_TOPICS = {
    '/emla/voltage': ('recording', 'voltage', False),
    '/emla/current': ('recording', 'current', True),
    '/emla/position': ('recording', 'position', True),
    '/emla/reference': ('recording', 'reference', False),
    '/emla/plant/voltage': ('recording', 'voltage', False),
    '/emla/plant/current': ('truth', 'current', True),
    '/emla/plant/position': ('truth', 'position', True),
}


def add_arguments(parser):
    parser.add_argument('scenario', nargs='?', default='default', help='scenario name (default: default)')
    parser.add_argument('--duration', type=float, metavar='S', help="simulated time, s (default: the scenario's)")
    parser.add_argument('--bag', required=True, metavar='DIR', help='bag directory to write')


def frames(values, n, state):
    """(index of the first sample, samples) of the graph's frames of n samples over len(values) - 1 intervals."""
    intervals = len(values) - 1
    if state:
        yield 0, values[:1]
        for k in range(0, intervals, n):
            yield k + 1, values[k + 1:min(k + n, intervals) + 1]
    else:
        for k in range(0, intervals, n):
            yield k, values[k:min(k + n, intervals)]


def write_bag(result, path, scenario):
    """The LoopResult `result` as a bag at `path` (see the module doc)."""
    recording = result.recording
    period, start = recording.sample_period, round(recording.start_time * 1e9)
    step = round(period * 1e9)
    end = start + (len(recording) - 1) * step
    logged = [(f, round(t * 1e9)) for f, t in enumerate(result.frame_times) if round(t * 1e9) <= end]
    truth = {name: float(values[logged[-1][0]]) for name, values in result.true_parameters.items()}
    with BagWriter(path, custom_data={'scenario': scenario, **{f'true_{k}': repr(v) for k, v in truth.items()}}) as bag:
        for topic, (source, name, state) in SIGNAL_TOPICS.items():
            values = (recording.signals if source == 'recording' else result.truth)[name]
            bag.add_topic(topic, SAMPLE_FRAME)
            for first, data in frames(values, FRAME_SAMPLES, state):
                bag.write_message(topic, start + first * step, sample_frame(start + first * step, period, data))
        for topic, log, std in ((PARAMETERS_TOPIC, result.estimates, result.std),
                                (TRUTH_TOPIC, result.true_parameters, None)):
            bag.add_topic(topic, PARAMETER_ESTIMATE)
            for f, stamp in logged:
                bag.write_message(topic, stamp, parameter_estimate(
                    stamp, {k: v[f] for k, v in log.items()}, std and {k: v[f] for k, v in std.items()},
                    samples_used=(stamp - start) // step))


def run(args):
    from emla_control import scenarios
    from emla_control.launcher import graph_case

    scenario = scenarios.get(args.scenario)
    duration = scenario.duration if args.duration is None else args.duration
    if not 0 < duration < 1e6:
        raise InputError(f'--duration must be positive, got {duration}')
    started = time.monotonic()
    result = scenario.run_case(graph_case(scenario), duration)
    write_bag(result, args.bag, scenario.name)
    print(f'emla simulate: {scenario.name}, {duration:g} s ({len(result.recording) - 1} samples) in '
          f'{time.monotonic() - started:.1f} s; bag {args.bag}', file=sys.stderr)
    return 0
