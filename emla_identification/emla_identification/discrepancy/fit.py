"""The nominal regressions of first_order.py, augmented by candidate terms, solved jointly and judged on
held-out blocks.

Rows of the electrical and the mechanical regression are stacked, each weighted by 1/sigma of its nominal
residual, so that a parameter shared by both equations (Km(x)) is fitted once. The h-dependent
coefficient of each regression is tied (regressors.tie) with h = R Ts / L of the model the fit is
linearised about. A candidate's columns are its terms linearised about that model (one Gauss-Newton step;
`fit` refits once about the result), scaled so that their coefficients are the candidate's physical
parameters:

    electrical, I_k+1 = alpha I_k + beta (u_k - Km v) over one interval, so
        voltage term e:        -beta e
        inductance term l:     dI_k+1/dL * l = -(alpha Ts / L^2) (u_k - R I_k - Km v) l
    mechanical, second difference of position / Ts^2 = triangle-weighted (force / m) - ..., so
        force term f:          -(f_k-1 + 4 f_k + f_k+1) / (6 m)

The electrical terms see the interval: its mean current (from the model's step, free of the output's
noise), mid position and back-EMF velocity; the mechanical ones see each sample.

The mechanical rows (output, regressors and candidate columns alike, which keeps the estimates unbiased,
physics.md) are prefiltered by (1 - rho) / (1 - rho q^-1)^2, rho = PREFILTER. The second difference of
position multiplies the white position noise by (1 - q^-1)^2, putting nearly all of it at high frequency
where no effect of interest lives; the prefilter undoes most of that (a partial whitening, as in
generalised least squares), so held-out errors measure the effects rather than the quantisation.
rho -> 1 would whiten fully but lets the lowest frequencies dominate a misspecified nominal fit.

The record is cut into FOLDS contiguous blocks and every block's sums of squares are kept, so each
leave-one-block-out fit and its error on the block it left out cost one small solve. The blocks give the
held-out (cross-validated) residuals and delete-one-block jackknife uncertainties, which stay honest when
residuals are coloured (by correlations shorter than a block).
"""
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .data import State, regression_rows
from .first_order import coil_parameters, force_parameters, instruments, rows, tie

FOLDS = 10
PREFILTER = 0.9
RELINEARISATIONS = 4
SYSTEMATIC_PREFILTERS = (0.8, 0.95)   # alternatives whose estimates bound the misfit bias (with_systematic)
NOMINAL = {'electrical': ('resistance', 'inductance', 'emf_constant'),
           'mechanical': ('mass', 'damping', 'load_force'), 'force': ('mass', 'damping', 'load_force')}


def _decay(model, ts):
    """h = R Ts / L of a model (0 without coil parameters: the force regression needs no tie)."""
    return model['resistance'] * ts / model['inductance'] if 'inductance' in model else 0.0


class ElectricalRows:
    """The tied electrical regression [I_k, u_k, -v] -> I_k+1 of `data` about `model`, and candidate columns."""

    def __init__(self, data, model):
        self.data, self.model = data, model
        ts = data.sample_period
        phi, self.y = rows('electrical', data.signals, ts)
        h = _decay(model, ts)
        self.phi = phi @ tie('electrical', h).T
        self.alpha, self.beta = np.exp(-h), -np.expm1(-h) / model['resistance']
        self.velocity = -self.phi[:, 2]    # the back-EMF's weighted mean velocity over the interval
        self.index = regression_rows(data)
        x = data.signals['position']
        self.position = 0.5 * (x[self.index] + x[self.index + 1])

    def columns(self, candidates, rows=slice(None), current=None):
        """(n, q) columns at regression rows `rows`, with the interval-start current `current` if given."""
        m = self.model
        current = self.phi[rows, 0] if current is None else current
        voltage = self.phi[rows, 1]
        if not candidates:
            return np.zeros((len(voltage), 0))
        drop = voltage - m['resistance'] * current - m['emf_constant'] * self.velocity[rows]
        state = State(self.data, self.index[rows], position=self.position[rows], velocity=self.velocity[rows],
                      current=0.5 * ((1.0 + self.alpha) * current + self.beta * drop), voltage=voltage)
        blocks = []
        for c in candidates:
            block = np.zeros((len(voltage), len(c.parameters)))
            e, li = c.voltage(state), c.inductance(state)
            if e is not None:
                block -= self.beta * e.T
            if li is not None:
                block -= (self.alpha * self.data.sample_period / m['inductance'] ** 2) * (drop * li).T
            blocks.append(block)
        return np.hstack(blocks)


