"""What the commands that read data share: the data flags, loading with them, and what was understood."""
import math
import numbers
import sys

from .numbers import add_number

DATA_HELP = """\
Data in your own names and units (CSV, MATLAB .mat, rosbag2 directory in MCAP or sqlite3, .mcap file):
  --columns voltage=u_V,current=i_mA,position=x_mm,t=time_ms   which column or MAT variable holds what
  --units current=mA,position=mm,t=ms                           units (a leading minus flips the sign)
  --topics voltage=/u,current=/i,position=/joint_states:position[0]   bag topics of standard messages
Column headers like x_mm, x [mm] or x (mm) give their unit without flags. A CSV file may start with a byte
order mark (Excel's "CSV UTF-8"), quote its header, and use ';' or tabs with decimal commas: this is seen from
its first lines, else say it with --delimiter ';' --decimal ','. Timestamps that jitter (by up to 10 % of the
period) are read at their steady rate; missing samples are named and refused."""
JITTER_NOTE = 1e-3  # relative jitter from which the command says on stderr that it read the steady rate


def add_data_arguments(parser):
    group = parser.add_argument_group('data in your own names and units')
    group.add_argument('--columns', metavar='NAME=SOURCE[,...]',
                       help='CSV column or MAT variable of each signal NAME (t, voltage, current, position, '
                            'velocity, force)')
    group.add_argument('--units', metavar='NAME=UNIT[,...]',
                       help='unit of each signal: s, ms, us, m, mm, um, A, mA, V, mV, N, rad, deg, ... or a '
                            'factor to SI; a leading minus flips the sign (current=-A)')
    group.add_argument('--topics', metavar='NAME=TOPIC[:FIELD[INDEX]][,...]',
                       help='bag topics of std_msgs Float64/Float32, Float64MultiArray, sensor_msgs JointState '
                            '(position|velocity|effort, joint by index or name) or emla_msgs SampleFrame')
    add_number(group, '--sample-period', low=1e-9, high=3600, unit='s', metavar='S',
               help='sample period in s of data without a time column')
    group.add_argument('--delimiter', choices=(',', ';', '|', 'tab'),
                       help='delimiter of a CSV file (default: found from its header)')
    group.add_argument('--decimal', choices=('.', ','),
                       help='decimal mark of a CSV file (default: , if the delimiter is not and the rows have one)')


def foreign(args):
    """Whether any data flag is given."""
    return any(getattr(args, flag) is not None
               for flag in ('columns', 'units', 'topics', 'sample_period', 'delimiter', 'decimal'))


def load_data(args, path=None):
    """The Recording of `path` (default: args.data) read with the data flags."""
    from emla_core.data import load
    return load(path or args.data, columns=args.columns, units=args.units, topics=args.topics,
                sample_period=args.sample_period, delimiter=args.delimiter, decimal=args.decimal)


def understood(recording, command):
    """{'inputs', 'sampling'} of the JSON where the data were foreign (mapped, converted, jittered or
    resampled); a note on stderr when the time was read at a steady rate behind jittered stamps, or signals
    were interpolated. Data in the suite's own names and SI units get neither."""
    sampling = recording.sampling
    jitter = sampling.get('jitter', 0.0)
    plain = all(source.get('source') == name and source.get('scale') == 1.0
                for name, source in recording.inputs.items())
    if plain and jitter <= JITTER_NOTE and 'how' not in sampling:
        return {}
    if jitter > JITTER_NOTE:
        print(f'emla {command}: note: timestamps jitter by up to {jitter:.1%} of the period; read at the steady '
              f'{1 / sampling["period"]:.6g} Hz', file=sys.stderr)
    if 'linearly' in sampling.get('how', ''):
        print(f'emla {command}: note: {sampling["how"]}', file=sys.stderr)
    return {'inputs': recording.inputs, 'sampling': sampling}


def unknown_figures(result, path=''):
    """A message for each figure of `result` (dicts and lists at any depth) that is not a finite number, which
    the JSON gives as null: it cannot be computed from these data."""
    if isinstance(result, dict):
        return [m for key, value in result.items() if key != 'warnings'
                for m in unknown_figures(value, _member(path, key))]
    if isinstance(result, (list, tuple)):
        return [m for j, value in enumerate(result) for m in unknown_figures(value, f'{path}[{j}]')]
    if isinstance(result, numbers.Real) and not math.isfinite(result):
        return [f'{path} cannot be computed from these data (null in the JSON)']
    return []


def _member(path, key):
    """path.key, or path["key"] for a key that is not a plain name (a file path)."""
    key = str(key)
    return (f'{path}.{key}' if path else key) if key.isidentifier() else f'{path}[{key!r}]'


def warn(messages, command):
    """Print each warning as one line on stderr; the list, for the JSON."""
    for message in messages:
        print(f'emla {command}: warning: {message}', file=sys.stderr)
    return list(messages)
