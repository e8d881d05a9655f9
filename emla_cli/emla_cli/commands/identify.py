"""`emla identify`: parses the options and calls the identification (grey box: emla_identification.greybox,
part by part for long records: streaming; ARX: arx; a model file's structure: model). The user's help is
description().

Records of 2^20 samples or more are identified part by part, in bounded memory: a bag is then never held whole
(streaming.read_record); the estimates equal the whole-record ones to rounding. The grey-box models take a record
with missing samples in segments (the JSON's "segments" and "gaps"); the others refuse it (inputs.load_data)."""
import contextlib
import sys
from pathlib import Path

from emla_core.bag.report import read_warnings
from emla_core.errors import InputError
from emla_core.parameters import FAMILIES

from .inputs import (
    DATA_HELP,
    add_data_arguments,
    foreign,
    load_data,
    reading_warnings,
    understood,
    unknown_figures,
    warn,
)
from .numbers import add_number
from .output import add_force_argument, check_outputs, emit_json, write_stdout

HELP = 'Identify actuator parameters (grey-box) or an ARX model from a CSV file or a bag.'


def description():
    return """\
Identify an actuator's parameters from a recording (CSV file, rosbag2 directory or .mcap file).

Grey-box models, from u = R I + L dI/dt + Km v and m dv/dt = Km I - B v - Fl (SI units):
  full        R, L, Km, m, B, Fl (needs voltage, current, position)
  electrical  R, L, Km           (the same signals)
  mechanical  m, B, Fl           (the same signals, or force and position)
Default: full with voltage/current/position, mechanical with force/position. Velocity comes from position.
Each parameter comes with its one-sigma uncertainty.

A solenoid (--actuator solenoid: a reluctance actuator, force I^2 L'(x)/2, L(x) = L0 + a/(g0 - x), a return
spring F0 + k x, end stops): R, L0, a, g0, m, B, k, F0 with one-sigma uncertainties and the fit check, from
voltage, current and position, offline. With --observer-from FIT.json (that JSON, from a bench record with
position) and --position-out FILE.csv, DATA needs voltage and current only: the armature's position is
estimated from the coil's current by a Kalman filter on the flux linkage, the mechanics and R (R tracked as the
coil warms), and written as t, position_estimate (m), position_std (m), resistance_estimate (ohm), held (1 where
the current alone could not locate the armature).

Black box (--model arx): y(t) + a1 y(t-1) + ... = b1 u(t-nk) + ... by recursive least squares; default
input voltage, output current, orders 2 2 1 (the coil current's exact structure). With --forgetting 1 it
equals batch least squares.

Long records (a million samples and more) are read and identified in parts with bounded memory; the
result is the same. A record with missing samples (a logger that dropped some, a bag's lost frames) is
identified in segments by the grey-box models: no regression row spans a gap, every segment's rows feed the one
estimate, and the JSON lists the "segments" (start, end s, samples) and "gaps" (start, end s, missing samples);
the fit is checked on the longest segment (with forgetting: the last); --start/--end take a part of a record.
The JSON goes to stdout unless --json FILE is given (then a summary table does; --json - keeps the JSON);
--plot draws the estimates converging (and the true values, when a simulated bag carries them); --trajectory
writes the estimates over time as CSV (time, then each parameter and its _std, SI units; with forgetting
they follow a drifting plant), one row per --trajectory-interval (default: about 200 rows). With --model-file
the structure of a model file (from `emla discrepancy --model-out`: the nominal model with the effects found)
is identified on DATA, effects' parameters included; --model-out writes what was
identified as a model file for the other commands. Data that look read in the wrong units or signs (a
current in mA, a voltage in mV, a time in ms, a position in mm; a sensor mounted the other way, named by its
root cause) are warned about on stderr with the flag that fixes it, and listed under "warnings" in the JSON;
the exit status stays 0.

""" + DATA_HELP
MODELS = ('electrical', 'mechanical', 'full', 'arx')
# options of the moving coil's identification that the solenoid's (offline, whole record) does not take
NOT_FOR_SOLENOID = {'--model': 'model', '--orders': 'orders', '--input': 'input', '--output': 'output',
                    '--plot': 'plot', '--trajectory': 'trajectory', '--trajectory-interval': 'trajectory_interval',
                    '--model-file': 'model_file', '--memory-time': 'memory_time'}
PROGRESS_MIN_SAMPLES = 200_000  # smaller inputs finish too fast for a progress bar
DEFAULT_POINTS = 200  # estimates in the trajectory (--plot, --trajectory) unless --trajectory-interval says


