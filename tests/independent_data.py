"""Measured data the suite did not make: an actuator simulated here, independently of emla_sim, and written
in the forms a user's data come in (CSV in their own units, MATLAB files, a bag of standard messages with
jittered log times).

The actuator is the linear two-equation model x' = A x + B [u, Fl] with state [I, position, velocity],
discretised exactly for a voltage held over each sample (scipy.signal.cont2discrete, zero-order hold),
under a PD position loop with a small random dither on a square stroke. The sensor adds Gaussian current
noise and quantises the position.

Regenerate the example files of the README (docs/examples/):
    .venv/bin/python tests/independent_data.py
"""
import sys
from pathlib import Path

import numpy as np
from scipy.signal import cont2discrete

# Not Table 1: another actuator, so nothing of the suite's defaults can help.
TRUTH = {'resistance': 3.2, 'inductance': 2.1e-3, 'emf_constant': 8.5, 'mass': 0.05, 'damping': 3.0,
         'load_force': 0.0}
EXAMPLES = Path(__file__).resolve().parent.parent / 'docs' / 'examples'


def simulate(duration=0.5, sample_period=1e-4, seed=7, truth=TRUTH, current_noise=5e-3, resolution=1e-6,
             velocity_noise=None):
    """(t, voltage, current, position) in SI: voltage held over [t_k, t_k + Ts), current and position sampled
    at t_k (noisy, quantised); with velocity_noise (m/s), a tachometer's velocity at t_k (Gaussian noise) too,
    as a fifth array."""
    r, ind, km, m, b, fl = (truth[k] for k in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping',
                                                 'load_force'))
    a = np.array([[-r / ind, 0.0, -km / ind], [0.0, 0.0, 1.0], [km / m, 0.0, -b / m]])
    bu = np.array([[1 / ind, 0.0], [0.0, 0.0], [0.0, -1 / m]])
    ad, bd, *_ = cont2discrete((a, bu, np.eye(3), np.zeros((3, 2))), sample_period, method='zoh')
    rng = np.random.default_rng(seed)
    n = int(round(duration / sample_period))
    state = np.zeros(3)
    voltage, current, position, velocity = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    previous = 0.0
    for k in range(n):
        if velocity_noise is not None:   # (drawn only then: the other records stay as they were)
            velocity[k] = state[2] + velocity_noise * rng.standard_normal()
        current[k] = state[0] + current_noise * rng.standard_normal()
        position[k] = np.round(state[1] / resolution) * resolution
        target = 2e-3 if (k * sample_period) % 0.04 < 0.02 else 0.0
        speed = (position[k] - previous) / sample_period
        previous = position[k]
        u = 8000.0 * (target - position[k]) - 20.0 * speed + 0.5 * rng.standard_normal()
        voltage[k] = min(max(u, -24.0), 24.0)
        state = ad @ state + bd @ np.array([voltage[k], fl])
    t = sample_period * np.arange(n)
    return (t, voltage, current, position) if velocity_noise is None else (t, voltage, current, position, velocity)


def write_csv(path, t, voltage, current, position):
    """time_ms,u_V,i_mA,x_mm: a logger's own names and units."""
    table = np.column_stack((t * 1e3, voltage, current * 1e3, position * 1e3))
    np.savetxt(path, table, delimiter=',', header='time_ms,u_V,i_mA,x_mm', comments='', fmt='%.9g')


def write_mat(path, t, voltage, current, position, hdf5=False):
    """A MATLAB file with vectors time, coil_voltage, coil_current, stroke (SI); v7.3 (HDF5) if `hdf5`."""
    variables = {'time': t, 'coil_voltage': voltage, 'coil_current': current, 'stroke': position}
    if hdf5:
        import h5py
        with h5py.File(path, 'w', userblock_size=512) as f:   # MATLAB v7.3 layout: a 512-byte header, HDF5
            for name, values in variables.items():
                f[name] = values[None, :]                      # 1 x N, as MATLAB stores a row vector
    else:
        import scipy.io
        scipy.io.savemat(path, {k: v[:, None] for k, v in variables.items()})


def write_bag(path, t, voltage, current, position, storage='mcap', jitter=0.05, seed=3):
    """A rosbag2 of standard messages: /joint_states (sensor_msgs/JointState, the actuator's joint 'slider'
    beside a second joint, stamped with the sample times), /drive/voltage and /drive/current (std_msgs/Float64,
    no header: only their log times, which jitter by up to +-`jitter` of the period)."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    types = store.types
    rng = np.random.default_rng(seed)
    ts = t[1] - t[0]
    start = 1_700_000_000_000_000_000   # log times since the epoch, as a recorder stores them
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    writer = Writer(path, version=9, storage_plugin=plugin)
    if storage == 'mcap':
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)   # zstd chunks, as ros2 bag does
    with writer:
        joints = writer.add_connection('/joint_states', 'sensor_msgs/msg/JointState', typestore=store)
        drive = {name: writer.add_connection(f'/drive/{name}', 'std_msgs/msg/Float64', typestore=store)
                 for name in ('voltage', 'current')}
        for k in range(len(t)):
            stamp = start + int(round(t[k] * 1e9))
            header = types['std_msgs/msg/Header'](
                stamp=types['builtin_interfaces/msg/Time'](sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id='')
            state = types['sensor_msgs/msg/JointState'](
                header=header, name=['valve', 'slider'], position=np.array([0.0, position[k]]),
                velocity=np.zeros(2), effort=np.zeros(2))
            writer.write(joints, stamp + 30_000, store.serialize_cdr(state, 'sensor_msgs/msg/JointState'))
            for name, values in (('voltage', voltage), ('current', current)):
                logged = stamp + int(round(rng.uniform(-jitter, jitter) * ts * 1e9)) + 50_000
                writer.write(drive[name], logged,
                             store.serialize_cdr(types['std_msgs/msg/Float64'](data=float(values[k])),
                                                 'std_msgs/msg/Float64'))


def write_examples(directory=EXAMPLES):
    """The README's example files: the same 0.3 s of data as a CSV, a MATLAB file and a bag."""
    directory.mkdir(parents=True, exist_ok=True)
    data = simulate(duration=0.3)
    write_csv(directory / 'logger.csv', *data)
    write_mat(directory / 'scope.mat', *data)
    bag = directory / 'drive_bag'
    if bag.exists():
        import shutil
        shutil.rmtree(bag)
    write_bag(bag, *data)


if __name__ == '__main__':
    write_examples(Path(sys.argv[1]) if len(sys.argv) > 1 else EXAMPLES)
