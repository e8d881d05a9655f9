"""A scenario as the ROS graph runs it: the parameters of each node (`emla launch`)."""
import dataclasses
from pathlib import Path

import numpy as np

from emla_core.errors import InputError

from .scenarios import ONLINE_EFFECTS, Scenario
from .valve import ValveScenario


def scenario_parameters(scenario: Scenario | ValveScenario,
                        directory: str | Path | None = None) -> dict[str, dict[str, object]]:
    """The node parameters that make the graph run a scenario's graph case.

    A moving coil's control period stays the nodes' own (1 ms frames), as do the controller's gains tuned for it.
    A solenoid valve's (ValveScenario) is its sample period, as in-process; its nodes read its solenoid from a
    model file written into `directory`.

    Parameters
    ----------
    scenario : Scenario or ValveScenario
        The scenario (emla_bench.scenarios); its `graph_case` says whether the plant is changed and the
        controller adapts.
    directory : str or Path, optional
        Where a solenoid scenario's model file goes (it must outlive the graph's run); a solenoid's needs it.

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

    if isinstance(scenario, ValveScenario):
        if directory is None:
            raise ValueError(f'scenario {scenario.name}: a solenoid\'s parameters need a directory for its model file')
        return _valve_parameters(scenario, Path(directory) / 'solenoid.yaml')
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


# s: the changed plant's R rises in steps this long over the scenario's warming (in-process: a step a frame)
RESISTANCE_STEP = 1e-3


def _valve_parameters(scenario, model_path):
    """scenario_parameters of a solenoid valve: its solenoid in the model file `model_path` for the plant, the
    identifier (which follows its R) and the controller; R's rise as steps of RESISTANCE_STEP."""
    from emla_control import solenoid as law
    from emla_core.model_file import Model, read, write
    from emla_core.physics.solenoid import SOLENOID_PARAMETER_NAMES

    params = scenario.params
    names = SOLENOID_PARAMETER_NAMES + ('stroke_min', 'stroke_max')
    write(Model(scenario.sample_period, {name: (getattr(params, name), None) for name in names},
                actuator='solenoid', provenance={'data': f'scenario {scenario.name}'}), model_path)
    if read(model_path).solenoid() != params:
        raise InputError(f'scenario {scenario.name}: its solenoid has what a model file does not carry (supply '
                         'voltage, friction)')
    changed, adaptive = scenario.cases[scenario.graph_case]
    solenoid = {'actuator': 'solenoid', 'model_file': str(model_path), 'sample_period': scenario.sample_period}
    plant = {**solenoid, 'control_period': scenario.sample_period,
             'initial_position': float(np.mean(scenario.reference(0.0)[0]))}
    if changed:
        start, end = scenario.warming
        times = start + RESISTANCE_STEP * np.arange(1, round((end - start) / RESISTANCE_STEP) + 1)
        levels = [scenario.resistance(float(t), True) for t in (start, *times)]
        plant.update(change_times=times.tolist(), change_parameters=['resistance'] * len(times),
                     change_factors=[float(after / before) for before, after in zip(levels, levels[1:])])
    reference = scenario.reference
    return {
        'plant': plant,
        'sensor': {'seed': scenario.seed, 'control_period': scenario.sample_period},
        'identifier': {**solenoid, 'memory_time': scenario.memory_time, 'measured_frames': True},
        'controller': {**solenoid, 'control_period': scenario.sample_period, 'adaptive': adaptive,
                       'min_samples': round(scenario.memory_time / scenario.sample_period), 'measured_frames': True,
                       'bandwidth': law.DEFAULT_BANDWIDTH, 'damping_ratio': law.DEFAULT_DAMPING,
                       'observer_bandwidth': law.DEFAULT_OBSERVER_BANDWIDTH, 'flux_time': law.DEFAULT_FLUX_TIME,
                       'stroke': reference.stroke, 'reference_period': reference.period,
                       'transition': reference.transition, 'reference_offset': reference.offset},
    }
