"""The actuator's physics, written once for every package (docs/physics.md §2 and §6).

`equations` holds the electromechanical equations in their general flux-linkage / co-energy form; `effect` the
effects' one parameterisation and their registry (`EFFECTS`, `register_effect`), each built-in effect a file
of `effects/` holding its plant terms, its discrepancy candidate (`candidate`, `CANDIDATES`), its online column
(`online`), its compensation by the inverse law and its model-file form; `kernel` the plant's compiled
right-hand side; `solenoid` the solenoid (reluctance actuator) family's parameters, magnetic circuit and compiled
plant step, through the same right-hand side. The plant (emla_sim), the controller's model (emla_control), the
identification and the model file read them instead of copies.
"""
from . import effects as _builtin  # noqa: F401  (registers the built-in effects)
from .candidate import CANDIDATES, Candidate, register_candidate
from .effect import AMBIENT_TEMPERATURE, EFFECTS, Effect, Parameter, make_effect, register_effect
from .effects.coulomb_friction import CoulombFriction
from .effects.drive_voltage_error import DriveVoltageError
from .effects.force_constant_variation import ForceConstantVariation
from .effects.inductance_saturation import InductanceSaturation
from .effects.position_inductance import PositionInductance
from .effects.resistance_drift import ResistanceDrift
from .effects.return_spring import ReturnSpring
from .effects.sensor_delay import SensorDelay
from .effects.sensor_filter import SensorFilter
from .effects.smooth_friction import SmoothFriction
from .effects.stribeck_friction import StribeckFriction
from .equations import coil_rates, friction_force
from .online import OnlineColumn
from .solenoid import SolenoidParameters

__all__ = ['AMBIENT_TEMPERATURE', 'CANDIDATES', 'EFFECTS', 'Candidate', 'CoulombFriction', 'DriveVoltageError',
           'Effect', 'ForceConstantVariation', 'InductanceSaturation', 'OnlineColumn', 'Parameter',
           'PositionInductance', 'ResistanceDrift', 'ReturnSpring', 'SensorDelay', 'SensorFilter', 'SmoothFriction',
           'SolenoidParameters',
           'StribeckFriction', 'coil_rates', 'friction_force', 'make_effect', 'register_candidate', 'register_effect']
