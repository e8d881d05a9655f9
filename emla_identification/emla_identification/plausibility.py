"""Estimates that physics forbids or that point to a slip in the data's units or signs, as warnings that name
the parameter, the likely cause and the flag that fixes it.

Signs: the model fixes R, L, m > 0 (and B >= 0), so a negative one means a measured signal runs the other way
round: current against voltage flips R and L (and Km), position against current flips Km, m and B.
Units: a moving-coil or solenoid actuator's stroke is millimetres to centimetres and its sample period well
under 10 ms; a position logged in mm but read as m makes the stroke metres and divides Km and m by 1000 and
10^6; time in ms read as s multiplies every time constant by 1000.
"""
import numpy as np

MAX_STROKE = 0.5        # m: beyond this the position is probably not in metres
MAX_SAMPLE_PERIOD = 0.01  # s: beyond this the time is probably not in seconds (or the coil is not resolved)
MIN_MASS = 1e-5         # kg
MAX_MASS = 1e3          # kg


def plausibility_warnings(parameters, std, recording):
    """One-line warnings about `parameters` ({name: value}, with one-sigma `std`) identified from `recording`."""
    warnings = []
    value = parameters.get
    sigma = lambda name: std.get(name, 0.0) if np.isfinite(std.get(name, np.nan)) else 0.0  # noqa: E731
    if value('resistance', 1.0) <= 0 or value('inductance', 1.0) <= 0:
        warnings.append(f'resistance {value("resistance", np.nan):.4g} ohm and inductance '
                        f'{value("inductance", np.nan):.4g} H must be positive: the current probably runs against '
                        f'the voltage (sensor mounted the other way?); flip it with --units current=-A')
    if value('mass', 1.0) <= 0 or value('damping', 0.0) < -3 * sigma('damping'):
        warnings.append(f'mass {value("mass", np.nan):.4g} kg and damping {value("damping", np.nan):.4g} N s/m '
                        f'must be positive: the position probably runs against the force of the current; flip it '
                        f'with --units position=-m')
    elif value('mass', 1.0) < MIN_MASS:
        warnings.append(f'mass {value("mass"):.3g} kg is implausibly small (a force constant of '
                        f'{value("emf_constant", np.nan):.3g} N/A beside it): is the position in mm or um? '
                        f'give its unit with --units position=mm')
    elif value('mass', 1.0) > MAX_MASS:
        warnings.append(f'mass {value("mass"):.3g} kg is implausibly large: is the time in ms? give its unit with '
                        f'--units t=ms (or --sample-period in s)')
    position = recording.signals.get('position')
    if position is not None and len(position) and np.ptp(position) > MAX_STROKE:
        warnings.append(f'the position spans {np.ptp(position):.3g} m, a stroke of metres: is it in mm? give its '
                        f'unit with --units position=mm')
    if recording.sample_period > MAX_SAMPLE_PERIOD:
        warnings.append(f'the sample period is {recording.sample_period:.3g} s, slow for a coil: is the time in '
                        f'ms? give its unit with --units t=ms')
    return warnings
