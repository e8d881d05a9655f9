"""emla_control: adaptive inverse-system position control of an electromagnetic linear actuator.

    InverseSystemController(params)   the inverse-system law with state feedback, an observer, and a guard
                                      on the identified parameters it is offered
    StrokeReference()                 the 40 ms out-and-back stroke with continuous s', s'', s'''
    run_closed_loop(plant, controller, reference, duration, ...)   the in-process lockstep loop
    run_scenario(name)                a named comparison (resistance_rise, mass_rise, thermal_drift, default):
                                      tracking metrics of each case; SCENARIOS holds them

Examples
--------
>>> from emla_control import run_scenario
>>> result = run_scenario('resistance_rise')              # doctest: +SKIP
>>> result.metrics['changed_adaptive']['rms_tracking_error']  # doctest: +SKIP
4.1e-07
"""
from emla_core.exports import lazy_exports

_EXPORTS = {  # name -> the module that holds it
    'InverseSystemController': 'controller',
    'StrokeReference': 'reference',
    'run_closed_loop': 'loop', 'LoopResult': 'loop',
    'Scenario': 'scenarios', 'SCENARIOS': 'scenarios', 'run_scenario': 'scenarios',
    'tracking_metrics': 'scenarios',
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