def mechanical_rows(data, model, candidates, rho=PREFILTER):
    """(Phi tied, Y, candidate force columns) of the mechanical (or force) regression about `model`."""
    kind = data.mechanical
    phi, y = rows(kind, data.signals, data.sample_period)
    phi = phi @ tie(kind, _decay(model, data.sample_period)).T
    state = data.state()
    blocks = [np.zeros((len(y), 0))]
    for c in candidates:
        f = c.force(state)
        if f is None:
            blocks.append(np.zeros((len(y), len(c.parameters))))
        else:
            blocks.append(-(f[:, 1:-3] + 4.0 * f[:, 2:-2] + f[:, 3:-1]).T / (6.0 * model['mass']))
    extra = np.hstack(blocks)
    held = held_samples(data, candidates)
    if held is not None:   # rows whose whole second difference is stuck: no acceleration, whatever the forces
        k = regression_rows(data)
        stuck = held[k - 1] & held[k] & held[k + 1]
        phi, extra = np.where(stuck[:, None], 0.0, phi), np.where(stuck[:, None], 0.0, extra)
    if rho is not None:
        filtered = lfilter([1.0 - rho], [1.0, -2.0 * rho, rho * rho], np.column_stack((phi, y, extra)), axis=0)
        phi, y, extra = filtered[:, :phi.shape[1]], filtered[:, phi.shape[1]], filtered[:, phi.shape[1] + 1:]
    return phi, y, extra


def held_samples(data, candidates):
    """Samples at which some candidate holds the part still (Candidate.held), or None."""
    masks = [m for m in (c.held(data) for c in candidates) if m is not None]
    return np.logical_or.reduce(masks) if masks else None


def design(data, model, candidates, rho=PREFILTER):
    """{kind: (Phi tied, Y, candidate columns)} about `model`; the mechanical rows prefiltered with `rho`
    (None: not prefiltered)."""
    out = {}
    if data.electrical:
        electrical = ElectricalRows(data, model)
        out['electrical'] = (electrical.phi, electrical.y, electrical.columns(candidates))
    out[data.mechanical] = mechanical_rows(data, model, candidates, rho)
    return out


@dataclass
class ModelOnData:
    """The model nominal + `candidates` on `data` as the coefficients of its regressions: what the subsystem
    predictions (predict.py) and the residuals need, whether the model was fitted here (a Fit) or given."""

    data: object
    candidates: tuple
    theta: dict            # kind -> tied nominal coefficients
    added: np.ndarray      # the candidates' parameters, in order
    parameters: dict       # nominal physical parameters (greybox names), + 'sample_period'
    linearised_about: dict  # the model the candidates' columns and the tie are evaluated about

    def added_slices(self):
        """(candidate, slice of `added`) pairs."""
        out, start = [], 0
        for c in self.candidates:
            out.append((c, slice(start, start + len(c.parameters))))
            start += len(c.parameters)
        return out

    def residuals(self):
        """{kind: one-step residual of each regression row (rows: data.regression_rows)}."""
        return {kind: y - phi @ self.theta[kind] - extra @ self.added
                for kind, (phi, y, extra) in design(self.data, self.linearised_about, self.candidates,
                                                    rho=None).items()}


@dataclass
class Fit(ModelOnData):
    """The model nominal + `candidates` fitted to `data`, with its uncertainties and held-out blocks."""

    added_std: np.ndarray  # the added parameters' jackknife one-sigma
    sigma: dict            # kind -> row weight 1/sigma (the reference's residual std)
    rms: dict              # kind -> this fit's residual std
    heldout: np.ndarray    # (FOLDS, kinds): weighted residual sum of squares of each block when left out
    std: dict              # the nominal parameters' jackknife one-sigma
    left_out: np.ndarray   # (FOLDS, coefficients): the fit without each block ([nominal of each kind | added])
    bounds: np.ndarray     # regression rows of each block: bounds[f] .. bounds[f + 1]

    def heldout_residuals(self):
        """{kind: one-step residual of each regression row, each block's from the fit that left it out}."""
        out, start = {}, 0
        added = self.left_out[:, sum(len(t) for t in self.theta.values()):]
        for kind, (phi, y, extra) in design(self.data, self.linearised_about, self.candidates,
                                            rho=None).items():
            coefficients = self.left_out[:, start:start + phi.shape[1]]
            start += phi.shape[1]
            e = np.empty(len(y))
            for f in range(FOLDS):
                r = slice(self.bounds[f], self.bounds[f + 1])
                e[r] = y[r] - phi[r] @ coefficients[f] - extra[r] @ added[f]
            out[kind] = e
        return out


