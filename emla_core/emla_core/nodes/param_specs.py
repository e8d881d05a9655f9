"""The declared parameters of a node: specs with descriptors (ranges, units), the actuator's, declaring
them, and the control period in samples."""
import dataclasses
import types

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.parameter import Parameter

from emla_core.errors import InputError
from emla_core.parameters import FAMILIES, PARAMETER_UNITS, TABLE1
from emla_core.topics import to_ns


def period_samples(sample_period, control_period):
    """Samples per control period; the control period must be a whole number of samples of whole ns."""
    n = round(control_period / sample_period)
    if n < 1 or abs(n * sample_period - control_period) > 1e-9 * control_period \
            or abs(sample_period * 1e9 - to_ns(sample_period)) > 1e-6:
        raise InputError(f'control_period ({control_period} s) must be a whole multiple of sample_period '
                         f'({sample_period} s, a whole number of ns)')
    return n


@dataclasses.dataclass(frozen=True)
class Spec:
    """A node parameter: default (float, int, bool, str, or an array Parameter.Type meaning empty),
    description with units, and for numbers the inclusive range [low, high]."""
    name: str
    default: object
    description: str
    low: float | None = None
    high: float | None = None

    def descriptor(self):
        descriptor = ParameterDescriptor(description=self.description, read_only=True)
        if isinstance(self.default, bool) or self.low is None:
            return descriptor
        if isinstance(self.default, int):
            descriptor.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=0)]
        else:
            descriptor.floating_point_range = [FloatingPointRange(from_value=float(self.low),
                                                                  to_value=float(self.high), step=0.0)]
        return descriptor


_RANGES = {'resistance': (1e-3, 1e3), 'inductance': (1e-6, 10.0), 'emf_constant': (1e-3, 1e3),
           'mass': (1e-4, 1e3), 'damping': (0.0, 1e4), 'load_force': (-1e4, 1e4), 'supply_voltage': (0.1, 1e4)}
ACTUATOR_FIELDS = tuple(_RANGES)  # the ActuatorParameters fields


def actuator_specs(what):
    """Specs of the actuator parameters (Table 1 defaults); `what` starts their descriptions."""
    return [Spec(name, getattr(TABLE1, name), f'{what} {name.replace("_", " ")}, {PARAMETER_UNITS[name]}',
                 *_RANGES[name]) for name in _RANGES]


def family(actuator):
    """The `actuator` parameter's value checked: one of the families (emla_core.parameters.FAMILIES)."""
    if actuator not in FAMILIES:
        raise InputError(f'actuator {actuator!r} is not one of {", ".join(FAMILIES)}')
    return actuator


def solenoid_from(model_file):
    """The SolenoidParameters of a `model_file` parameter: a solenoid's model file, or empty for issue 24's valve
    (SolenoidParameters())."""
    from emla_core.model_file import read
    from emla_core.physics.solenoid import SolenoidParameters
    return read(model_file).require('solenoid', model_file).solenoid() if model_file else SolenoidParameters()


def declare(node, specs):
    """Declare `specs` on `node`; their values (arrays as lists, empty when unset) as a namespace. A value of
    the wrong type is a ParameterException (rclpy's check), or an InputError for an empty list where a single
    value is declared (rclpy takes that as unset)."""
    values = {}
    for spec in specs:
        parameter = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        if parameter.type_ == Parameter.Type.NOT_SET and not isinstance(spec.default, Parameter.Type):
            raise InputError(f'parameter {spec.name!r} is an empty list, expecting type '
                             f'{Parameter.Type.from_parameter_value(spec.default).name!r}')
        values[spec.name] = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else []
    return types.SimpleNamespace(**values)
