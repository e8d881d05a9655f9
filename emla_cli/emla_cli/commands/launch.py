"""Run the plant, sensor, identifier and controller nodes as a ROS 2 graph of processes, record a bag.

The graph runs in its own ROS domain (this host only) in simulated time until the plant has run --duration
and the identifier has published its final estimate; then every process is stopped. Progress (simulated
time) goes to stderr, the summary JSON to --json or stdout. realtime_factor is simulated time over the wall
time from the plant's first 10 ms (its first true-parameter tick after the start: the run's first frames pay
for the start-up of the connections) to its last step; cpu_per_simulated_second is the CPU time each process
(and all together, 'total') spent over the same span per simulated second; wall_time is the whole launch,
start-up and stop included.
"""
import os
import signal
import sys
import time
from pathlib import Path

from emla_core.parameters import FAMILIES

from . import scenario_args, staging
from .output import BAG, check_outputs, emit_json, publish
from .staging import mark

HELP = 'Run the plant, sensor, identifier and controller nodes as a ROS 2 graph and record a bag.'
MAX_DURATION = 3600.0  # s: an hour of the graph (about as long in wall time)


def description():
    from emla_bench.scenarios import catalogue
    return f"""\
Run the plant, sensor, identifier and controller nodes as a ROS 2 graph of separate processes and record
every topic to a bag.

The graph runs in its own ROS domain (this host only), in simulated time with a deterministic lockstep,
until the plant has run --duration and the identifier has published its final estimate; then every process
is stopped. Progress goes to stderr; the summary JSON (final estimates, true parameters, real-time factor,
node pids) to --json or stdout. Scenarios (the graph runs the adaptive case):
{catalogue()}
"""


def add_arguments(parser):
    scenario_args.add_arguments(parser, MAX_DURATION)
    parser.add_argument('--actuator', metavar='FAMILY', choices=FAMILIES,
                        help='moving_coil or solenoid: a scenario of this family (without one, its default: '
                             'default, or valve_resistance_rise); default: the scenario\'s')
    parser.add_argument('--bag', metavar='DIR', help='bag directory to record, new or empty (default: '
                                                     'bags/<scenario>-<time>)')
    parser.add_argument('--force', action='store_true', help='replace DIR if it holds a bag already, and FILE if '
                                                             'it exists')
    parser.add_argument('--json', metavar='FILE', help='write the summary here (default: stdout)')


def default_bag(name):
    stem = Path('bags') / f'{name}-{time.strftime("%Y%m%d-%H%M%S")}'
    bag, n = stem, 1
    while bag.exists():
        n += 1
        bag = stem.with_name(f'{stem.name}-{n}')
    return bag


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _keep_partial(reservation, bag):
    """Where the recording of a launch that failed or was stopped now is: never under the name of a complete bag,
    but beside it as <bag>.partial (where that name is free), marked as emla's, readable up to its last split."""
    partial = bag.with_name(f'{bag.name}.partial')
    if not (reservation.output / 'metadata.yaml').is_file() or os.path.lexists(partial):
        return f'nothing was recorded to {bag}'
    try:
        mark(reservation.output, BAG)
        os.rename(reservation.output, partial)
    except OSError:
        return f'nothing was recorded to {bag}'
    return f'the recording up to then is in {partial} (not {bag}: that name is kept for a complete run)'


def run(args):
    from emla_bench.node_parameters import scenario_parameters
    from emla_cli.launcher import LaunchError, launch

    scenario, duration = scenario_args.scenario_and_duration(args, args.actuator, FAMILIES)
    bag = Path(args.bag) if args.bag else default_bag(scenario.name)
    check_outputs({'--json': args.json}, [args.model_file], args.force, {'--bag': (bag, BAG)})
    reservation = staging.reserve(bag)
    # the params files beside the bag being recorded: a launcher killed leaves nothing elsewhere, and the next
    # command writing there removes them (emla_cli.commands.staging)
    workdir = reservation.staging / '.emla-launch'
    summary = {}

    def record(temporary):
        workdir.mkdir(exist_ok=True)
        summary.update(launch(scenario.name, duration, temporary, scenario_parameters(scenario, workdir),
                              scenario.actuator, workdir=workdir, recorder_fds=staging.held_descriptors()))
        summary['bag'] = str(bag)

    signal.signal(signal.SIGTERM, _interrupt)      # stop the graph as on Ctrl-C
    try:
        reservation.clear()
        record(reservation.output)
        mark(reservation.output, BAG)
    except (LaunchError, KeyboardInterrupt) as error:
        stopped = isinstance(error, KeyboardInterrupt)
        print(f'emla launch: {"interrupted" if stopped else error}; {_keep_partial(reservation, bag)}',
              file=sys.stderr)
        return 130 if stopped else 1
    except OSError as exc:
        reservation.clear()
        raise staging.cannot_write(bag, exc) from None
    except BaseException:
        reservation.clear()
        raise
    publish([reservation])
    emit_json(summary, args.json)
    print(f'emla launch: {duration:g} s simulated in {summary["wall_time"]:.1f} s (real-time factor '
          f'{summary["realtime_factor"]}); bag {bag}', file=sys.stderr)
    return 0