def fit(data, candidates=(), reference=None, *, relinearise=True):
    """Nominal + candidates fitted to data, linearised about and weighted like `reference` (a Fit).

    Without a reference, the nominal model is fitted first and serves as one. With `relinearise` the
    result is refitted about itself (up to RELINEARISATIONS times), so that the candidates' columns (and
    the tie) follow the re-identified model rather than the reference.
    """
    candidates = tuple(candidates)
    if reference is None:
        start = _coil_guess(data)
        unweighted = _solve(data, (), start, {kind: 1.0 for kind in data.kinds})
        reference = _solve(data, (), unweighted.parameters, unweighted.rms)
        if not candidates:
            return reference
    result = _solve(data, candidates, reference.parameters, reference.sigma)
    # the candidate columns are scaled by the model they are linearised about (1/m, beta, ...), so their
    # parameters are right only once that model is the estimate itself: refit until it stops moving
    for _ in range(RELINEARISATIONS if relinearise else 0):
        if not physical(result.parameters):
            break
        previous, result = result, _solve(data, candidates, result.parameters, reference.sigma)
        if all(abs(result.parameters[k] - v) <= 1e-9 * abs(v) for k, v in previous.parameters.items()):
            break
    return result


def with_systematic(fit, alternatives=SYSTEMATIC_PREFILTERS):
    """(std of the nominal parameters, std of the added ones) of a Fit with a systematic part: the largest
    change of each estimate when the mechanical rows are prefiltered otherwise (a prefilter weighs the
    frequencies differently; estimates that move with it carry a misfit bias the jackknife cannot see),
    added in quadrature to the jackknife sigma."""
    alternatives = [_solve(fit.data, fit.candidates, fit.linearised_about, fit.sigma, rho) for rho in alternatives]
    shift = {k: max(abs(a.parameters[k] - fit.parameters[k]) for a in alternatives) for k in fit.std}
    added_shift = np.max([np.abs(a.added - fit.added) for a in alternatives], axis=0) if len(fit.added) else fit.added
    return ({k: float(np.hypot(s, shift[k])) for k, s in fit.std.items()}, np.hypot(fit.added_std, added_shift))


def physical(parameters):
    """Whether a parameter set is a possible actuator (finite; R, L, m positive where present)."""
    return all(np.isfinite(v) for v in parameters.values()) and \
        all(parameters.get(name, 1.0) > 0 for name in ('resistance', 'inductance', 'mass'))


def _coil_guess(data):
    """R and L from the untied electrical regression, to tie it (h) in the first fit."""
    if not data.electrical:
        return {}
    phi, y = rows('electrical', data.signals, data.sample_period)
    alpha, beta = np.linalg.lstsq(phi, y, rcond=None)[0][:2]
    resistance = (1.0 - alpha) / beta
    return {'resistance': resistance, 'inductance': resistance * data.sample_period / -np.log(alpha)}


