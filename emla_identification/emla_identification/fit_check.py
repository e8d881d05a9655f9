"""Does the identified model explain its data? Each equation's residual with the final parameters, as MATLAB's
`resid` judges a model, against what the sensor noise alone would leave in it:

- size and noise floor: the residual's RMS in physical units (V of the voltage balance, N of the force balance)
  and, in its low band where the effects of an actuator live, the part the sensor noise does not explain
  against the part it does (noise_floor.py); their power ratio is near 1 for a model that fits;
- whiteness: white sensor noise reaches a row's residual through the few samples the row spans (noise.py), so
  the residual of a model that fits is uncorrelated beyond that span; the largest normalised autocorrelation
  at lags HISTORY+1 .. MAX_LAG is reported beside its 99 % bound for white residuals;
- dependence: the signals the low-passed residual is a function of (dependence.py, beside the
  equation's own regressors), the first place to look for what is missing.

An equation whose low band holds more than noise_floor.MAX_RATIO times the noise's share does not fit: its
parameters' uncertainties (from the sensor noise) do not cover the model error, and the warning says so.
"""
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import savgol_filter

from .dependence import dependence
from .noise import noise_filters
from .noise_floor import MAX_RATIO, low_band
from .online_effects import regression_rows
from .physical import coefficients, stiffness_index
from .regressors import COLUMNS, HISTORY, LEAD

MAX_LAG = 50          # samples: the whiteness test's last lag
WHITE_BOUND = 2.58    # normal quantile of the 99 % bound on a white residual's autocorrelation (times 1/sqrt(N))
NEGLIGIBLE = 1e-6     # an unexplained low band below this fraction of the equation's output fits whatever its ratio
EQUATION = {'electrical': 'electrical', 'mechanical': 'mechanical', 'electrical_velocity': 'electrical',
            'mechanical_velocity': 'mechanical', 'force': 'mechanical'}
QUANTITY = {'electrical': ('voltage', 'V'), 'mechanical': ('force', 'N')}
DEPENDS = 0.2         # share of the low-passed residual a signal explains for the warning to name it


@dataclass
class EquationFit:
    """How well one equation of the model explains the data."""

    equation: str          # 'electrical' or 'mechanical'
    rms: float             # RMS residual, physical units
    size: float            # low-band RMS the sensor noise does not explain
    floor: float           # low-band RMS the sensor noise explains
    ratio: float           # low-band power over the noise's share
    correlation: float     # largest |autocorrelation| at lags HISTORY+1 .. MAX_LAG
    bound: float           # its 99 % bound for white residuals
    depends_on: list       # [{'signal': name, 'explained': fraction}], best first
    size_of_terms: float = 0.0   # RMS of the equation's output in the same units (what the terms balance)

    @property
    def adequate(self):
        """The low band holds little more than noise, or what it holds is negligible beside the equation's
        terms (a noise-free record's rounding)."""
        return self.ratio <= MAX_RATIO or self.size <= NEGLIGIBLE * self.size_of_terms

    def scaled(self, factor):
        """The same fit with its physical figures in units `factor` times larger (greybox's rescaled records)."""
        return replace(self, rms=self.rms * factor, size=self.size * factor, floor=self.floor * factor,
                       size_of_terms=self.size_of_terms * factor)

    @property
    def quantity(self):
        return QUANTITY[self.equation]

    def to_dict(self):
        name, unit = self.quantity
        return {'quantity': name, 'unit': unit, 'rms': float(self.rms), 'unexplained': float(self.size),
                'noise_floor': float(self.floor), 'ratio': float(self.ratio), 'adequate': bool(self.adequate),
                'whiteness': {'max_correlation': float(self.correlation), 'bound': float(self.bound),
                              'white': bool(self.correlation <= self.bound)},
                'depends_on': self.depends_on[:3]}

    def warning(self):
        """One line for an equation that does not fit, else None."""
        if self.adequate:
            return None
        name, unit = self.quantity
        top = self.depends_on[0] if self.depends_on else None
        where = (f', most of it a function of the {top["signal"]} ({100 * top["explained"]:.0f} % of it)'
                 if top and top['explained'] >= DEPENDS else ', a function of no single signal')
        if where.endswith('signal') and self.equation == 'electrical':
            # white noise on a logged voltage reaches the residual flat, into the low band that the current's
            # noise (differenced by the row) leaves nearly empty; a flat source in the floor would hide effects
            where += (' (if the voltage is a measured one, not the command, its own noise, which the noise model '
                      'takes as exact, leaves such a residual)')
        return (f'the {self.equation} equation does not fit these data: its residual holds {self.ratio:.3g} times the '
                f'sensor noise in the low band ({self.size:.3g} {unit} of {name} unexplained){where}; the '
                f'uncertainties do not cover this model error: run `emla discrepancy` to find what is missing')


