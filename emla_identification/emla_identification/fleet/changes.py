"""Changes of an identified parameter across many recordings: Page's two-sided CUSUM on the standardised
innovations of a Kalman filter that tracks the parameter (Basseville & Nikiforov, Detection of Abrupt Changes,
1993, ch. 2 and 9), the reference frozen while an excursion is in progress.

Each parameter's estimates x_i (in time order) with their one-sigma std_i are modelled as a level (or, when the
series has a trend, a level with a slowly varying slope: a local linear trend) plus noise of variance
c^2 std_i^2; c^2 >= 1 covers the scatter between recordings that the within-record std does not (model error, a
unit's day-to-day variation), from the median size of the second differences, which a step barely moves. Each
innovation (the estimate minus the filter's prediction from the recordings before the excursion in progress)
over its standard deviation is z_i, clipped to +-CAP so that no single recording, however far off, makes a change
by itself. The CUSUMs S+ = max(0, S+ + z - k), S- = max(0, S- - z - k), k = K plus REFERENCE standard deviations
of the prediction's own error, signal a change when one exceeds H: with K = 0.5, CAP = 4 and H = 10 a change
needs at least three recordings in a row beyond their band (3 x 3.5 > 10); on 200 recordings of noise (the std
right, or 2 or 4 times too small) none was found in 100 trials each, and steps of 3 to 100 standard deviations
were found at their recording (within 2 for the smallest). The change is dated where a step best explains the
excursion (the least-squares change point); `before` is the filter's prediction there, `after` the mean of the
excursion with the earlier trend removed, `sigma` the step after - before in units of the recording-to-recording
standard deviation. The filter then goes on from the new level, so a later change is measured against it.

Limits: a trend is assumed when the differences have one sign far more often than chance (a sign test at 3
sigma); a drift slower than that (a few tenths of a standard deviation per recording) is not a trend, and is
reported as changes each time it has left its band. On a trend the filter takes each recording at once (a
reference held while the trend bends would be left behind), all but those beyond CAP: a step on a straight
trend is found (10 standard deviations on a drift of one per recording: 93 %), but on a trend that bends
quickly (R of a warming coil measured to 0.02 %) the filter's slope noise is large and even big steps are
mostly absorbed (a 100-sigma step in R during a thermal rise: found in 21 % of trials).
"""
import math

import numpy as np

K = 0.5        # CUSUM allowance, in standard deviations: shifts above 2 K accumulate
H = 10.0       # CUSUM threshold
CAP = 4.0      # |z| counted at most: one wild recording is not a change
MIN_SERIES = 5  # recordings of a parameter needed before any change is looked for
HUBER = 2.0    # standardised innovations beyond this weigh linearly in the choice of a trend's slope noise
SLOPE_NOISE = 10.0 ** np.arange(-4.0, 4.01, 0.5)   # slope noise q / r tried for a series with a trend
REFERENCE = 2.0   # standard deviations of the reference's own error added to the allowance
HISTORY = 4    # recordings that set the first reference before any change is looked for


def detect_changes(recordings: list, names: list | None = None) -> list:
    """The changes of each parameter over recordings in time order.

    Parameters
    ----------
    recordings : list of dict
        Each with 'path', 'parameters' {name: value} and 'std' {name: one-sigma} (SI); values that are missing
        or not finite are left out of that parameter's series.
    names : list of str, optional
        The parameters to look at (default: those of the first recording, in its order).

    Returns
    -------
    list of dict
        {'parameter', 'path', 'index' (into `recordings`), 'before', 'after', 'sigma'} for each change, in the
        order of their index (then of `names`).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> damping = np.r_[np.full(20, 2.0), np.full(20, 2.4)] + 0.004 * rng.standard_normal(40)
    >>> runs = [{'path': f'r{i}.csv', 'parameters': {'damping': b}, 'std': {'damping': 0.004}}
    ...         for i, b in enumerate(damping)]
    >>> [(c['parameter'], c['index'], round(c['after'] - c['before'], 1)) for c in detect_changes(runs)]
    [('damping', 20, 0.4)]
    """
    if not recordings:
        return []
    names = list(recordings[0]['parameters']) if names is None else list(names)
    found = []
    for name in names:
        index, values, std = [], [], []
        for j, record in enumerate(recordings):
            value = record['parameters'].get(name)
            sigma = record['std'].get(name)
            if _finite(value) and _finite(sigma) and sigma >= 0:
                index.append(j)
                values.append(value)
                std.append(sigma)
        for at, before, after, sigma in series_changes(np.array(values), np.array(std)):
            j = index[at]
            found.append({'parameter': name, 'path': recordings[j]['path'], 'index': j, 'before': before,
                          'after': after, 'sigma': sigma})
    order = {name: k for k, name in enumerate(names)}
    return sorted(found, key=lambda c: (c['index'], order[c['parameter']]))