def _solve(data, candidates, model, sigma, rho=PREFILTER):
    """The Fit of `candidates` about `model` with row weights 1/sigma: the electrical rows by instrumental
    variables (their regressors, candidate columns included, one row earlier: the current noise of row k
    sits in its regressors and its output, not in those of row k-1; greybox.py does the same), the
    mechanical rows by least squares."""
    blocks = design(data, model, candidates, rho)
    kinds = tuple(blocks)
    widths = [blocks[k][0].shape[1] for k in kinds]
    q = next(iter(blocks.values()))[2].shape[1]
    n = sum(widths) + q
    index = regression_rows(data)
    bounds = np.searchsorted(index * FOLDS // len(data), np.arange(FOLDS + 1))   # contiguous blocks
    # per block and regression: Z'Z and W'Z, Z = [Phi | Y] / sigma, W the instruments (Z for least squares)
    sums = np.zeros((FOLDS, len(kinds), n + 1, n + 1))
    instrumented = np.zeros_like(sums)
    for j, kind in enumerate(kinds):
        phi, y, extra = blocks[kind]
        z = np.column_stack((phi, extra, y))
        w = z if kind != 'electrical' else _electrical_instruments(data, model, z)
        # this regression's columns within the stacked [nominal of each kind | candidates | Y]
        at = np.r_[sum(widths[:j]):sum(widths[:j + 1]), sum(widths):n + 1]
        for f in range(FOLDS):
            zf, wf = z[bounds[f]:bounds[f + 1]], w[bounds[f]:bounds[f + 1]]
            sums[f, j][np.ix_(at, at)] = zf.T @ zf / sigma[kind] ** 2
            instrumented[f, j][np.ix_(at, at)] = wf.T @ zf / sigma[kind] ** 2
    total, total_w = sums.sum(axis=(0, 1)), instrumented.sum(axis=(0, 1))
    theta = _solve_normal(total_w, total, n)
    left_out = np.array([_solve_normal(total_w - instrumented[f].sum(axis=0), total - sums[f].sum(axis=0), n)
                         for f in range(FOLDS)])
    heldout = np.array([[_rss(sums[f, j], t, n) for j in range(len(kinds))] for f, t in enumerate(left_out)])
    rows_per_kind = len(index)
    # residual std of each equation, floored for noise-free data (it becomes a row weight)
    rms = {kind: sigma[kind] * max(np.sqrt(max(_rss(sums[:, j].sum(axis=0), theta, n), 0.0) / (rows_per_kind - n)),
                                   1e-9 * np.sqrt(sums[:, j, n, n].sum() / rows_per_kind))
           for j, kind in enumerate(kinds)}
    nominal = slice(0, sum(widths))
    values = _physical(kinds, np.vstack((theta, left_out))[:, nominal], data.sample_period)
    names = [name for kind in kinds for name in NOMINAL[kind]]
    added = slice(sum(widths), n)
    return Fit(data=data, candidates=candidates,
               theta={k: theta[sum(widths[:j]):sum(widths[:j + 1])] for j, k in enumerate(kinds)},
               added=theta[added], parameters=dict(zip(names, map(float, values[0])), sample_period=data.sample_period),
               linearised_about=model, added_std=_jackknife_std(left_out[:, added]), sigma=sigma, rms=rms,
               heldout=heldout, std=dict(zip(names, map(float, _jackknife_std(values[1:])))), left_out=left_out,
               bounds=bounds)


def _electrical_instruments(data, model, z):
    """The electrical rows' instruments, laid out like z = [Phi tied | candidate columns | Y]: the regressors'
    instruments of regressors.instruments (tied), the candidate columns one row earlier, and Y as it is
    (its row of W'Z is not used)."""
    h = _decay(model, data.sample_period)
    zeta = instruments('electrical', data.signals, data.sample_period) @ tie('electrical', h).T
    width = zeta.shape[1]
    extra = z[:, width:-1]
    lagged = np.vstack((extra[:1], extra[:-1]))
    return np.column_stack((zeta, lagged, z[:, -1]))
def _physical(kinds, coefficients, ts):
    """Physical parameters (NOMINAL order) from rows of tied coefficients."""
    with np.errstate(all='ignore'):
        return force_parameters(coefficients, ts) if kinds == ('force',) else coil_parameters(coefficients, ts)


def _jackknife_std(left_out):
    """Delete-one-block jackknife standard deviation of each column of the leave-one-out estimates."""
    deviation = left_out - left_out.mean(axis=0)
    return np.sqrt((FOLDS - 1) / FOLDS * np.sum(deviation ** 2, axis=0))


def _solve_normal(gw, g, n):
    """theta of the normal equations held in gw = W'Z (instruments; = Z'Z for least squares), Z = [Phi | Y];
    columns scaled by g = Z'Z for conditioning."""
    if not (np.all(np.isfinite(gw)) and np.all(np.isfinite(g))):
        return np.full(n, np.nan)
    scale = np.sqrt(np.diag(g)[:n])
    scale[scale == 0] = 1.0
    return np.linalg.lstsq(gw[:n, :n] / np.outer(scale, scale), gw[:n, n] / scale, rcond=1e-13)[0] / scale


def _rss(s, theta, n):
    return float(s[n, n] - 2.0 * theta @ s[:n, n] + theta @ s[:n, :n] @ theta)
