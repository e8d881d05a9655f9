"""Is anything left to explain? Each equation's held-out one-step residual against what the sensor noise
alone would leave in it.

White noise on a measured signal reaches the residual of row k through a short stencil (regressors.
noise_stencils: the rows' construction, weighted by the fitted coefficients), so the residual of an adequate
model has the spectrum sum_s a_s |C_s(f)|^2: known shapes C_s, unknown levels a_s. The stencils put the
noise mostly at high frequency (the second difference of the position, the one-step current), where the
effects of an actuator (friction at reversals, springs, heating, saturation at the strokes) put little. So:
  1. the levels a_s are fitted (non-negative least squares) to the residual's Welch spectrum in the high band
     (above HIGH of the sampling rate), where the noise dominates;
  2. the power the noise predicts in the low band (below LOW) is compared with the residual's power there.
An adequate model leaves the ratio near 1 (0.9-1.3 on noise-only records); a missing effect adds low-band
power (ratios of 10 to 10^4 for the effects of physics.md at realistic strengths). A named effect whose model
is a close but not exact description of the plant's (a first-order thermal model, a quadratic saturation)
leaves ratios of 1.5-3, which MAX_RATIO accepts as explained. The excess is reported in physical units (V of the
voltage balance, N of the force balance) as the RMS of the residual the noise does not explain, beside the RMS the
noise puts in the low band (the floor).
"""
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls
from scipy.signal import welch

from emla_identification.regressors import noise_stencils, tie

HIGH = 0.25          # of the sampling rate: above it, the noise's band (up to the Nyquist rate 0.5)
LOW = 0.05           # of the sampling rate: below it, the effects' band
MAX_RATIO = 3.5      # low-band power over the noise's prediction above which the equation is not adequate
SEGMENT = 1024       # samples per Welch segment
EQUATION = {'electrical': 'electrical', 'mechanical': 'mechanical', 'force': 'mechanical'}   # regression kinds


@dataclass
class Adequacy:
    """One equation's held-out residual against its sensor-noise floor (low band, physical units)."""

    equation: str        # 'electrical' or 'mechanical'
    quantity: str        # 'voltage' (V) or 'force' (N)
    residual: np.ndarray  # held-out one-step residual in physical units, per regression row
    size: float          # RMS of the low-band residual the noise does not explain
    floor: float         # RMS the sensor noise puts in the low band
    ratio: float         # low-band power over the noise's prediction

    @property
    def adequate(self):
        return self.ratio <= MAX_RATIO

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
    coefficients of the fit's tied regression; candidate terms are slow and left out)."""
    ts = fit.data.sample_period
    h = fit.linearised_about['resistance'] * ts / fit.linearised_about['inductance'] \
        if 'inductance' in fit.linearised_about else 0.0
    coefficients = tie(kind, h).T @ fit.theta[kind]
    return {name: dy - dphi @ coefficients for name, (dy, dphi) in noise_stencils(kind, ts).items()}


def assess_adequacy(fit):
    """{equation: Adequacy} of a Fit. The noise levels are those of the sensors, shared by the equations
    (the same current and position noise enters both): one fit over every equation's high band."""
    ts = fit.data.sample_period
    spectra = {}
    for kind, residual in fit.heldout_residuals().items():
        scale, quantity = physical_scale(kind, fit.parameters, ts)
        e = residual * scale
        frequency, power = welch(e, fs=1.0 / ts, nperseg=min(SEGMENT, len(e) // 4), detrend='constant')
        filters = noise_filters(fit, kind)
        shapes = {name: np.abs(np.fft.rfft(c * scale, 2 * (len(frequency) - 1))) ** 2 for name, c in filters.items()}
        spectra[kind] = (quantity, e, frequency, power, shapes)
    sources = sorted({name for *_, shapes in spectra.values() for name in shapes})
    rows, targets = [], []
    for _quantity, _e, frequency, power, shapes in spectra.values():
        high = frequency >= HIGH / ts
        weight = 1.0 / power[high].mean()          # each equation in its own units
        rows.append(weight * np.column_stack([shapes.get(name, np.zeros(len(frequency)))[high] for name in sources]))
        targets.append(weight * power[high])
    levels = dict(zip(sources, nnls(np.vstack(rows), np.concatenate(targets))[0]))
    out = {}
    for kind, (quantity, e, frequency, power, shapes) in spectra.items():
        predicted = sum(levels[name] * shape for name, shape in shapes.items())
        low = (frequency > 0) & (frequency <= LOW / ts)
        step = frequency[1] - frequency[0]
        measured_low, predicted_low = power[low].sum() * step, predicted[low].sum() * step
        ratio = measured_low / predicted_low if predicted_low > 0 else np.inf
        out[EQUATION[kind]] = Adequacy(EQUATION[kind], quantity, e,
                                       float(np.sqrt(max(measured_low - predicted_low, 0.0))),
                                       float(np.sqrt(predicted_low)), float(ratio))
    return out
