"""A scenario as the ROS graph runs it: the parameters of each node (`emla launch`)."""
import dataclasses

from emla_core.errors import InputError

from .scenarios import ONLINE_EFFECTS, Scenario


def scenario_parameters(scenario: Scenario) -> dict[str, dict[str, object]]:
    """The node parameters that make the graph run a scenario's graph case.

    The control period stays the nodes' own (1 ms frames), as do the controller's gains tuned for it.

    Parameters
    ----------
    scenario : Scenario
        The scenario (emla_bench.scenarios); its `graph_case` says whether the plant is changed and the
        controller adapts.

    Returns
    -------
    dict
        {node: {parameter: value}} for the plant, sensor, identifier and controller nodes.

    Raises
    ------
    InputError
        If the scenario changes a parameter other than by a factor (the plant node takes factors only).
    """
    from emla_core.nodes.param_specs import ACTUATOR_FIELDS

    changed, adaptive = scenario.cases[scenario.graph_case]
    actuator = {name: getattr(scenario.params, name) for name in ACTUATOR_FIELDS}
    plant = {**actuator, 'sample_period': scenario.sample_period}
    effects = scenario.model_effects + (scenario.effects if changed else ())
    if effects:
        plant['effects'] = [effect.name for effect in effects]
        plant['effect_parameters'] = [f'{effect.name}.{f.name}={getattr(effect, f.name)!r}'
                                      for effect in effects for f in dataclasses.fields(effect)]
    if changed and scenario.changes:
        if any(change.factor is None for change in scenario.changes):
            raise InputError(f'scenario {scenario.name}: the plant node takes parameter changes as factors only')
        plant['change_times'] = [float(change.time) for change in scenario.changes]
        plant['change_parameters'] = [change.parameter for change in scenario.changes]
        plant['change_factors'] = [float(change.factor) for change in scenario.changes]
    reference = scenario.reference
    online = scenario.graph_case in scenario.compensated  # the friction and spring estimated online, compensated
    return {
        'plant': plant,
        'sensor': {'seed': scenario.seed},
        'identifier': {'sample_period': scenario.sample_period, 'memory_time': scenario.memory_time,
                       'measured_frames': True,
                       'effects': list(ONLINE_EFFECTS if online else ())},
        'controller': {**actuator, **scenario.controller_effects, 'sample_period': scenario.sample_period,
                       'adaptive': adaptive, 'adapt_effects': online, 'measured_frames': True,
                       'stroke': reference.stroke, 'reference_period': reference.period,
                       'transition': reference.transition},
    }
