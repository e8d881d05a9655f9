"""`emla import`: measured data (CSV, MAT or another bag) into a rosbag2 directory of the suite's topics."""
from pathlib import Path

from emla_core.errors import InputError

from .inputs import DATA_HELP, add_data_arguments, load_data, understood
from .output import BAG, check_outputs, write_output, write_stdout

HELP = 'Convert measured data into a rosbag2 directory (MCAP) with the suite topics.'


def description():
    return """\
Convert a recording (CSV or MAT file, or a bag of other topics) into a rosbag2 directory (MCAP) of the
suite's topics. Each signal becomes a /emla/<signal> topic of SampleFrame messages (100 samples per
frame) in SI units, stamped from the data's time. `emla identify` gives the same answer on the data and on
the bag. The data must hold voltage, current and position (or force and position).

""" + DATA_HELP


def add_arguments(parser):
    parser.add_argument('data', metavar='DATA', help='CSV or MAT file, rosbag2 directory or .mcap file')
    parser.add_argument('bagdir', metavar='BAGDIR', help='rosbag2 directory to create (new or empty)')
    parser.add_argument('--force', action='store_true',
                        help='replace BAGDIR if it holds a bag emla wrote (and nothing else)')
    add_data_arguments(parser)


def run(args):
    from emla_core.bag import write_recording
    check_outputs({}, [args.data], args.force, {'BAGDIR': (args.bagdir, BAG)})
    recording = load_data(args)
    _require_measured(recording, args.data)
    write_output(args.bagdir, lambda temporary: write_recording(
        recording, temporary, custom_data={'imported_from': Path(args.data).name}), BAG)
    understood(recording, 'import')
    write_stdout(f'{args.bagdir}: {len(recording)} samples of {", ".join(recording.signals)} '
                 f'at {1.0 / recording.sample_period:g} Hz\n')
    return 0


def _require_measured(recording, data):
    """An InputError unless the record has the signals the suite identifies from (voltage, current and position,
    or force and position): a bag whose corrupt chunks held them would give a bag of its other topics only."""
    from emla_identification.regressors import default_model
    if default_model(recording.signals) is None:
        raise InputError(f'{data}: no measured voltage, current and position (or force and position) to import; '
                         f'it has {", ".join(recording.signals) or "no signals"}')