def _finite(value):
    return isinstance(value, (int, float, np.floating)) and math.isfinite(value)


def noise_model(values: np.ndarray, std: np.ndarray) -> tuple[float, float | None]:
    """(c^2, q): the factor by which the variances std^2 are too small, and the variance of the trend's slope
    change per recording (None: the series has no trend), from the series' differences.

    - c^2 = (1.4826 MAD(d2))^2 / (6 median(std^2)), at least 1, d2 the second differences (a level step moves
      only two of them; white noise of variance v gives them variance 6 v): the scatter between recordings that
      the within-record std does not cover (model error, a unit's day-to-day variation);
    - a trend: first differences of one sign far more often than chance allows (a sign test at 3 sigma, which a
      few steps do not move); then q is chosen from SLOPE_NOISE times c^2 median(std^2) by the likelihood of the
      trend filter's innovations (Huber's loss, so that a few steps weigh little).
    """
    base = max(float(np.median(std ** 2)), np.finfo(float).tiny)
    if len(values) < MIN_SERIES:
        return 1.0, None
    d2 = np.diff(values, 2)
    c2 = max(1.0, (1.4826 * float(np.median(np.abs(d2 - np.median(d2))))) ** 2 / (6.0 * base))
    signs = np.sign(np.diff(values))
    if abs(float(np.sum(signs))) < 3.0 * math.sqrt(np.count_nonzero(signs)):
        return c2, None
    return c2, _slope_noise(values, std ** 2 * c2, c2 * base)


def _slope_noise(values, r, base):
    """q of a series with a trend: the slope variance per recording, from SLOPE_NOISE times `base`, under which
    the trend filter's one-step innovations are likeliest (Huber's loss on them, so that a few steps weigh
    little)."""
    q = SLOPE_NOISE * base
    level, slope = values[1] + 0.0 * q, values[1] - values[0] + 0.0 * q
    p00, p01, p11 = r[1] + 0.0 * q, r[1] + 0.0 * q, r[0] + r[1] + 0.0 * q
    loss = np.zeros_like(q)
    for i in range(2, len(values)):
        level = level + slope
        p00, p01, p11 = p00 + 2.0 * p01 + p11, p01 + p11, p11 + q
        variance = p00 + r[i]
        innovation = values[i] - level
        z = np.abs(innovation) / np.sqrt(variance)
        loss += np.where(z <= HUBER, 0.5 * z * z, HUBER * z - 0.5 * HUBER ** 2) + 0.5 * np.log(variance)
        g0, g1 = p00 / variance, p01 / variance
        level, slope = level + g0 * innovation, slope + g1 * innovation
        p00, p01, p11 = p00 - g0 * p00, p01 - g0 * p01, p11 - g1 * p01
    return float(q[int(np.argmin(loss))])


def series_changes(values: np.ndarray, std: np.ndarray) -> list:
    """[(index, before, after, sigma)] of the changes in one parameter's series (see the module doc).

    Parameters
    ----------
    values, std : (N,) ndarray
        The estimates in time order and their one-sigma uncertainties (finite).

    Returns
    -------
    list of tuple
        Each change: the index where it starts, the level before and after it, and after - before in units of
        the recording-to-recording standard deviation there.
    """
    values, std = np.asarray(values, dtype=float), np.asarray(std, dtype=float)
    if len(values) < MIN_SERIES:
        return []
    c2, q = noise_model(values, std)
    return _changes(values, np.maximum(std ** 2, np.finfo(float).tiny) * c2, q)


