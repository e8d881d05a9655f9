"""emla_core: what every emla package uses.

Actuator parameters and their SI units (`ActuatorParameters`, `TABLE1`), the one error type for bad input
(`InputError`), sampled recordings (`Recording`) and loading them from CSV files or bags (`load`), the topic
names and message builders of the ROS 2 graph (`emla_core.topics`, `emla_core.messages`), rosbag2 writing and
reading (`emla_core.bag`), and the node plumbing and the recorder node (`emla_core.nodes`).

Examples
--------
>>> from emla_core import load
>>> recording = load('run.csv')                     # doctest: +SKIP
>>> recording.sample_period, sorted(recording.signals)  # doctest: +SKIP
(0.0001, ['current', 'position', 'voltage'])
"""
from emla_core.data import load
from emla_core.errors import InputError
from emla_core.parameters import PARAMETER_NAMES, PARAMETER_UNITS, TABLE1, ActuatorParameters
from emla_core.data import read_csv
from emla_core.recording import Recording, write_csv

__all__ = ['ActuatorParameters', 'InputError', 'PARAMETER_NAMES', 'PARAMETER_UNITS', 'Recording', 'TABLE1', 'load',
           'read_csv', 'write_csv']
