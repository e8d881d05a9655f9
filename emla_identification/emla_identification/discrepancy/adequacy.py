"""Is anything left to explain? Each equation's held-out one-step residual against what the sensor noise
alone would leave in it (noise_floor.py: the low band of the residual's spectrum against the noise's share).
"""
from dataclasses import dataclass, replace

import numpy as np

from emla_identification.noise_floor import LowBand, low_band, noise_variances
from emla_identification.regressors import noise_stencils

from .fit import PREFILTER, prefiltered
from .rows import rows_of

REALISATIONS = 8   # of the noise through the candidates' terms (_through_terms): Welch over 8 records

EQUATION = {'electrical': 'electrical', 'mechanical': 'mechanical', 'force': 'mechanical'}   # regression kinds


@dataclass
class Adequacy(LowBand):
    """One equation's held-out residual against its sensor-noise floor (low band, physical units)."""

    equation: str = ''        # 'electrical' or 'mechanical'
    quantity: str = ''        # 'voltage' (V) or 'force' (N)
    residual: np.ndarray | None = None  # held-out one-step residual in physical units, per regression row

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


def assess_adequacy(fit, terms=True):
    """{equation: Adequacy} of a Fit (noise_floor.low_band of its held-out residuals, in volts or newtons): the
    floor of the sensors' noise through the rows and (`terms`) through the candidates' terms that read it
    (_through_terms), or through the rows alone (rows_adequacy)."""
    equations, quantities = _equations(fit, terms)
    return {EQUATION[kind]: Adequacy(band.size, band.floor, band.ratio, equation=EQUATION[kind],
                                     quantity=quantities[kind], residual=equations[kind][0])
            for kind, band in low_band(equations, fit.data.sample_period).items()}


def rows_adequacy(fit):
    """assess_adequacy against the floor of the noise through the rows alone, the one candidates are compared in
    (a share of the disagreement removed, the least left): the floor a friction's terms add rises with its own
    pre-sliding band and level, and would favour it over a candidate that reads no signal (a force saturation at
    10 kHz was named a Stribeck friction)."""
    return assess_adequacy(fit, terms=False)


def sensor_noise(fit):
    """{signal: variance} of each measured signal's white noise, fitted to the high band of a Fit's held-out
    residuals through the rows' stencils (noise_floor.noise_variances)."""
    return noise_variances(_equations(fit, terms=False)[0], fit.data.sample_period)


def _equations(fit, terms=True):
    """({kind: (held-out residual, {signal: its noise filter})} in physical units, {kind: the quantity}); with
    `terms`, the filter of a signal some candidate's terms read (Candidate.reads) is realisations of its noise
    through the rows and those terms (_through_terms)."""
    equations, quantities, scales = {}, {}, {}
    for kind, residual in fit.heldout_residuals().items():
        rows = rows_of(fit.data, kind, fit.linearised_about)
        scales[kind], quantities[kind] = rows.scale()
        equations[kind] = (residual * scales[kind],
                           {name: c * scales[kind] for name, c in noise_filters(fit, rows).items()})
    read = sorted({name for c in fit.candidates for name in c.reads}) if terms else ()
    if read:
        variances = noise_variances(equations, fit.data.sample_period)
        for name in read:
            if variances.get(name, 0.0) > 0.0:
                for kind, realisations in _through_terms(fit, name, np.sqrt(variances[name]), scales).items():
                    equations[kind][1][name] = realisations
    return equations, quantities


def _through_terms(fit, name, sigma, scales):
    """{kind: (REALISATIONS, rows)}: the change of a Fit's residuals (physical units, per unit sigma) when white
    noise of `sigma` (through any re-alignment's shaping) is added to the measured signal `name` and the candidates
    that read it (Candidate.reads) read it again (Candidate.reread).

    The rows' own stencils treat a signal's noise as linear and the candidates' terms as slow; a friction whose
    pre-sliding band is a few position-noise sigmas wide (or a tanh steep against the velocity's noise) turns
    that noise into force at every stop and reversal, low band included: a 0.09 N Coulomb friction (
    at 10 kHz on a 1 um quantiser, band 2 um) left its force balance at 3.6 times the stencils' floor with every
    parameter within 2.5 sigma; at 1.1 times this floor. The noise added rides on the record's own, so the terms
    see sqrt(2) sigma: a floor near, not at, the one of the record's noise alone (above it where a reversal falls
    within an interval: at 2 kHz, right parameters, 0.64 times this floor)."""
    rng = np.random.default_rng(0)   # the same floor for the same fit
    base = fit.residuals()
    x = fit.data.signals[name]
    taps = fit.data.shaping.get(name, [1.0])
    out = {kind: [] for kind in base}
    for _ in range(REALISATIONS):
        noise = sigma * np.convolve(rng.standard_normal(len(x)), taps)[:len(x)]
        data = replace(fit.data, signals=dict(fit.data.signals, **{name: x + noise}))
        candidates = tuple(c.reread(data) if name in c.reads else c for c in fit.candidates)
        for kind, residual in replace(fit, data=data, candidates=candidates).residuals().items():
            out[kind].append((residual - base[kind]) * scales[kind] / sigma)
    return {kind: np.array(rows) for kind, rows in out.items()}


def noise_gains(fit):
    """{kind: {signal: g}}: white noise of unit variance on `signal` puts g into the held-out error of a Fit's
    regression `kind` (Fit.heldout summed over the blocks: its weights, the mechanical rows prefiltered): each
    row's noise through its filters (noise_filters, with any re-alignment's shaping; the mechanical ones through
    fit.PREFILTER as well)."""
    rho = PREFILTER
    gains = {}
    for kind in fit.data.kinds:
        rows = rows_of(fit.data, kind, fit.linearised_about)
        gains[kind] = {}
        for name, c in noise_filters(fit, rows).items():
            if kind != 'electrical':   # the prefilter's impulse response has decayed to 1e-12 after 300 samples
                c = prefiltered(np.pad(c, (0, 300)), rho)
            gains[kind][name] = len(rows.y) * float(np.sum(np.square(c))) / fit.sigma[kind] ** 2
    return gains


def heldout_noise(gains, variances):
    """{kind: the part of a Fit's held-out error in regression `kind` that white sensor noise of `variances`
    ({signal: variance}) puts there}, from its noise_gains `gains`."""
    return {kind: sum(variances.get(name, 0.0) * g for name, g in signals.items()) for kind, signals in gains.items()}