def _changes(values, r, q):
    """series_changes with the noise model (r, q) given: the filter and the two CUSUMs over the series."""
    n = len(values)
    changes = []
    if q is None:                    # no trend: a level alone (the segment's running mean)
        filt = _Trend(values[0], 0.0, r[0], 0.0, 0.0, 0.0, anchor=0)
        first = 1
    else:
        filt = _Trend(values[1], values[1] - values[0], r[1], r[1], r[0] + r[1], q, anchor=1)
        first = 2
    for i in range(first, min(n, HISTORY)):   # the first recordings set the reference
        filt.update(i, values[i], r[i])
    high = low = 0.0
    high_start = low_start = None
    held = []     # recordings of the CUSUM excursions in progress: the filter takes them once they end in nothing
    for i in range(HISTORY, n):
        level, variance = filt.predict(i)
        raw = (values[i] - level) / math.sqrt(variance + r[i])
        z = min(max(raw, -CAP), CAP)
        allowance = K + REFERENCE * math.sqrt(variance / (variance + r[i]))   # the reference's own error allowed
        high, low = max(0.0, high + z - allowance), max(0.0, low - z - allowance)
        high_start = (high_start if high_start is not None else i) if high > 0 else None
        low_start = (low_start if low_start is not None else i) if low > 0 else None
        if high > H or low > H:
            at = _step_start(values, filt, high_start if high > H else low_start, i)
            before, _ = filt.predict(at)
            span = np.arange(at, i + 1)
            after = before + float(np.mean(values[span] - (before + filt.slope * (span - at))))
            changes.append((at, float(before), float(after), float((after - before) / math.sqrt(r[at]))))
            # the filter goes on from the new level at i with the slope it had, as uncertain as the mean of the
            # excursion's m recordings and m recordings' worth of slope noise
            m = len(span)
            filt = _Trend(after + filt.slope * (i - at), filt.slope, float(np.mean(r[span])) / m, 0.0,
                          filt.p11 + m * filt.q, filt.q, anchor=i)
            high = low = 0.0
            high_start = low_start = None
            held = []
        elif q is not None:   # a trend: the filter takes each recording at once (a reference held while the
            if abs(raw) <= CAP:   # trend bends would leave it behind), but for those beyond CAP (a step's)
                filt.update(i, values[i], r[i])
        else:   # a level: the filter takes every recording before the excursions in progress (all, if none)
            held.append(i)
            since = min((start for start in (high_start, low_start) if start is not None), default=i + 1)
            while held and held[0] < since:
                j = held.pop(0)
                filt.update(j, values[j], r[j])
    return changes


def _step_start(values, filt, first, last):
    """The start k in [first, last] of the step that best explains recordings first..last against the filter's
    prediction (the least-squares change point: the largest (sum of the departures from k on)^2 / their count)."""
    departures = np.array([values[j] - filt.predict(j)[0] for j in range(first, last + 1)])
    tails = np.cumsum(departures[::-1])[::-1] / np.sqrt(np.arange(len(departures), 0, -1))
    return first + int(np.argmax(np.abs(tails)))


class _Trend:
    """The local-linear-trend Kalman filter (level' = level + slope, slope' = slope + w, var w = q) after the
    recording `anchor`: its state (level, slope) and covariance [[p00, p01], [p01, p11]]."""

    def __init__(self, level, slope, p00, p01, p11, q, anchor):
        self.level, self.slope, self.p00, self.p01, self.p11, self.q = level, slope, p00, p01, p11, q
        self.anchor = anchor

    def _ahead(self, i):
        """(level, slope, p00, p01, p11) predicted for recording i > anchor."""
        level, slope, p00, p01, p11 = self.level, self.slope, self.p00, self.p01, self.p11
        for _ in range(i - self.anchor):
            level = level + slope          # [[1, 1], [0, 1]] P [[1, 0], [1, 1]] + diag(0, q)
            p00, p01, p11 = p00 + 2.0 * p01 + p11, p01 + p11, p11 + self.q
        return level, slope, p00, p01, p11

    def predict(self, i):
        """(level, its variance) predicted for recording i (before or after the anchor)."""
        if i <= self.anchor:   # a recording the filter has taken already: its level extrapolated back
            back = self.anchor - i
            return self.level - back * self.slope, self.p00 - 2.0 * back * self.p01 + back * back * self.p11
        level, _, p00, _, _ = self._ahead(i)
        return level, p00

    def update(self, i, value, r):
        """Take recording i (after the anchor) with its value and noise variance r."""
        level, slope, p00, p01, p11 = self._ahead(i)
        variance = p00 + r
        g0, g1 = p00 / variance, p01 / variance
        innovation = value - level
        self.level, self.slope = level + g0 * innovation, slope + g1 * innovation
        self.p00, self.p01, self.p11 = p00 - g0 * p00, p01 - g0 * p01, p11 - g1 * p01
        self.anchor = i
