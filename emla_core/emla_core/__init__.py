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
from emla_core.exports import lazy_exports

_EXPORTS = {'ActuatorParameters': 'parameters', 'InputError': 'errors', 'PARAMETER_NAMES': 'parameters',
            'PARAMETER_UNITS': 'parameters', 'Recording': 'recording', 'TABLE1': 'parameters', 'load': 'data',
            'read_csv': 'data', 'write_csv': 'recording'}

__all__ = ['ActuatorParameters', 'InputError', 'PARAMETER_NAMES', 'PARAMETER_UNITS', 'Recording', 'TABLE1', 'load',
           'read_csv', 'write_csv']
# loaded on first use: a node that imports one module of emla_core does not load the data readers (scipy)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