def add_arguments(parser):
    parser.add_argument('data', metavar='DATA', help='CSV or MAT file, rosbag2 directory or .mcap file')
    parser.add_argument('--actuator', default='moving_coil', metavar='FAMILY',
                        help='moving_coil (default) or solenoid (a reluctance actuator: see above)')
    parser.add_argument('--model', default=None, metavar='MODEL',
                        help='electrical, mechanical, full or arx (default: full for voltage/current/position '
                             'data, mechanical for force/position data)')
    parser.add_argument('--spring', choices=('auto', 'on', 'off'), default='auto',
                        help='a return spring k x in the mechanical equation: auto (default) where the data call '
                             'for it (the JSON\'s notes say so), on always, off never')
    parser.add_argument('--orders', nargs=3, metavar=('NA', 'NB', 'NK'),
                        help='ARX orders: output lags, input lags, input delay in samples (default 2 2 1)')
    memory = parser.add_mutually_exclusive_group()
    add_number(memory, '--forgetting', low=0.5, high=1.0, default=1.0, metavar='LAMBDA',
               help='forgetting factor in [0.5, 1] (default 1: no forgetting; memory 1/(1 - LAMBDA) samples)')
    add_number(memory, '--memory-time', low=0, high=1e6, open_low=True, unit='s', metavar='S',
               help='memory time constant in s instead (LAMBDA = 1 - Ts/S)')
    parser.add_argument('--input', metavar='COL', help='ARX input column (default voltage)')
    parser.add_argument('--output', metavar='COL', help='ARX output column (default current)')
    parser.add_argument('--json', metavar='FILE', help='write the result here (a summary table then goes to stdout); '
                                                       '- for stdout, as without it')
    parser.add_argument('--plot', metavar='FILE.png', help='PNG of the estimates converging over time (with '
                        '--observer-from: the position and R from the coil over time)')
    parser.add_argument('--trajectory', metavar='FILE.csv',
                        help='grey box: CSV of the estimates over time: time (s), then each parameter and its '
                             '<name>_std (SI), one row per interval')
    add_number(parser, '--trajectory-interval', low=0, high=1e6, open_low=True, unit='s', metavar='S',
               help='time between the rows of --trajectory (default: about 200 rows over the record)')
    parser.add_argument('--model-file', metavar='M.yaml',
                        help='identify the structure of this model file (its effects too) on DATA')
    parser.add_argument('--model-out', metavar='M.yaml', help='write the identified model to this model file')
    parser.add_argument('--observer-from', metavar='FIT.json',
                        help='--actuator solenoid: estimate the position of DATA (voltage, current) from the coil, '
                             'with the solenoid identified in FIT.json')
    parser.add_argument('--position-out', metavar='FILE.csv',
                        help='with --observer-from: CSV of t, position_estimate (m), position_std (m), '
                             'resistance_estimate (ohm), held')
    add_force_argument(parser)
    add_data_arguments(parser)


