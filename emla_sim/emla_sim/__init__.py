"""emla_sim: the simulated actuator and its sensors.

    Plant(params, effects, changes)   the two-equation actuator, advanced over zero-order-hold voltage
                                      intervals (exact discretisation; RK4 sub-steps with effects)
    Sensor(SensorConfig(...))         DSP-like sampling: current noise, position quantisation, delay
    effects=[...]                     the effects a real actuator has that the model lacks: those of the
                                      physics layer (emla_core.physics.EFFECTS), by name or instance
    ParameterChange(time, name, factor)  a step change of a parameter during a run
    closed_loop(params, duration)     a Recording of the actuator under a PID position loop (test data)
    SolenoidPlant(params)             a solenoid (emla_core.physics.SolenoidParameters), with end stops
    solenoid.record(params, duration) a Recording of it under a voltage that moves it across its stroke

Examples
--------
>>> from emla_core import TABLE1
>>> from emla_core.physics import CoulombFriction
>>> from emla_sim import Plant
>>> plant = Plant(TABLE1, effects=[CoulombFriction(coulomb_force=1.0)])
>>> current, position, velocity = plant.step(12.0, 1e-4)   # hold 12 V for one 0.1 ms sample
"""
from emla_core.exports import lazy_exports

_EXPORTS = {  # name -> the module that holds it
    'Plant': 'plant',
    'Sensor': 'sensor', 'SensorConfig': 'sensor',
    'ParameterChange': 'effects',
    'SolenoidPlant': 'solenoid',
    'closed_loop': 'datasets', 'force_driven': 'datasets',
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
