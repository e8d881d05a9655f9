"""The discrepancy workflow's regressions: the identification's exact sampled-data rows (regressors.py),
linearised about a model, with the candidates' terms as further columns (docs/physics.md §3.6, §6.3).

Row k of regression `kind` predicts its output y_k = phi_k g(q) for the nominal parameters q (physical.coefficients:
exact at any sample period). About a model q0 the error of q = q0 + dq is linear in dq:

    y_k - phi_k g(q0) = phi_k J dq + sum over candidates of columns_k p,      J = dg/dq at q0,

so the nominal parameters are fitted as the correction dq, one for all the regressions (the coefficients of both
coil rows depend on R, L, Km, m and B), beside the candidates' parameters p; refitting about q0 + dq (fit.fit) is
Gauss-Newton on the exact rows.

A candidate's terms enter like the inputs whose place they take, through the gains of a voltage or a load force
held over each interval the row spans (physical.input_gains): an extra voltage drop e as -e times the voltage's
gain, a force f (opposing +x) as f times the load's gain, an extra inductance l as the voltage l dI/dt it takes.

- Electrical rows (the interval [t_k-1, t_k]): the terms at the middle of each of PIECES equal parts of the
  interval (the position and velocity of the cubic spline through the measured positions, the current along the
  model's own path from the interval's start to its end, bent by a term stiff in the current: Rows._path), each
  weighted by the row's gain of an input over that part
  (physical.piece_gains): the row does not weigh an interval's parts equally (a voltage acts on I_k the more the
  later it comes, through L/R).
- Mechanical rows (the intervals [t_k-1, t_k+1]): the terms at the middle of each of PIECES / 2 parts of
  both intervals (the spline's position and velocity, the current as above, a measured force linear), each
  weighted by the row's gain of that part: for a free mass the triangle, otherwise the row's own kernel. A spring's
  k x or a force constant's Km(x) I under a loop hunting at a 2 kHz logger is far from linear between samples.
  The force regression (a measured force) is the triangle's over -m.
- A force term that switches within an interval (a friction reversing) or needs the history of the motion (its
  contact) is given between the samples instead (Candidate.force_between: its mean over eighths of every
  interval), through the same gains.
"""
import functools
from dataclasses import replace

import numpy as np

from emla_core.parameters import PARAMETER_NAMES
from emla_core.physics import Candidate
from emla_identification.physical import MODEL_PARAMETERS, gains_jacobian, jacobian, piece_gains_jacobian, transition
from emla_identification.regressors import instruments, rows

from .data import PARTS, State, regression_rows

PIECES = 8   # parts of an electrical row's interval its terms are taken on, each at its middle (_electrical)
PARTS_PER_TAU = 8   # or as many per fastest time constant of the coil, where an inductance bends (Rows.parts)
MAX_PIECES = 64     # (a mechanical row's intervals: half as many each)
INSTRUMENT_LAG = 2   # rows: an electrical row's error holds the noise of samples k-1 and k; these hold k-3, k-2
MIN_INDUCTANCE = 0.1   # of the model's: the least a current's path takes (Rows._bent)
BEND = 0.05   # a candidate's voltage bends the current's path where its slope dV/dI reaches this share of R (bending)
KEPT_ROWS = 2   # Rows kept (rows_of): of two regressions about the three models last linearised about


_KEPT: 'dict[tuple, Rows]' = {}   # (id of the data, kind, model) -> Rows, least recently asked first


def bending(candidates, data, model):
    """The candidates whose terms, at their fitted values, bend the current's path through an interval somewhere
    over the data: a voltage (Candidate.path_voltage) whose slope dV/dI reaches BEND times the resistance, or an
    inductance (path_inductance) BEND times the model's ({name: value}). A gentler one (a weak drop, a drop fading
    over a wide band, a sensor offset's V_0 alone) moves the path by less than the move to the measured end
    corrects, and bending costs: sweep cases with a drive named took 1.5-3 times as long (Rows._bent)."""
    current, state = data.signals['current'], None
    out = []
    for c in candidates:
        voltage = c.path_voltage(current)
        if voltage is not None and np.max(voltage[1]) > BEND * model['resistance']:
            out.append(c)
        elif _inductive(c):
            state = data.state() if state is None else state
            inductance = c.path_inductance(state)
            if inductance is not None and np.max(np.abs(inductance)) > BEND * model['inductance']:
                out.append(c)
    return out