def run(args):
    if args.actuator not in FAMILIES:
        raise InputError(f'--actuator {args.actuator!r}: choose one of {", ".join(FAMILIES)}')
    if (args.observer_from is None) != (args.position_out is None):
        raise InputError('--observer-from FIT.json and --position-out FILE.csv go together')
    if args.observer_from is not None and args.actuator != 'solenoid':
        raise InputError('--observer-from applies to --actuator solenoid')
    if args.actuator == 'solenoid':
        return _observer(args) if args.observer_from else _solenoid(args)
    model, orders = _options(args)
    forgetting = args.forgetting
    json_path = None if args.json == '-' else args.json   # '-': stdout, as without --json
    check_outputs({'--json': json_path, '--plot': args.plot, '--model-out': args.model_out,
                   '--trajectory': args.trajectory}, [args.data, args.model_file], args.force)
    structure = None
    if args.model_file:
        from emla_core.model_file import read as read_model
        structure = read_model(args.model_file).require('moving_coil', args.model_file)
    with read_warnings() as lost:  # a bag's skipped chunks and the data they cost, for the JSON too
        parts, lam = None, 1.0   # lam: the forgetting factor of the grey-box estimate
        if model == 'arx':
            recording = load_data(args)
            result, plot = _arx(recording, orders, _memory(args, forgetting, recording), args)
            identified = trajectory = None
            fit = []
        elif structure is not None and structure.effects:
            recording = load_data(args)
            result, plot, identified = _with_effects(structure, recording, args)
            trajectory, fit = None, []
        else:
            from emla_identification.streaming import read_record
            recording, parts = read_record(args.data, lambda path: load_data(args, gaps=True), plain=not foreign(args),
                                           start=args.start, end=args.end)
            lam = _memory(args, forgetting, recording)
            result, plot, identified, trajectory, fit = _greybox(recording, parts, model, lam, args)
    from emla_identification.plausibility import plausibility_warnings
    slips = [] if model == 'arx' else plausibility_warnings(result['parameters'], result['std'], recording,
                                                            forgetting=lam, samples=result.get('samples'))
    found = slips or fit   # a slip the plausibility checks name is the root cause of any misfit
    if fit and not slips and result.get('model') == 'full' and parts is None:   # another actuator family's record?
        from emla_identification.solenoid import solenoid_hint
        found += [hint for hint in (solenoid_hint(max(recording.segments(), key=len)),) if hint]
    found += unknown_figures(result)
    read = reading_warnings(recording)   # (understood prints them)
    if model != 'arx' or found or lost or read:   # (an ARX result has warnings only when there are some)
        result['warnings'] = lost + warn(found, 'identify') + read
    result.update(understood(recording, 'identify'))
    files = []
    if args.model_out:
        from emla_core.model_file import write
        files.append((args.model_out, lambda temporary: write(identified, temporary)))
    if args.plot:
        from emla_cli.identify_plot import save_convergence_plot
        files.append((args.plot, lambda temporary: save_convergence_plot(temporary, *plot)))
    if args.trajectory:
        from emla_identification.trajectory_file import write_trajectory
        files.append((args.trajectory, lambda temporary: write_trajectory(trajectory, temporary)))
    emit_json(result, json_path, files)
    if json_path is not None and 'std' in result:   # the JSON in its file: a table for the person on stdout
        from emla_identification.summary import summary_text
        with contextlib.suppress(InputError):   # a closed stdout: the result is in its file all the same
            write_stdout(summary_text(f'{Path(args.data).name}: {result.get("model", model)} model, '
                                      f'{result.get("samples", len(recording))} samples',
                                      result['parameters'], result['std'], result.get('fit', {}),
                                      result.get('notes', ()), result.get('warnings', ())))
    return 0


def _solenoid(args):
    """`emla identify --actuator solenoid`: the JSON of emla_identification.solenoid, its warnings on stderr."""
    from emla_identification.solenoid import identify_solenoid
    _solenoid_only(args)
    check_outputs({'--json': args.json, '--model-out': args.model_out}, [args.data], args.force)
    with read_warnings() as lost:
        recording = load_data(args)
        result = identify_solenoid(recording)
    data = result.to_dict()
    data['warnings'] = lost + warn(result.warnings() + unknown_figures(data), 'identify')
    data.update(understood(recording, 'identify'))
    files = []
    if args.model_out:
        from emla_core.model_file import write
        model = result.model_file(args.data, _command_line())
        files.append((args.model_out, lambda temporary: write(model, temporary)))
    emit_json(data, args.json, files)
    return 0


def _observer(args):
    """`emla identify --actuator solenoid --observer-from FIT.json --position-out FILE.csv`: the position of DATA
    from its coil (emla_identification.solenoid_observer); a summary JSON."""
    import json

    import numpy as np

    from emla_identification.solenoid_observer import observe_position, observer_model
    _solenoid_only(args, allowed=('--plot',))
    check_outputs({'--json': args.json, '--position-out': args.position_out, '--plot': args.plot},
                  [args.data, args.observer_from], args.force)
    from emla_core.limits import read_document
    text = read_document(args.observer_from, 'JSON file')   # at most limits.MAX_DOCUMENT_BYTES, checked first
    try:   # numbers as floats: a 5000-digit integer is no ValueError here and no OverflowError later
        fit = json.loads(text, parse_int=float)
    except RecursionError:
        raise InputError(f'--observer-from {args.observer_from}: cannot read it as JSON (nested too deeply)') from None
    except ValueError as exc:   # json.JSONDecodeError is one
        raise InputError(f'--observer-from {args.observer_from}: cannot read it as JSON ({exc})') from None
    params, noise = observer_model(fit)
    with read_warnings() as lost:
        recording = load_data(args)
    recording.require('voltage', 'current')
    estimate = observe_position(params, recording.sample_period, recording.signals['voltage'],
                                recording.signals['current'], current_noise=noise)
    data = {'model': 'solenoid', 'observer_from': str(args.observer_from), 'samples': len(recording),
            'sample_period': recording.sample_period, 'held': int(estimate.held.sum()),
            'resistance': {'start': float(estimate.resistance[0]), 'end': float(estimate.resistance[-1]),
                           'end_std': float(estimate.resistance_std[-1])},
            'position_std_median': float(np.median(estimate.position_std)),
            'warnings': lost, **understood(recording, 'identify')}
    measured = recording.signals.get('position')
    if measured is not None:   # a record with its own position: how far the estimate is from it
        data['position_rms_error'] = float(np.sqrt(np.mean((estimate.position - measured) ** 2)))
    files = [(args.position_out, lambda temporary: estimate.write_csv(recording.time, temporary))]
    if args.plot:
        from emla_cli.observer_plot import save_observer_plot
        files.append((args.plot, lambda temporary: save_observer_plot(
            temporary, recording.time, estimate, measured, f'{Path(args.data).name}: position from the coil')))
    emit_json(data, args.json, files)
    return 0


