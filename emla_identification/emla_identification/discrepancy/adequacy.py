"""Is anything left to explain? Each equation's held-out one-step residual against what the sensor noise
alone would leave in it (noise_floor.py: the low band of the residual's spectrum against the noise's share).
"""
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from emla_identification.noise_floor import LowBand, low_band, noise_variances
from emla_identification.regressors import noise_stencils

from .fit import PREFILTER
from .rows import Rows

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


def noise_filters(fit, rows):
    """{signal: c}: white noise of sample k - 3 + j on `signal` adds c_j to the residual of row k (the exact rows'
    coefficients at the fit, `rows` the regression's Rows; candidate terms are slow and left out). Where a
    re-alignment (a fractional delay, a sensor filter: data.Data.shaping) filtered a signal, its noise reaches the
    rows through that filter too (c convolved with its taps; only |C(f)| matters)."""
    coefficients = rows.coefficients + rows.jacobian @ fit.shift
    shaping = getattr(fit.data, 'shaping', {})
    return {name: np.convolve(dy - dphi @ coefficients, shaping.get(name, [1.0]))
            for name, (dy, dphi) in noise_stencils(rows.kind, fit.data.sample_period).items()}


def assess_adequacy(fit):
    """{equation: Adequacy} of a Fit (noise_floor.low_band of its held-out residuals, in volts or newtons)."""
    equations, quantities = _equations(fit)
    return {EQUATION[kind]: Adequacy(band.size, band.floor, band.ratio, equation=EQUATION[kind],
                                     quantity=quantities[kind], residual=equations[kind][0])
            for kind, band in low_band(equations, fit.data.sample_period).items()}


def sensor_noise(fit):
    """{signal: variance} of each measured signal's white noise, fitted to the high band of a Fit's held-out
    residuals as assess_adequacy fits it (noise_floor.noise_variances)."""
    return noise_variances(_equations(fit)[0], fit.data.sample_period)


def _equations(fit):
    """({kind: (held-out residual, {signal: its noise filter})} in physical units, {kind: the quantity})."""
    equations, quantities = {}, {}
    for kind, residual in fit.heldout_residuals().items():
        rows = Rows(fit.data, kind, fit.linearised_about)
        scale, quantities[kind] = rows.scale()
        equations[kind] = (residual * scale, {name: c * scale for name, c in noise_filters(fit, rows).items()})
    return equations, quantities


def noise_gains(fit):
    """{kind: {signal: g}}: white noise of unit variance on `signal` puts g into the held-out error of a Fit's
    regression `kind` (Fit.heldout summed over the blocks: its weights, the mechanical rows prefiltered): each
    row's noise through its filters (noise_filters, with any re-alignment's shaping; the mechanical ones through
    fit.PREFILTER as well)."""
    rho = PREFILTER
    gains = {}
    for kind in fit.data.kinds:
        rows = Rows(fit.data, kind, fit.linearised_about)
        gains[kind] = {}
        for name, c in noise_filters(fit, rows).items():
            if kind != 'electrical':   # the prefilter's impulse response has decayed to 1e-12 after 300 samples
                c = lfilter([1.0 - rho], [1.0, -2.0 * rho, rho * rho], np.pad(c, (0, 300)))
            gains[kind][name] = len(rows.y) * float(np.sum(np.square(c))) / fit.sigma[kind] ** 2
    return gains


def heldout_noise(gains, variances):
    """{kind: the part of a Fit's held-out error in regression `kind` that white sensor noise of `variances`
    ({signal: variance}) puts there}, from its noise_gains `gains`."""
    return {kind: sum(variances.get(name, 0.0) * g for name, g in signals.items()) for kind, signals in gains.items()}
