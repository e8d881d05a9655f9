"""The built-in effects, one file each; importing this package registers them (effect.register_effect)."""
from . import (  # noqa: F401
               coulomb_friction,
               drive_voltage_error,
               force_constant_variation,
               inductance_saturation,
               position_inductance,
               resistance_drift,
               return_spring,
               sensor_delay,
               sensor_filter,
               smooth_friction,
               stribeck_friction,
)