def _solenoid_only(args, allowed=()):
    """InputError for the moving coil's options given with --actuator solenoid (but those `allowed`)."""
    given = [flag for flag, name in NOT_FOR_SOLENOID.items()
             if getattr(args, name) is not None and flag not in allowed]
    if args.forgetting != 1.0:
        given.append('--forgetting')
    if given:
        raise InputError(f'{", ".join(given)} applies to the moving coil, not to --actuator solenoid (identified '
                         f'offline over the whole record)')


def _options(args):
    """(model or None, orders or None) checked before any data is read."""
    model = args.model
    if model is not None and model not in MODELS:
        raise InputError(f'--model {model!r}: choose one of {", ".join(MODELS)}')
    if model != 'arx':
        for flag, value in (('--orders', args.orders), ('--input', args.input), ('--output', args.output)):
            if value is not None:
                raise InputError(f'{flag} applies to --model arx only')
    else:
        for flag, value in (('--model-file', args.model_file), ('--model-out', args.model_out),
                            ('--trajectory', args.trajectory)):
            if value is not None:
                raise InputError(f'{flag} applies to the grey-box models, not to --model arx')
    if args.trajectory_interval is not None and args.trajectory is None:
        raise InputError('--trajectory-interval goes with --trajectory FILE.csv')
    if (args.input is None) != (args.output is None):
        raise InputError('--input and --output go together')
    orders = None
    if model == 'arx':
        from emla_identification.arx import DEFAULT_ORDERS, MAX_ORDERS
        try:
            orders = tuple(int(v) for v in args.orders) if args.orders else DEFAULT_ORDERS
        except ValueError:
            raise InputError(f'--orders {" ".join(args.orders)}: need three integers NA NB NK') from None
        if min(orders) < 0 or orders[0] + orders[1] == 0 or any(map(int.__gt__, orders, MAX_ORDERS.values())):
            raise InputError(f'--orders {" ".join(map(str, orders))}: need NA, NB, NK >= 0 and NA + NB >= 1, '
                             f'NA, NB <= {MAX_ORDERS["na"]}, NK <= {MAX_ORDERS["nk"]}')
    return model, orders


def _memory(args, forgetting, recording):
    """The forgetting factor: --forgetting, or from --memory-time at the data's sample period."""
    if args.memory_time is None:
        return forgetting
    from emla_identification.rls import forgetting_factor
    try:
        return forgetting_factor(memory_time=args.memory_time, sample_period=recording.sample_period)
    except ValueError as exc:
        raise InputError(f'--memory-time {args.memory_time:g}: {exc}') from None


def _command_line():
    return 'emla ' + ' '.join(sys.argv[1:])


def _with_effects(structure, recording, args):
    """(JSON, plot, Model) of a model file's structure with effects identified on `recording`."""
    from emla_identification.model import identified_structure
    if args.memory_time is not None or args.forgetting != 1.0 or args.plot or args.trajectory:
        raise InputError('--forgetting, --memory-time, --plot and --trajectory apply to models without effects')
    result, identified = identified_structure(structure, recording, args.data, _command_line(), args.model_file)
    return result, None, identified


