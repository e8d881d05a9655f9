"""Where a model's residuals lie: each equation's one-step residual in physical units against time, velocity,
position, the drive and its rate, and its whiteness and correlation with the input."""
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from .adequacy import EQUATION
from .data import regression_rows
from .residuals import binned, cross_correlation, whiteness

SMOOTHING = 1e-3   # s, of the residuals binned against the signals


@dataclass
class Localisation:
    """One equation's one-step residual in physical units, and what it correlates with."""

    equation: str               # 'electrical' or 'mechanical'
    quantity: str               # 'voltage' (V) or 'force' (N)
    whiteness: object           # residuals.Correlation
    input_name: str
    cross: object               # residuals.Correlation with the input
    bins: dict                  # signal name -> residuals.Binned of the residual smoothed over SMOOTHING


def localise(result):
    """{equation: Localisation} of a Fit's residuals against time, velocity, position, the drive and its rate."""
    data, p = result.data, result.parameters
    ts = data.sample_period
    k = regression_rows(data)
    against = {'time': data.time[k], 'velocity': data.velocity()[k], 'position': data.signals['position'][k]}
    drive = data.drive
    against[drive] = data.signals[drive][k]
    against[f'{drive} rate'] = np.gradient(data.signals[drive], ts)[k]
    out = {}
    for kind, residual in result.residuals().items():
        if kind == 'electrical':
            h = p['resistance'] * ts / p['inductance']
            scale, quantity, input_name = p['resistance'] / -np.expm1(-h), 'voltage', 'voltage'   # 1 / beta
        else:
            scale, quantity, input_name = p['mass'], 'force', drive
        e = residual * scale
        # the sensor noise in a one-step residual is mostly high-frequency: a centred 1 ms mean leaves
        # the effects (which vary more slowly) for the binned plots
        smooth = uniform_filter1d(e, max(1, int(round(SMOOTHING / ts))), mode='nearest')
        out[EQUATION[kind]] = Localisation(EQUATION[kind], quantity, whiteness(e), input_name,
                                           cross_correlation(e, data.signals[input_name][k]),
                                           {name: binned(smooth, z) for name, z in against.items()})
    return out