def check_fit(signals, statistics, q, sample_period):
    """{equation: EquationFit} of parameters q (physical.parameter_names order) on the record's signals (a dict of
    equally long arrays) for the regressions in `statistics` ({kind: Statistics})."""
    ts = sample_period
    equations, residuals, regressors, sizes = {}, {}, {}, {}
    effects = next(iter(statistics.values())).effects   # every regression has the same effects' columns
    made = regression_rows(signals, tuple(statistics), ts, effects)
    for kind in statistics:
        phi, y, _ = made[kind]
        theta = coefficients(kind, q, ts, stiffness=stiffness_index(statistics))
        scale = _physical_scale(kind, theta, q, ts)
        residuals[kind] = (y - phi @ theta) * scale
        sizes[kind] = float(np.sqrt(np.mean((y * scale) ** 2)))
        regressors[kind] = phi
        filters = noise_filters(kind, np.eye(len(theta)), theta, ts, effects)
        equations[kind] = (residuals[kind], {name: c * scale for name, c in filters.items()})
    bands = low_band(equations, ts)
    index = np.arange(LEAD, LEAD + len(next(iter(residuals.values()))))
    return {EQUATION[kind]: equation_fit(EQUATION[kind], e, bands[kind], regressors[kind], signals, index, ts,
                                         sizes[kind])
            for kind, e in residuals.items()}


def equation_fit(equation, residual, band, regressors, signals, index, sample_period, size_of_terms):
    """The EquationFit of one equation's `residual` (physical units) at the samples `index` of the record's
    `signals`, with its noise_floor.LowBand `band` and the equation's `regressors` (rows x terms)."""
    singles, _ = dependence(residual, _signals(signals, index, sample_period), regressors, sample_period)
    return EquationFit(equation, float(np.sqrt(np.mean(residual * residual))), band.size, band.floor, band.ratio,
                       _correlation(residual), WHITE_BOUND / np.sqrt(len(residual)), singles, size_of_terms)


def _physical_scale(kind, theta, q, ts):
    """A row's residual -> V (electrical: the current's error over the voltage's coefficient) or N (the
    acceleration's error times the mass; of a velocity row, times m / Ts)."""
    if kind.startswith('electrical'):
        return 1.0 / theta[COLUMNS[kind].index('voltage')]
    mass = q[0] if kind == 'force' else q[3]
    return mass / ts if kind == 'mechanical_velocity' else mass


def _correlation(e):
    """The largest |normalised autocorrelation| of e at lags HISTORY+1 .. MAX_LAG."""
    e = e - e.mean()
    power = e @ e
    if power <= 0 or len(e) <= 2 * MAX_LAG:
        return 0.0
    return float(max(abs(e[lag:] @ e[:-lag]) / power for lag in range(HISTORY + 1, MAX_LAG + 1)))


def _signals(signals, index, ts):
    """{name: values at rows `index`} of the signals a residual may depend on (as dependence.signals_of)."""
    motion = 'position' if 'position' in signals else 'velocity'
    window = min(21, len(signals[motion]) // 2 * 2 - 1)
    out = {'time': ts * index}
    for name in ('voltage', 'current', 'force', 'position', 'velocity'):
        if name in signals:
            out[name] = np.asarray(signals[name], dtype=float)[index]
    if 'position' in signals and 'velocity' not in signals:
        out['velocity'] = savgol_filter(signals['position'], window, 3, deriv=1, delta=ts)[index]
    drive = 'current' if 'current' in signals else 'force'
    out[f'{drive} rate'] = savgol_filter(signals[drive], window, 3, deriv=1, delta=ts)[index]
    return out
