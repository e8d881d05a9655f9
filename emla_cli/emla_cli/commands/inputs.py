"""What the commands that read data share: the data flags, loading with them, and what was understood."""
import math
import numbers
import sys
from pathlib import Path

from emla_core.errors import InputError

from .numbers import add_number

DATA_HELP = """\
Data in your own names and units (CSV, MATLAB .mat, rosbag2 directory in MCAP or sqlite3, .mcap file):
  --columns voltage=u_V,current=i_mA,position=x_mm,t=time_ms   which column or MAT variable holds what
  --units current=mA,position=mm,t=ms                           units (a leading minus flips the sign)
  --topics voltage=/u,current=/i,position=/joint_states:position[0]   bag topics of standard messages
  --start 1.5 --end 4                                            only the part from t = 1.5 s to before 4 s
Column headers like x_mm, x [mm] or x (mm) give their unit without flags. A CSV file may start with a byte
order mark (Excel's "CSV UTF-8"), quote its header, and use ';' or tabs with decimal commas: this is seen from
its first lines, else say it with --delimiter ';' --decimal ','. Timestamps that jitter (by up to 10 % of the
period) are read at their steady rate. A row repeated exactly (time and values) is dropped with a warning.
Missing samples (a logger that drops some, a bag's lost frames) are never bridged: the grey-box
identification takes the record in segments (no row spans a gap; the JSON lists segments and gaps), the other
commands name the gaps and the part without them to take with --start/--end."""
JITTER_NOTE = 1e-3  # relative jitter from which the command says on stderr that it read the steady rate
WINDOW_LIMIT = 1e12  # s: --start and --end (a bag's stamps count from 1970, some 1.7e9 s)


def add_data_arguments(parser, window=True):
    """The data flags; `window`: with --start/--end (for a command that reads one record with load_data)."""
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
    if window:
        add_number(group, '--start', low=-WINDOW_LIMIT, high=WINDOW_LIMIT, unit='s', metavar='S',
                   help='read the record from t = S s on (its own time axis; default: its start)')
        add_number(group, '--end', low=-WINDOW_LIMIT, high=WINDOW_LIMIT, unit='s', metavar='E',
                   help='read the record up to before t = E s (default: to its end)')


def foreign(args):
    """Whether any data flag is given."""
    return any(getattr(args, flag) is not None
               for flag in ('columns', 'units', 'topics', 'sample_period', 'delimiter', 'decimal'))


def load_data(args, path=None, gaps=False):
    """The Recording of `path` (default: args.data) read with the data flags; `gaps`: in segments where samples
    are missing (for the grey-box identification), else such a record is refused (emla_core.data.load), as is
    a MATLAB file none of whose variables holds a signal (`_no_mat_signals`)."""
    from emla_core.data import load
    path = path or args.data
    recording = load(path, columns=args.columns, units=args.units, topics=args.topics,
                     sample_period=args.sample_period, delimiter=args.delimiter, decimal=args.decimal,
                     start=args.start, end=args.end, gaps=gaps)
    if not recording.signals and Path(path).suffix.lower() == '.mat' and Path(path).is_file():
        raise _no_mat_signals(path, recording)
    return recording


def _no_mat_signals(path, recording):
    """The InputError for a MATLAB file where no variable was taken for a signal, listing its numeric vectors
    and their lengths: only the chosen variables are read, so the record cannot name the others (as a CSV
    file's record does its unmapped columns, which the commands' errors list)."""
    from emla_core.tables import mat_vectors
    time = recording.inputs.get('t', {}).get('source')
    vectors = ', '.join(f'{name} ({length} values{", read as the time" if name == time else ""})'
                        for name, length in mat_vectors(path).items())
    return InputError(f'{path}: no variable holds voltage, current, position or force; its numeric vectors are '
                      f'{vectors}: map yours with --columns voltage=NAME,current=NAME,position=NAME')


def understood(recording, command):
    """{'inputs', 'sampling'} of the JSON where the data were foreign (mapped, converted, jittered or
    resampled) or reading them dropped rows; a note on stderr when the time was read at a steady rate behind
    jittered stamps, or signals were interpolated, and a warning for each row dropped (the command's JSON
    `warnings` take them: reading_warnings). Data in the suite's own names and SI units get neither."""
    sampling = recording.sampling
    jitter = sampling.get('jitter', 0.0)
    plain = all(source.get('source') == name and source.get('scale') == 1.0
                for name, source in recording.inputs.items())
    for message in reading_warnings(recording):
        print(f'emla {command}: warning: {message}', file=sys.stderr)
    if plain and jitter <= JITTER_NOTE and 'how' not in sampling and not reading_warnings(recording):
        return {}
    if jitter > JITTER_NOTE:
        print(f'emla {command}: note: timestamps jitter by up to {jitter:.1%} of the period; read at the steady '
              f'{1 / sampling["period"]:.6g} Hz', file=sys.stderr)
    if 'linearly' in sampling.get('how', ''):
        print(f'emla {command}: note: {sampling["how"]}', file=sys.stderr)
    return {'inputs': recording.inputs, 'sampling': sampling}


def reading_warnings(recording):
    """The warnings of reading the record (rows dropped), which `understood` prints."""
    return list(recording.sampling.get('warnings', ()))


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