def _greybox(recording, parts, model, forgetting, args):
    from tqdm import tqdm

    from emla_core.sampling import listing
    from emla_identification.greybox import identify
    from emla_identification.streaming import identify_chunks
    points = _points(args, recording, parts) if args.plot or args.trajectory else 1   # else the final one only
    spring = {'auto': None, 'on': True, 'off': False}[args.spring]
    if parts is None:
        with tqdm(total=100, unit='%', desc='identify', file=sys.stderr, leave=False,
                  disable=not sys.stderr.isatty() or len(recording) < PROGRESS_MIN_SAMPLES) as bar:
            result = identify(recording, model, forgetting, points=points,
                              spring=spring,
                              progress=lambda done: bar.update(round(100 * done) - bar.n))
        spans = [(segment.start_time, len(segment)) for segment in recording.segments()]
    else:
        spans = []   # [start s, samples] of each segment, as identify_chunks reads them
        with tqdm(unit=' samples', unit_scale=True, desc='identify', file=sys.stderr, leave=False,
                  disable=not sys.stderr.isatty()) as bar:
            result = identify_chunks(parts, model, forgetting, points=points,
                                     progress=lambda samples: bar.update(samples - bar.n), spans=spans, spring=spring)
    truth = recording.truth(result.parameters)
    trajectory = result.trajectory
    title = f'{Path(recording.source).name}: {result.model} model'
    identified = None
    if args.model_out:
        from emla_identification.model import from_greybox
        identified = from_greybox(result, args.data, _command_line())
    plot = (trajectory.time, trajectory.parameters, trajectory.std, truth, title)
    data = result.to_dict()
    if len(spans) > 1:   # samples were missing: the record was identified in segments
        data.update(listing(spans, recording.sample_period))
    return data, plot, identified, trajectory, result.warnings()


def _points(args, recording, parts):
    """How many estimates the trajectory holds: one per --trajectory-interval over the record (a bag read in
    parts: over the duration its metadata gives), else DEFAULT_POINTS."""
    if args.trajectory_interval is None:
        return DEFAULT_POINTS
    from emla_identification.trajectory_file import trajectory_points
    duration = len(recording) * recording.sample_period
    if parts is not None and Path(args.data).is_dir():   # the first part of a bag: its whole span from metadata
        from emla_core.bag.reader import bag_info
        try:
            duration = max(duration, float(bag_info(Path(args.data))['duration']['nanoseconds']) * 1e-9)
        except (KeyError, TypeError, ValueError):
            pass
    try:
        return trajectory_points(duration, args.trajectory_interval, recording.sample_period)
    except ValueError as exc:
        raise InputError(f'--trajectory-interval {args.trajectory_interval:g}: {exc}') from None


def _arx(recording, orders, forgetting, args):
    from emla_identification import offline
    from emla_identification.arx import DEFAULT_SIGNALS, arx_regressors, identify_arx
    source = recording.source
    if args.input is None and not recording.has(*DEFAULT_SIGNALS):
        raise InputError(f'{source}: no voltage and current columns for the default ARX input and output; '
                         f'choose them with --input COL --output COL (columns: {", ".join(recording.signals)})')
    columns = (tuple(_signal_of(recording, name) for name in (args.input, args.output)) if args.input is not None
               else DEFAULT_SIGNALS)
    recording.require(*columns)
    u, y = (recording.signals[c] for c in columns)
    if len(y) - max(orders[0], orders[2] + orders[1] - 1) <= orders[0] + orders[1]:
        raise InputError(f'{source}: {len(y)} samples are too few for ARX{orders}')
    try:
        model = identify_arx(u, y, *orders, forgetting=forgetting)
        phi, target = arx_regressors(u, y, *orders)
        path = offline.trajectory(phi, target, max(1, len(target) // 200), forgetting=forgetting)
    except ValueError as exc:
        raise InputError(f'{source}: {exc}') from None
    na = orders[0]
    names = [f'a{i}' for i in range(1, na + 1)] + [f'b{i}' for i in range(1, orders[1] + 1)]
    time = recording.start_time + (path.samples + len(y) - len(target) - 1) * recording.sample_period
    std = path.std
    title = f'{Path(source).name}: ARX{orders} from {columns[0]} to {columns[1]}'
    from emla_core.units import SIGNAL_UNITS
    ratio = '/'.join(SIGNAL_UNITS.get(c, f'[{c}]') for c in reversed(columns))   # b: output per input
    units = {name: '-' if name.startswith('a') else ratio for name in names}
    return model.to_dict(), (time, dict(zip(names, path.theta.T)), dict(zip(names, std.T)), {}, title, units)


def _signal_of(recording, column):
    """The signal that holds the user's `column`: its own name, or the suite's signal it was read as (a column
    named u is read as the voltage)."""
    if column in recording.signals:
        return column
    return next((signal for signal, origin in recording.inputs.items()
                 if origin.get('source') == column and signal in recording.signals), column)