def rows_of(data, kind, model):
    """The Rows of regression `kind` of `data` about `model` ({name: value}), the last KEPT_ROWS asked for kept: a
    diagnosis fits hundreds of candidates and variants about one model, and the rows, their Jacobian and the states
    and current's path along each interval are the same for all of them. Read only. (Kept here, not on the data: a
    diagnosis keeps every candidate's fit and its data, and memory would grow with their number.)"""
    key = (id(data), kind) + tuple(float(model[name]) for name in nominal_names(data))
    rows = _KEPT.pop(key, None)
    if rows is None or rows.data is not data:   # (an id outlives its object)
        rows = Rows(data, kind, model)
    _KEPT[key] = rows   # the latest last
    while len(_KEPT) > KEPT_ROWS:
        del _KEPT[next(iter(_KEPT))]
    return rows


def nominal_names(data):
    """The nominal parameters of these data's regressions, in the order of physical.coefficients."""
    return MODEL_PARAMETERS['mechanical'] if data.kinds == ('force',) else PARAMETER_NAMES


@functools.lru_cache(maxsize=64)
def _linearised(kind, q0, sample_period):
    """(coefficients, their d/dq, (voltage gains, load gains, their d/dq)) of regression `kind` at the model q0 (a
    tuple): the same for every Rows linearised about one model, which a workflow makes hundreds of."""
    q0 = np.array(q0)
    coefficients, derivative = jacobian(kind, q0, sample_period)
    if kind == 'force':   # the acceleration per unit force is -1/m over both intervals
        load_slopes = np.zeros((2, len(q0)))
        load_slopes[:, 0] = 0.5 / q0[0] ** 2
        return coefficients, derivative, (np.zeros(2), np.full(2, -0.5 / q0[0]), np.zeros((2, len(q0))), load_slopes)
    return coefficients, derivative, gains_jacobian(kind, q0, sample_period)


@functools.lru_cache(maxsize=64)
def _piece_gains(kind, q0, sample_period, pieces):
    """physical.piece_gains_jacobian at the model q0 (a tuple), kept for the Rows linearised about it."""
    return piece_gains_jacobian(kind, np.array(q0), sample_period, pieces)


@functools.lru_cache(maxsize=64)
def _substep(q0, sample_period, pieces):
    """(P, G, H) of the model q0 (a tuple) over one of the 2 `pieces` equal steps of an interval (Rows._bent)."""
    return transition(np.array(q0), sample_period / (2 * pieces))


@functools.lru_cache(maxsize=64)
def _reach(q0, sample_period):
    """d x_k+1 / d v_k of the model q0 (a tuple): how far a start velocity carries the position over an interval."""
    return float(transition(np.array(q0), sample_period)[0][1, 2])


@functools.lru_cache(maxsize=64)
def _within(q0, sample_period, pieces):
    """The current's rows of (P, G, H) of the model q0 (a tuple) from an interval's start to each of 2 `pieces` + 1
    equally spaced times, its start to its end (times x 3, times, times)."""
    times = sample_period * np.linspace(0.0, 1.0, 2 * pieces + 1)
    p, g, h = transition(np.array(q0), times[:, None, None])   # one matrix exponential per time
    return p[:, 0], g[:, 0], h[:, 0]


def has_inductance(candidate):
    """Does the candidate have an inductance term (it can bend the current's path: Candidate.path_inductance)?"""
    return type(candidate).inductance is not Candidate.inductance


