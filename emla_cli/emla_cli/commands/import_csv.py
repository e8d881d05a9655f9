"""`emla import`: measured data (CSV, MAT or another bag) into a rosbag2 directory of the suite's topics."""
import shutil
from pathlib import Path

from .inputs import DATA_HELP, add_data_arguments, load_data, understood
from .output import replace_bag

HELP = 'Convert measured data into a rosbag2 directory (MCAP) with the suite topics.'


def description():
    return """\
Convert a recording (CSV or MAT file, or a bag of other topics) into a rosbag2 directory (MCAP) of the
suite's topics. Each signal becomes a /emla/<signal> topic of SampleFrame messages (100 samples per
frame) in SI units, stamped from the data's time. `emla identify` gives the same answer on the data and on
the bag.

""" + DATA_HELP


def add_arguments(parser):
    parser.add_argument('data', metavar='DATA', help='CSV or MAT file, rosbag2 directory or .mcap file')
    parser.add_argument('bagdir', metavar='BAGDIR', help='rosbag2 directory to create (new or empty)')
    parser.add_argument('--force', action='store_true', help='replace BAGDIR if it holds a bag already')
    add_data_arguments(parser)


def run(args):
    from emla_core.bag import write_recording
    recording = load_data(args)
    bag = Path(args.bagdir)
    replace_bag(bag, args.force)
    existed = bag.is_dir()
    fresh = not existed or not any(bag.iterdir())  # else write_recording refuses it, and it is left alone
    try:
        write_recording(recording, bag, custom_data={'imported_from': Path(args.data).name})
    except BaseException:
        # an interrupted or failed import must not leave a bag that reads as complete
        if fresh and bag.exists():
            shutil.rmtree(bag)
            if existed:
                bag.mkdir()
        raise
    understood(recording, 'import')
    print(f'{bag}: {len(recording)} samples of {", ".join(recording.signals)} '
          f'at {1.0 / recording.sample_period:g} Hz')
    return 0
