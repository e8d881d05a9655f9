"""Convert a CSV recording into a rosbag2 directory (MCAP) with the suite topics.

Each column becomes a /emla/<column> topic of SampleFrame messages (100 samples per frame) stamped from
the `t` column; `emla identify` gives the same answer on the CSV and on the bag.
"""
import shutil
from pathlib import Path

HELP = 'Convert a CSV recording into a rosbag2 directory (MCAP) with the suite topics.'


def description():
    return """\
Convert a CSV recording into a rosbag2 directory (MCAP) of the suite's topics.

Each column becomes a /emla/<column> topic of SampleFrame messages (100 samples per frame), stamped from
the t column (s). `emla identify` gives the same answer on the CSV and on the bag.
"""


def add_arguments(parser):
    parser.add_argument('csv', metavar='CSV', help='CSV file with a header row and a t column (s)')
    parser.add_argument('bagdir', metavar='BAGDIR', help='rosbag2 directory to create (new or empty)')


def run(args):
    from emla_core.bag import write_recording
    from emla_core.recording import read_csv
    recording = read_csv(args.csv)
    bag = Path(args.bagdir)
    existed = bag.is_dir()
    fresh = not existed or not any(bag.iterdir())  # else write_recording refuses it, and it is left alone
    try:
        write_recording(recording, bag, custom_data={'imported_from': Path(args.csv).name})
    except BaseException:
        # an interrupted or failed import must not leave a bag that reads as complete
        if fresh and bag.exists():
            shutil.rmtree(bag)
            if existed:
                bag.mkdir()
        raise
    print(f'{bag}: {len(recording)} samples of {", ".join(recording.signals)} '
          f'at {1.0 / recording.sample_period:g} Hz')
    return 0
