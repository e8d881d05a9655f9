"""How much of an equation's residual the sensor noise explains, and how much it leaves to the model.

White noise on a measured signal reaches the residual of row k through a short stencil (the rows' construction,
weighted by the fitted coefficients: noise.py, regressors.noise_stencils), so the residual of an adequate model
has the spectrum sum_s a_s |C_s(f)|^2: known shapes C_s, unknown levels a_s. The stencils put the noise mostly
at high frequency (the second difference of the position, the one-step current), where the effects of an
actuator (friction at reversals, springs, heating, saturation at the strokes) put little. So:
  1. the levels a_s are fitted (non-negative least squares) to the residual's Welch spectrum in the high band
     (above HIGH of the sampling rate), where the noise dominates, shared by the equations (the same sensors);
  2. the power the noise predicts in the low band (below LOW) is compared with the residual's power there (its
     mean included).
An adequate model leaves the ratio near 1 (0.9-1.3 on noise-only records); a missing effect adds low-band
power (ratios of 10 to 10^4 for the effects of physics.md at realistic strengths). A model that is a close but
not exact description of the plant (a first-order thermal model, a quadratic saturation) leaves ratios of 1.5-3,
which MAX_RATIO accepts. The excess is reported in physical units (V of the voltage balance, N of the force
balance) as the RMS of the residual the noise does not explain, beside the RMS the noise puts in the low band
(the floor).
"""
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls
from scipy.signal import welch

HIGH = 0.25          # of the sampling rate: above it, the noise's band (up to the Nyquist rate 0.5)
LOW = 0.05           # of the sampling rate: below it, the effects' band
MAX_RATIO = 3.5      # low-band power over the noise's prediction above which the equation is not adequate
SEGMENT = 1024       # samples per Welch segment


@dataclass
class LowBand:
    """One equation's low-band residual against its sensor-noise floor."""

    size: float     # RMS of the low-band residual the noise does not explain
    floor: float    # RMS the sensor noise puts in the low band
    ratio: float    # low-band power over the noise's prediction

    @property
    def adequate(self):
        return self.ratio <= MAX_RATIO


def low_band(equations, sample_period):
    """{key: LowBand} of {key: (residual, {signal: c})}: each equation's residual per row in physical units and
    how white noise of unit variance on each measured signal enters it (c_j: the noise of the j-th sample of a
    row's span, same units; or, for rows that are not consecutive samples, a 2-D array of realisations: the
    residuals such noise gives, each as long as the residual). The noise levels are fitted jointly over every
    equation's high band."""
    spectra = _spectra(equations, sample_period)
    levels = _levels(spectra, sample_period)
    out = {}
    for key, (frequency, power, shapes, constant) in spectra.items():
        predicted = sum(levels[name] * shape for name, shape in shapes.items())
        low = (frequency > 0) & (frequency <= LOW / sample_period)
        step = frequency[1] - frequency[0]
        # the residual's mean too (Welch's detrending drops it): an offset the model cannot meet (a current
        # sensor's, a drive's) is a low-band misfit; the noise's own mean is some 1/N of its low band
        measured_low, predicted_low = power[low].sum() * step + constant, predicted[low].sum() * step
        ratio = measured_low / predicted_low if predicted_low > 0 else np.inf
        out[key] = LowBand(float(np.sqrt(max(measured_low - predicted_low, 0.0))), float(np.sqrt(predicted_low)),
                           float(ratio))
    return out


def noise_variances(equations, sample_period):
    """{signal: variance} of the white noise on each measured signal (its units squared), as low_band fits it to
    the high band of the `equations` (low_band's argument)."""
    levels = _levels(_spectra(equations, sample_period), sample_period)
    # Welch's one-sided density of white noise of variance s2 through C: 2 Ts s2 |C(f)|^2
    return {name: float(level) / (2.0 * sample_period) for name, level in levels.items()}


def _spectra(equations, ts):
    """{key: (frequencies, the residual's Welch density, {signal: |C(f)|^2}, its mean squared)}."""
    spectra = {}
    for key, (e, filters) in equations.items():
        segment = min(SEGMENT, len(e) // 4)
        frequency, power = welch(e, fs=1.0 / ts, nperseg=segment, detrend='constant')
        shapes = {name: _shape(c, segment, 2 * (len(frequency) - 1), ts) for name, c in filters.items()}
        spectra[key] = (frequency, power, shapes, float(np.mean(e)) ** 2)
    return spectra


def _levels(spectra, ts):
    """{signal: the level of its noise's density} fitted (non-negative least squares) to every equation's high
    band, each equation weighted by its mean power there (each in its own units)."""
    sources = sorted({name for _, _, shapes, _ in spectra.values() for name in shapes})
    rows, targets = [], []
    for frequency, power, shapes, _ in spectra.values():
        high = frequency >= HIGH / ts
        weight = 1.0 / power[high].mean() if power[high].mean() > 0 else 1.0
        rows.append(weight * np.column_stack([shapes.get(name, np.zeros(len(frequency)))[high] for name in sources]))
        targets.append(weight * power[high])
    return dict(zip(sources, nnls(np.vstack(rows), np.concatenate(targets))[0]))


def _shape(c, segment, points, ts):
    """The power gain |C(f)|^2 of a stencil c at the Welch frequencies (an FFT of `points`), or the mean Welch
    spectrum (segments of `segment`) of the realisations c (rows) over that of unit white noise."""
    c = np.asarray(c, dtype=float)
    if c.ndim == 1:
        return np.abs(np.fft.rfft(c, points)) ** 2
    spectra = [welch(row, fs=1.0 / ts, nperseg=segment, detrend='constant')[1] for row in c]
    return np.mean(spectra, axis=0) / (2.0 * ts)
