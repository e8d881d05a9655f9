"""emla_bench: the closed-loop bench, above the simulated plant (emla_sim) and the controller (emla_control).

    run_closed_loop(plant, controller, reference, duration, ...)   the in-process lockstep loop: plant,
                                      sensor, online identifier and controller
    run_scenario(name)                a named comparison (resistance_rise, mass_rise, thermal_drift,
                                      friction_and_spring, default; a solenoid valve's valve_resistance_rise):
                                      tracking metrics of each case; SCENARIOS holds them
    scenario_parameters(scenario, directory)   a scenario as the ROS graph runs it: {node: {parameter:
                                      value}} (a solenoid's model file written into directory)

Examples
--------
>>> from emla_bench import run_scenario
>>> result = run_scenario('resistance_rise')              # doctest: +SKIP
>>> result.metrics['changed_adaptive']['rms_tracking_error']  # doctest: +SKIP
4.1e-07
"""
from emla_core.exports import lazy_exports

_EXPORTS = {  # name -> the module that holds it
    'run_closed_loop': 'loop', 'LoopResult': 'loop',
    'Scenario': 'scenarios', 'SCENARIOS': 'scenarios', 'run_scenario': 'scenarios',
    'tracking_metrics': 'scenarios',
    'scenario_parameters': 'node_parameters',
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
