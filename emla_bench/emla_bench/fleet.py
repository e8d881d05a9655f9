"""A long run as many recordings: the actuator's parameters at each recording's hour (a coil warming, a step in
one parameter at a chosen hour), for `emla simulate --fleet` and the trend's demonstration and benchmark."""
import math
from dataclasses import dataclass

from emla_core.errors import InputError
from emla_core.limits import STAMP_LIMIT, STAMP_LIMIT_S
from emla_core.parameters import PARAMETER_BOUNDS, PARAMETER_NAMES, PARAMETER_UNITS, ActuatorParameters

HOUR = 3600.0
PAPER_RISE = 0.267     # the source paper: R from 0.45 to 0.57 ohm over its 100 hours


@dataclass(frozen=True)
class Step:
    """A parameter multiplied by `factor` from `hour` on."""
    name: str
    factor: float
    hour: float


def parse_step(text: str) -> Step:
    """NAME=FACTOR@HOUR ('damping=1.3@60') as a Step; InputError in one line otherwise."""
    try:
        name, rest = text.split('=', 1)
        factor, hour = (float(v) for v in rest.split('@'))
    except ValueError:
        raise InputError(f'--step {text}: give NAME=FACTOR@HOUR, e.g. damping=1.3@60') from None
    if name not in PARAMETER_NAMES:
        raise InputError(f'--step {text}: {name!r} is not a parameter; one of {", ".join(PARAMETER_NAMES)}')
    if not (math.isfinite(factor) and factor > 0 and math.isfinite(hour) and hour >= 0):
        raise InputError(f'--step {text}: need FACTOR > 0 and HOUR >= 0')
    return Step(name, factor, hour)


def long_run(base: ActuatorParameters, hours: float, every: float, *, resistance_rise: float = PAPER_RISE,
             thermal_time: float = 20.0, steps: tuple = ()) -> list:
    """[(start s, ActuatorParameters)] of one recording every `every` hours over `hours` hours.

    Parameters
    ----------
    base : ActuatorParameters
        The actuator at hour 0.
    hours, every : float
        The run's length and the time between recordings, hours (recordings at 0, every, 2 every, ... < hours).
    resistance_rise : float, optional
        R rises to (1 + resistance_rise) R0 as a first-order thermal response: R0 (1 + rise (1 - exp(-t / tau))).
    thermal_time : float, optional
        tau, hours.
    steps : tuple of Step
        Parameters multiplied by a factor from an hour on (a friction or damping step, a load change).

    Returns
    -------
    list of (float, ActuatorParameters)
    """
    count = max(1, math.ceil(hours / every - 1e-9))
    last = (count - 1) * every
    if last * HOUR >= STAMP_LIMIT_S:   # a stamp's sec is int32: later recordings would wrap to negative times
        raise InputError(f'--hours {hours:g} --every {every:g}: the last recording would start at hour {last:g} '
                         f'({last * HOUR:.4g} s), past the {STAMP_LIMIT} a ROS time stamp holds; give --hours '
                         f'{STAMP_LIMIT_S / HOUR:.0f} or less')
    out = []
    for k in range(count):
        hour = k * every
        factors = {'resistance': 1.0 + resistance_rise * (1.0 - math.exp(-hour / thermal_time))}
        for step in steps:
            if hour >= step.hour:
                factors[step.name] = factors.get(step.name, 1.0) * step.factor
        changed = {name: getattr(base, name) * factor for name, factor in factors.items()}
        for name, value in changed.items():   # a factor of 1e308 would overflow (inf: a ValueError below)
            low, high = PARAMETER_BOUNDS[name]
            if not low <= value <= high:
                given = ' '.join(f'--step {s.name}={s.factor:g}@{s.hour:g}' for s in steps if s.name == name)
                raise InputError(f'{given or "--resistance-rise"}: {name} would be {value:g} '
                                 f'{PARAMETER_UNITS[name]} at hour {hour:g}, outside [{low:g}, {high:g}]')
        out.append((hour * HOUR, base.replace(**changed)))
    return out
