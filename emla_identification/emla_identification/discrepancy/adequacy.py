"""Is anything left to explain? Each equation's held-out one-step residual against what the sensor noise
alone would leave in it (noise_floor.py: the low band of the residual's spectrum against the noise's share).
"""
from dataclasses import dataclass

import numpy as np

from emla_identification.noise_floor import LowBand, low_band

from .first_order import noise_stencils, tie

EQUATION = {'electrical': 'electrical', 'mechanical': 'mechanical', 'force': 'mechanical'}   # regression kinds


@dataclass
class Adequacy(LowBand):
    """One equation's held-out residual against its sensor-noise floor (low band, physical units)."""

    equation: str = ''        # 'electrical' or 'mechanical'
    quantity: str = ''        # 'voltage' (V) or 'force' (N)
    residual: np.ndarray = None  # held-out one-step residual in physical units, per regression row

    def to_dict(self):
        return {'quantity': self.quantity, 'size': float(self.size), 'noise_floor': float(self.floor),
                'ratio': float(self.ratio), 'adequate': bool(self.adequate)}


def physical_scale(kind, parameters, sample_period):
    """Residual of a row of `kind` -> physical units: the current step over beta (V) or the acceleration times
    the mass (N)."""
    if kind == 'electrical':
        h = parameters['resistance'] * sample_period / parameters['inductance']
        return parameters['resistance'] / -np.expm1(-h), 'voltage'
    return parameters['mass'], 'force'


def noise_filters(fit, kind):
    """{signal: c}: white noise of sample k - 2 + j on `signal` adds c_j to the residual of row k (the raw
    coefficients of the fit's tied regression; candidate terms are slow and left out). Where a re-alignment
    (a fractional delay, a sensor filter: data.Data.shaping) filtered a signal, its noise reaches the rows
    through that filter too (c convolved with its taps; only |C(f)| matters)."""
    ts = fit.data.sample_period
    h = fit.linearised_about['resistance'] * ts / fit.linearised_about['inductance'] \
        if 'inductance' in fit.linearised_about else 0.0
    coefficients = tie(kind, h).T @ fit.theta[kind]
    shaping = getattr(fit.data, 'shaping', {})
    return {name: np.convolve(dy - dphi @ coefficients, shaping.get(name, [1.0]))
            for name, (dy, dphi) in noise_stencils(kind, ts).items()}


def assess_adequacy(fit):
    """{equation: Adequacy} of a Fit (noise_floor.low_band of its held-out residuals)."""
    ts = fit.data.sample_period
    equations, quantities = {}, {}
    for kind, residual in fit.heldout_residuals().items():
        scale, quantities[kind] = physical_scale(kind, fit.parameters, ts)
        equations[kind] = (residual * scale, {name: c * scale for name, c in noise_filters(fit, kind).items()})
    return {EQUATION[kind]: Adequacy(band.size, band.floor, band.ratio, equation=EQUATION[kind],
                                     quantity=quantities[kind], residual=equations[kind][0])
            for kind, band in low_band(equations, ts).items()}