def _inductive(candidate):
    """Does the candidate, at its fitted values, give the current's path an inductance (path_inductance)?"""
    return bool(candidate.fitted) and has_inductance(candidate)


def _advanced(held, g, voltage, stiff, rise):
    """The state a path's step reaches: `held` (the state the step reaches with no voltage) plus the gains `g` of
    `voltage` less what terms of slope `stiff` (dV/dI) take from it over the step's current rise (`rise` without
    them), taken implicitly."""
    return held + np.outer(g, voltage - stiff * rise / (1.0 + g[0] * stiff))


class Rows:
    """Regression `kind` of `data` linearised about `model` ({name: value}): `phi` and `y` as regressors.rows
    gives them, `nominal` = phi J (the columns of dq), `target` = y - phi g(q0), the candidates' `columns`."""

    def __init__(self, data, kind, model):
        ts = data.sample_period
        self.data, self.kind, self.names = data, kind, nominal_names(data)
        q0 = self.q0 = np.array([model[name] for name in self.names], dtype=float)
        self.phi, self.y = rows(kind, data.signals, ts)
        self.coefficients, self.jacobian, gains = _linearised(kind, tuple(q0), ts)
        self.index = regression_rows(data)
        self.voltage_gains, self.load_gains, self.voltage_slopes, self.load_slopes = gains
        self.shaped = self._voltage_shape()
        self._kept, self._kept_terms = (), None   # the candidates _terms last gave all rows' terms for, and those
        self._memo = {}   # what every candidate's terms take on all rows alike (memoised)
        self.prediction = self.phi @ self.coefficients
        if self.shaped is not None:
            self.prediction = self.prediction + self.shaped @ self._shape_gains()[0]
        for shared in (self.phi, self.y, self.prediction):   # shared by every fit about this model (rows_of)
            shared.flags.writeable = False

    @functools.cached_property
    def nominal(self):
        out = self.phi @ self.jacobian
        if self.shaped is not None:
            out = out + self.shaped @ self._shape_gains()[1]
        out.flags.writeable = False
        return out

    @functools.cached_property
    def target(self):
        out = self.y - self.prediction
        out.flags.writeable = False
        return out

    def memoised(self, key, keep, make):
        """make(), kept under `key` where `keep`: what every fit about this model takes alike."""
        if not keep:
            return make()
        if key not in self._memo:
            self._memo[key] = make()
        return self._memo[key]

    def _voltage_shape(self):
        """Each row's voltage less its interval mean over every part of the intervals the row spans (rows x
        parts), where a re-alignment left the voltage not held over the interval (data.Data.voltage_parts): the
        rows' columns take the mean, held, through the interval's gain; this through each part's gain
        (_shape_gains) makes them exact. None when the voltage is held or the rows take none."""
        deviation = self.data.voltage_deviation()
        if deviation is None or self.kind == 'force':
            return None
        k = self.index
        if self.kind == 'electrical':   # the voltage over [t_k-1, t_k]
            return deviation[k - 1]
        return np.hstack((deviation[k - 1], deviation[k]))   # over [t_k-1, t_k] and [t_k, t_k+1]

    def _shape_gains(self):
        """(gain, its d/dq) of a voltage over each of the PARTS parts of the intervals the row spans, in time order."""
        voltage, _, slopes, _ = self._pieces(PARTS)
        return voltage.reshape(-1), slopes.reshape(-1, slopes.shape[-1])

    def scale(self):
        """Row residual -> physical units: (factor, quantity): the voltage (V) of an electrical row, the force (N)
        of a mechanical one (the inverse of the input's total gain)."""
        if self.kind == 'electrical':
            return 1.0 / float(self.voltage_gains[0]), 'voltage'
        return 1.0 / abs(float(np.sum(self.load_gains))), 'force'

    def instruments(self, candidates):
        """The electrical rows' instruments laid out like [nominal | columns]: the regressors' instruments
        (regressors.instruments) through J, the candidate columns INSTRUMENT_LAG rows earlier."""
        data = self.data
        zeta = self.memoised('instruments', True,
                             lambda: instruments(self.kind, data.signals, data.sample_period) @ self.jacobian)
        extra = self.columns(candidates)
        lagged = np.vstack((np.repeat(extra[:1], INSTRUMENT_LAG, axis=0), extra[:len(extra) - INSTRUMENT_LAG]))
        return np.column_stack((zeta, lagged))

    def columns(self, candidates, rows=slice(None), current=None):
        """(n, sum of the candidates' parameters) columns at regression rows `rows`; `current`: the electrical
        rows' start currents to use instead of the measured ones (a prediction)."""
        blocks = [np.zeros((len(self.y[rows]), 0))]
        parts = self.parts(candidates)
        for candidate, (voltage, load) in zip(candidates, self._terms(candidates, rows, current)):
            between = candidate.force_between(self.data)
            block = (np.tensordot(self._weights('load_gains', parts), load, 1) if between is None
                     else self._between(between, rows, self._pieces(between.shape[1])[1])) \
                - np.tensordot(self._weights('voltage_gains', parts), voltage, 1)
            blocks.append(block * candidate.free())
        return np.hstack(blocks)

    def parts(self, candidates):
        """The parts of an electrical row's interval the candidates' terms are taken on (a mechanical row's
        intervals: half as many each): PIECES, or where an inductance bends the current's path (_bent), enough that
        each part is at most 1/PARTS_PER_TAU of the coil's fastest time constant (its least L + l over R), up to
        MAX_PIECES. At 2 kHz an iron saturating to a third of L (Table 1: L/R 1.3 sample periods at its least)
        kept Km 0.76 % and B 10 % off on 8 parts (noise-free), 0.08 and 1.0 % on 32."""
        model = dict(zip(self.names, self.q0))
        inductive = 'resistance' in model and [c for c in bending(candidates, self.data, model) if _inductive(c)]
        if not inductive:
            return PIECES
        least = model['inductance'] + np.min(sum(c.path_inductance(self.data.state()) for c in inductive))
        fastest = max(least, MIN_INDUCTANCE * model['inductance']) / model['resistance']
        need = int(np.ceil(PARTS_PER_TAU * self.data.sample_period / fastest))
        return int(min(MAX_PIECES, 2 * ((max(need, PIECES) + 1) // 2)))   # even: a mechanical row takes half

    def _pieces(self, pieces):
        """(voltage, load piece gains, their d/dq) of `pieces` parts per interval (physical.piece_gains) at the
        model the rows are linearised about."""
        return _piece_gains(self.kind, tuple(self.q0), self.data.sample_period, pieces)

    def _between(self, between, rows, gains):
        """A force term given between the samples (Candidate.force_between) through the rows' gain of each part of
        their intervals (`gains`: intervals x pieces, or x parameters too for the derivatives)."""
        k = self.index[rows]
        out = np.tensordot(between[k - 1], gains[0], axes=(1, 0))   # (n, q, ...): sum over the pieces
        if self.kind != 'electrical':   # the second interval of a mechanical row
            out = out + np.tensordot(between[k], gains[1], axes=(1, 0))
        return out

    def slopes(self, candidates, added):
        """(n, nominal parameters): d/dq of the candidates' terms with parameters `added` (their columns depend on
        the model through the input gains): the cross terms of the Gauss-Newton step about (q0, added)."""
        out = np.zeros((len(self.y), len(self.names)))
        start, parts = 0, self.parts(candidates)
        for candidate, (voltage, load) in zip(candidates, self._terms(candidates, slice(None), None)):
            p = added[start:start + voltage.shape[-1]]
            start += len(p)
            between = candidate.force_between(self.data)
            if between is not None:
                out += np.einsum('nqj,q->nj', self._between(between, slice(None),
                                                            self._pieces(between.shape[1])[3]), p)
                load = np.zeros_like(load)
            for j in range(len(voltage)):
                out += np.outer(load[j] @ p, self._weights('load_slopes', parts)[j]) \
                    - np.outer(voltage[j] @ p, self._weights('voltage_slopes', parts)[j])
        return out

    def _terms(self, candidates, rows, current):
        """Per candidate: (voltage terms, load-force terms) at each piece of the row (pieces x n x parameters, zero
        where it has none, and the load's where it is given between the samples). The terms are taken at the current
        along the model's path (_path), an extra inductance l(I, x) as the voltage l dI/dt with the path's rate over
        the piece."""
        whole = current is None and rows == slice(None)   # the fit's columns, its slopes and instruments: kept
        if whole and self._kept_terms is not None and len(self._kept) == len(candidates) \
                and all(a is b for a, b in zip(self._kept, candidates)):
            return self._kept_terms
        parts = self.parts(candidates)
        pieces, paths = self._electrical(rows, current, candidates, parts, whole) if self.kind == 'electrical' \
            else self._samples(rows, candidates, parts // 2, whole)
        out = []
        for c in candidates:
            shape = (len(pieces), len(pieces[0].index), len(c.parameters))
            voltage, load = np.zeros(shape), np.zeros(shape)
            between = c.force_between(self.data) is not None
            for j, state in enumerate(pieces):
                along = state if paths is None else replace(state, current=paths[0][j])   # on the model's path
                e, f = c.voltage(along), None if between else c.force(along)
                inductance = None if paths is None else c.inductance(along)
                if e is not None:
                    voltage[j] = e.T
                if inductance is not None:
                    voltage[j] += (inductance * paths[1][j]).T
                if f is not None:
                    load[j] = f.T
            out.append((voltage, load))
        if whole:
            self._kept, self._kept_terms = tuple(candidates), out
        return out

    def _path(self, j, start, end, pieces, candidates):
        """(the current at the middle of each of `pieces` parts of the intervals [t_j, t_j+1], its mean rate over
        each part): the model's own path from `start` under the interval's voltage (the coil's L/R bends it: at a
        2 kHz logger a step's current rises mostly early in the interval), moved linearly in time to meet `end`.
        Taken as linear instead, a saturating inductance's l dI/dt lands late in the interval, and the rows' unequal
        weighting of its parts turns that into a bias of Km, m and B (7-30 sigma at 2-3 kHz; docs/physics.md 6.3).
        A candidate's voltage stiff in the current (Candidate.path_voltage) bends the path as well (_bent), and
        where its slope dV/dI holds the current the path is moved the less, by R / (R + slope): there the current
        forgets its start within microseconds, and moving it to the measured end would spread that sample's noise
        over the interval (5 mA against a 25 mA band: the fade current found 7 % wide, R 11 sigma off)."""
        ts = self.data.sample_period
        signals = self.data.signals
        s = np.stack((start, signals['position'][j], self.data.velocity()[j]))
        bends = bending(candidates, self.data, dict(zip(self.names, self.q0)))
        anchor = np.linspace(0.0, 1.0, 2 * pieces + 1)[:, None]   # the share of the miss at the end moved in
        if bends:
            inductive = [c for c in bends if _inductive(c)]
            model, slope, last = self._bent(s, j, signals['voltage'][j], bends, inductive, pieces)
            if inductive:   # the start velocity that meets the measured end position on this path (_bent)
                s[2] += (signals['position'][j + 1] - last[1]) / _reach(tuple(self.q0[:6]), ts)
                model, slope, _ = self._bent(s, j, signals['voltage'][j], bends, inductive, pieces)
            anchor = anchor * (self.q0[0] / (self.q0[0] + slope))
        else:
            p, g, h = _within(tuple(self.q0[:6]), ts, pieces)
            model = p @ s + np.outer(g, signals['voltage'][j]) + h[:, None] * self.q0[5]
        path = model + anchor * (end - model[-1])
        return list(path[1::2]), list((path[2::2] - path[:-1:2]) * (pieces / ts))

    def _bent(self, s, j, voltage, bends, inductive, pieces):
        """(the model's currents, the slopes dV/dI of the candidates' `bends` voltages there) at 2 `pieces` + 1 equal
        steps through the intervals [t_j, t_j+1] from the states s (3 x n) under the held `voltage` less those voltages
        at the current (Candidate.path_voltage) and the voltage l dI/dt the inductance l of those `inductive` takes
        (path_inductance); and the states the path ends in. A dead-time drop V_d reversing over I_eps acts about zero
        current as a resistance V_d / I_eps, up to 30 times R (time constants of 20 us): the current settles within the
        band early in an interval, and a path without the drop puts it there late (L 1 % off at 10 kHz). An iron
        saturated to half its inductance doubles the current's rate and its bend by L/R: a path at the model's L put its
        l dI/dt where it is not (R, Km 4-5 sigma off at 20 kHz, 0.02-0.08 %; 0.0000 and 0.003 % on the path with l,
        noise-free). Each step takes the drop implicitly in its slope and l dI/dt in its rise, so stable at any
        stiffness, l as the mean of its values at the step's ends (predicted, then corrected: with l at the start alone,
        a noise-free 2 kHz record of an iron saturating to a third of L kept 1.8 times the current's misfit). The
        inductance a path takes is at least MIN_INDUCTANCE times the model's: a fitted l may overshoot. Where an
        inductance bends it, the path starts at the velocity that takes it to the measured position at the interval's
        end (_path): at 2 kHz the five-point velocity is 15 mm/s (rms) off the motion's on a clean noise-free record,
        which puts the path 28 mA off the measured current at the end, and the move to it (linear in time) lands in l
        dI/dt where l is large."""
        step, floor = self.data.sample_period / (2 * pieces), -(1.0 - MIN_INDUCTANCE) * self.q0[1]

        def drop(current):
            drops = [d for d in (c.path_voltage(current) for c in bends) if d is not None]
            return sum(d[0] for d in drops), np.maximum(sum(d[1] for d in drops), 0.0)

        def inductance(s):
            state = State(self.data, j, position=s[1], velocity=s[2], current=s[0])
            return np.maximum(sum(c.path_inductance(state) for c in inductive), floor)
        p, g, h = _substep(tuple(self.q0[:6]), self.data.sample_period, pieces)
        value, slope = drop(s[0])
        extra = inductance(s) if inductive else 0.0
        out, slopes = [s[0]], [slope * np.ones_like(s[0])]
        for _ in range(2 * pieces):
            held = p @ s + h[:, None] * self.q0[5]
            rise = held[0] + g[0] * (voltage - value) - s[0]   # the step's rise at the drop of its start
            # dV/dI over the step: the drops' slope, and l / step of l dI/dt at the mean of the ends' l
            ahead = _advanced(held, g, voltage - value, slope + extra / step, rise)
            if inductive:
                ahead = _advanced(held, g, voltage - value, slope + 0.5 * (extra + inductance(ahead)) / step, rise)
                extra = inductance(ahead)
            s = ahead
            value, slope = drop(s[0])
            out.append(s[0])
            slopes.append(slope * np.ones_like(s[0]))
        return np.array(out), np.array(slopes), s

    def _step(self, rows, start):
        """The model's I_k from I_k-1 = `start` (and the rows' other regressors)."""
        step = start * self.coefficients[0] + self.phi[rows, 1:] @ self.coefficients[1:]
        return step if self.shaped is None else step + self.shaped[rows] @ self._shape_gains()[0]

    def _weights(self, name, parts):
        """Each piece's weight of the gains `name` (voltage_gains, load_gains, or their d/dq: voltage_slopes,
        load_slopes, along a last axis): the electrical row's gain of each of the PIECES parts of its interval
        (physical.piece_gains: the row weighs the parts unequally, the back-EMF through L/R the interval's end);
        the mechanical rows' of each of the half as many parts of both intervals, in turn (module doc); `parts`:
        an electrical row's (Rows.parts)."""
        electrical = self.kind == 'electrical'
        voltage, load, voltage_slopes, load_slopes = self._pieces(parts if electrical else parts // 2)
        gains = {'voltage_gains': voltage, 'load_gains': load, 'voltage_slopes': voltage_slopes,
                 'load_slopes': load_slopes}[name]
        return gains[0] if electrical else gains.reshape((-1,) + gains.shape[2:])   # both intervals' parts in turn

    def _electrical(self, rows, current, candidates, parts, whole):
        """([the states along the interval [t_k-1, t_k] at the middle of each of its `parts` parts], _path's currents
        and rates there, from the interval's start to its end: the measured currents, or in a prediction the model's
        step): the position and velocity of the cubic spline through the measured positions, the current linear in time
        (the terms take _path's instead: _terms). `whole`: all rows from the measured currents (kept: memoised)."""
        k = self.index[rows]
        start = self.phi[rows, 0] if current is None else current
        end = self.y[rows] if current is None else self._step(rows, start)

        def states():
            between = self.data.between(parts)
            position, velocity = between['position'][k - 1], between['velocity'][k - 1]   # one gather, then views
            return [State(self.data, k - 1, position=position[:, m], velocity=velocity[:, m],
                          current=start + (m + 0.5) / parts * (end - start), voltage=self.phi[rows, 1])
                    for m in range(parts)]
        return (self.memoised(('states', parts), _kept(whole, parts), states),
                self._along(candidates, whole, parts, lambda: self._path(k - 1, start, end, parts, candidates)))

    def _along(self, candidates, whole, parts, path):
        """path(): the current's path (_path), kept where no candidate bends it (it is then the model's alone)."""
        return self.memoised(('path', parts), _kept(whole, parts) and not bending(
            candidates, self.data, dict(zip(self.names, self.q0))), path)

    def _samples(self, rows, candidates, parts, whole):
        """([the states at the middle of each of the `parts` parts of the intervals [t_k-1, t_k] and [t_k, t_k+1], in
        turn], _path's currents and rates there or None for the force regression): the cubic spline's position and
        velocity, the current (or force) linear between its samples, the voltage held. A force along the row is so taken
        where it acts, through the row's gain of each part: a spring's k x is not linear between the samples of a loop
        hunting at a 2 kHz logger. `whole`: all rows (kept: memoised)."""
        k = self.index[rows]

        def states():
            between = self.data.between(parts)
            out = []
            for j in (k - 1, k):
                position, velocity = between['position'][j], between['velocity'][j]   # one gather, then views
                ends = {name: (values[j], values[j + 1])
                        for name, values in self.data.signals.items() if name != 'position'}
                for m in range(parts):
                    share = (m + 0.5) / parts
                    others = {name: first if name == 'voltage' else (1.0 - share) * first + share * last
                              for name, (first, last) in ends.items()}
                    out.append(State(self.data, j, position=position[:, m], velocity=velocity[:, m], **others))
            return out
        pieces = self.memoised(('states', parts), _kept(whole, parts), states)
        if self.kind != 'mechanical':   # the force regression has no coil
            return pieces, None

        def path():   # on each interval once: a row's second is the next row's first
            spans = np.arange(k[0] - 1, k[-1] + 1) if len(k) else k
            current = self.data.signals['current']
            along = self._path(spans, current[spans], current[spans + 1], parts, candidates)
            at = [np.searchsorted(spans, j) for j in (k - 1, k)]
            return ([c[i] for i in at for c in along[0]], [r[i] for i in at for r in along[1]])
        return pieces, self._along(candidates, whole, parts, path)


def _kept(whole, parts):
    """Are the states and path of a row's parts kept (Rows.memoised): taken on all rows from the measured currents
    (`whole`), on the usual parts (finer ones, where an inductance bends, would take up to 8 times the memory)?"""
    return whole and parts in (PIECES, PIECES // 2)
