"""The estimates over time as a table and a CSV file (`emla identify --trajectory`): a GreyBoxResult's
trajectory, one row per estimate, columns `t` (s) then each parameter `<name>` and its one-sigma
`<name>_std`, SI units. With forgetting the rows follow a drifting plant (a coil warming up); without, they
show the estimates converging. A figure that cannot be computed (an uncertainty before enough excitation)
is an empty cell, as it is null in the JSON."""
from pathlib import Path

import numpy as np

MAX_ROWS = 10_000   # rows `emla identify --trajectory` writes at most (each costs an estimate of its own)


def trajectory_table(trajectory):
    """The trajectory as a pyarrow Table: `t` (s), then `<name>`, `<name>_std` per parameter (SI).

    Parameters
    ----------
    trajectory : emla_identification.greybox.Trajectory
        time (K,), parameters and std ({name: (K,) array}); a GreyBoxResult's `trajectory`.

    Returns
    -------
    pyarrow.Table
        float64 columns; non-finite values are nulls.
    """
    import pyarrow as pa
    columns = {'t': trajectory.time}
    for name, values in trajectory.parameters.items():
        columns[name] = values
        columns[f'{name}_std'] = trajectory.std[name]
    arrays = {}
    for name, values in columns.items():
        values = np.asarray(values, dtype=float).reshape(-1)
        arrays[name] = pa.array(values, type=pa.float64(), mask=~np.isfinite(values))
    return pa.table(arrays)


def write_trajectory(trajectory, path: Path | str) -> None:
    """Write the trajectory as CSV: a header `t,<name>,<name>_std,...` and one row per estimate, each number
    in the shortest form that reads back to the same float; an empty cell where it is not finite.

    Parameters
    ----------
    trajectory : emla_identification.greybox.Trajectory
        A GreyBoxResult's `trajectory`.
    path : str or Path
        The file to write (replaced if it exists).
    """
    table = trajectory_table(trajectory)
    columns = [column.to_pylist() for column in table.columns]
    with open(path, 'w', encoding='ascii', newline='') as f:
        f.write(','.join(table.column_names) + '\n')
        for row in zip(*columns, strict=True):
            f.write(','.join('' if value is None else repr(value) for value in row) + '\n')


def trajectory_points(duration, interval, sample_period):
    """How many estimates a trajectory of one per `interval` s over a record of `duration` s holds:
    ceil(duration / interval).

    Parameters
    ----------
    duration, interval, sample_period : float
        s.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        An interval shorter than the sample period, or more than MAX_ROWS rows; the message says why.
    """
    if interval < sample_period * (1 - 1e-9):
        raise ValueError(f'{interval:g} s is shorter than the sample period ({sample_period:g} s): at most one '
                         f'row per sample')
    points = max(1, int(np.ceil(duration / interval - 1e-9)))
    if points > MAX_ROWS:
        raise ValueError(f'{interval:g} s gives {points} rows over the {duration:g} s record, more than the '
                         f'{MAX_ROWS} a trajectory file holds: choose at least {duration / MAX_ROWS:.3g} s')
    return points
