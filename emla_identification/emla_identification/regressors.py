"""Grey-box regressions of the EMLA, exact for its sampled data at any sample period (docs/physics.md §8).

Sample k holds the current I_k, the position x_k (or the velocity v_k) measured at t_k and the voltage u_k
applied over [t_k, t_k+1] (zero-order hold). Over one interval the state s = [I, x, v] of

    u = R I + L dI/dt + Km v,      m dv/dt = Km I - B v - F,   F the load force (and the effects' forces),

moves exactly as s_k+1 = P s_k + G u_k + H F with P, G, H from the matrix exponential of the model over Ts
(physical.transition), for any Ts, whether it is short or long beside L/R. The velocity is not measured;
eliminating it exactly gives relations between measured samples alone, linear in their coefficients:

Electrical (the interval [t_k-1, t_k]):

    I_k = e0 I_k-1 + e1 u_k-1 + e2 (x_k - x_k-1) + e3 F,

    e0 = P_II - P_Iv P_xI / P_xv,  e1 = G_I - P_Iv G_x / P_xv,  e2 = P_Iv / P_xv,  e3 = H_I - P_Iv H_x / P_xv.

Mechanical (the intervals [t_k-1, t_k+1]), with a = P_vv:

    x_k+1 - x_k = a (x_k - x_k-1) + P_xI I_k + (P_xv P_vI - a P_xI) I_k-1 + G_x u_k + (P_xv G_v - a G_x) u_k-1
                  + (H_x + P_xv H_v - a H_x) F,

regressed in the symmetric form: the second difference x_k+1 - 2 x_k + x_k-1 on the central difference
x_k+1 - x_k-1 (coefficient -(1 - a)/(1 + a); the other coefficients times 2/(1 + a)). White position noise
enters the second difference symmetrically and the central difference antisymmetrically about t_k: their
products telescope, so quantisation neither biases the damping nor swamps it at high sample rates.

The rows are in SI magnitudes (differences of position over Ts, a second difference over Ts^2: a velocity and an
acceleration), as the regressions' prior and sums of squares need (greybox.py); physical.coefficients says so too.

The coefficients are nonlinear in R, L, Km, m, B; physical.py fits the parameters to them (minimum distance).
With a velocity signal instead of the position (a tachometer, JointState velocity), P, G and H apply directly:
I_k and v_k each on [I_k-1, v_k-1, u_k-1, 1].

Instruments. In closed loop the controller turns the measured current and position into the voltage, so u
carries the noise that the rows' errors hold, and the current's noise sits in the mechanical regressors: least
squares is biased. Each coil regression is therefore solved by instrumental variables: its instruments are
its regressors' signals two or three samples earlier (samples k-3, k-2; the errors hold the noise of samples
k-1 .. k+1), except the central difference (its noise is uncorrelated with the error's, above) and the constant.

A measured force (the force regression) is taken as linear between samples; the second difference of position is
the exact triangle-weighted mean acceleration over [t_k-1, t_k+1], hence the triangle-weighted force, and
v_tri = the central difference with a third-difference correction (least squares; the force's noise is not fed
back into the position).

Rows are made for samples k = LEAD .. N-1-(HISTORY-LEAD); each uses samples k-3 .. k+2 (with the instruments and
the effects' columns, online_effects.py), so a stream carries the last HISTORY samples from one frame to the next.
"""
import functools

import numpy as np

HISTORY = 5  # samples a stream keeps from one frame for the next (rows need k-3 .. k+2)
LEAD = 3     # samples a row needs before its own (row j is sample k = j + LEAD)

# Regressions and the signals each needs. The coil regressions come in pairs: from position or from velocity.
SIGNALS = {
    'electrical': ('voltage', 'current', 'position'),
    'mechanical': ('voltage', 'current', 'position'),
    'electrical_velocity': ('voltage', 'current', 'velocity'),
    'mechanical_velocity': ('voltage', 'current', 'velocity'),
    'force': ('force', 'position'),
}
COLUMNS = {
    'electrical': ('current', 'voltage', 'displacement', 'one'),
    'mechanical': ('central_difference', 'current', 'current_before', 'voltage', 'voltage_before', 'one'),
    'electrical_velocity': ('current', 'velocity', 'voltage', 'one'),
    'mechanical_velocity': ('current', 'velocity', 'voltage', 'one'),
    'force': ('force', 'velocity', 'one'),
}
MODELS = ('electrical', 'mechanical', 'full')
INSTRUMENTED = ('electrical', 'mechanical', 'electrical_velocity', 'mechanical_velocity')
# The combinations of the mechanical regression's columns that its first-order form keeps ([central difference,
# mean current, one]): what the data must excite (the other directions are fixed by the physics through the
# minimum-distance fit; at high sample rates the free coefficients are nearly collinear, the currents of
# neighbouring samples nearly equal), and the form physical.initial_guess starts from.
FIRST_ORDER = {'mechanical': (np.array([[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.5, 0.5, 0.0, 0.0, 0.0],
                                        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]), ('central_difference', 'current', 'one'))}
COIL = {'position': ('electrical', 'mechanical'), 'velocity': ('electrical_velocity', 'mechanical_velocity')}


def regressions_for(model, available):
    """The regressions `model` needs given the available signal names, or a ValueError naming what is missing.

    mechanical: force and position if there is a force signal. Otherwise every model needs the coil signals
    (voltage, current, and position or velocity) and uses both coil regressions: their coefficients all depend on
    all five coil parameters.
    """
    if model not in MODELS:
        raise ValueError(f'unknown model {model!r}; choose one of {", ".join(MODELS)}')
    available = set(available)
    if model == 'mechanical' and available >= set(SIGNALS['force']):
        return ('force',)
    motion = 'position' if 'position' in available or 'velocity' not in available else 'velocity'
    missing = [s for s in ('voltage', 'current', motion) if s not in available]
    if missing:
        need = 'voltage, current, position (or velocity)' + (' (or force, position)' if model == 'mechanical' else '')
        raise ValueError(f'model {model} needs {need}; missing {", ".join(missing)}')
    return COIL[motion]


def default_model(available):
    """'full' for coil signals, 'mechanical' for force data, None if neither is complete."""
    available = set(available)
    if available >= {'voltage', 'current'} and available & {'position', 'velocity'}:
        return 'full'
    if available >= set(SIGNALS['force']):
        return 'mechanical'
    return None


def _lags(values, first=-LEAD, last=HISTORY - LEAD):
    """{offset d: the signal at samples k + d} for the rows' samples k and offsets first .. last."""
    values = np.asarray(values, dtype=float)
    n = len(values) - HISTORY
    return {d: values[LEAD + d:LEAD + d + n] for d in range(first, last + 1)}


def rows(kind, signals, sample_period):
    """(Phi, Y) of regression `kind` from a dict of equally long 1-D arrays; row j is sample k = j + LEAD."""
    first = signals[SIGNALS[kind][-1]]
    if len(first) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind]))), np.empty(0)
    if kind == 'force':
        return triangle_rows(_lags(signals['position']), _lags(signals['force']), sample_period)
    i, u = _lags(signals['current']), _lags(signals['voltage'])
    ones = np.ones(len(i[0]))
    if kind in ('electrical_velocity', 'mechanical_velocity'):
        v = _lags(signals['velocity'])
        return np.column_stack((i[-1], v[-1], u[-1], ones)), (i[0] if kind == 'electrical_velocity' else v[0]).copy()
    x, ts = _lags(signals['position']), float(sample_period)
    if kind == 'electrical':
        return np.column_stack((i[-1], u[-1], (x[0] - x[-1]) / ts, ones)), i[0].copy()
    return (np.column_stack(((x[1] - x[-1]) / (2.0 * ts), i[0], i[-1], u[0], u[-1], ones)),
            (x[1] - 2.0 * x[0] + x[-1]) / ts ** 2)


def triangle_rows(x, f, sample_period):
    """(Phi, Y) of the force regression from {offset: samples} of position and force (offsets -2 .. 2)."""
    ts = float(sample_period)
    f_lin = (f[-1] + 4.0 * f[0] + f[1]) / 6.0
    v_tri = (x[1] - x[-1]) / (2.0 * ts) - (x[2] - 2.0 * x[1] + 2.0 * x[-1] - x[-2]) / (24.0 * ts)
    y = (x[1] - 2.0 * x[0] + x[-1]) / ts ** 2
    return np.column_stack((f_lin, -v_tri, -np.ones_like(y))), y


def instruments(kind, signals, sample_period):
    """The instruments of regression `kind`, one row per row of rows() (N - HISTORY x n), or None for a
    regression solved by least squares (its regressors are their own instruments). See the module doc."""
    if kind not in INSTRUMENTED:
        return None
    first = signals[SIGNALS[kind][-1]]
    if len(first) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind])))
    i, u = _lags(signals['current']), _lags(signals['voltage'])
    ones = np.ones(len(i[0]))
    if kind in ('electrical_velocity', 'mechanical_velocity'):
        v = _lags(signals['velocity'])
        return np.column_stack((i[-2], v[-2], u[-2], ones))
    x, ts = _lags(signals['position']), float(sample_period)
    if kind == 'electrical':
        return np.column_stack((i[-2], u[-2], (x[-2] - x[-3]) / ts, ones))
    return np.column_stack(((x[1] - x[-1]) / (2.0 * ts), i[-2], i[-3], u[-2], u[-3], ones))


@functools.lru_cache(maxsize=64)
def noise_stencils(kind, sample_period, make_rows=rows, history=HISTORY):
    """How white noise on each measured signal enters row k: {signal: (dY, dPhi)}, index j = 0..history for
    the noise of the j-th of the history + 1 samples a row spans, read off the rows themselves (an impulse
    through `make_rows`, the rows' construction; a row spans samples k - lead .. k - lead + history).

    The voltage is the applied one and taken as exact; current, position, velocity and force are measured.
    """
    span = 2 * history + 1  # the history + 1 rows of a span this long all see the impulse at sample `history`
    names = set(SIGNALS[kind])  # every kind of make_rows reads (a subset of) these
    zero = {name: np.zeros(span) for name in names}
    base_phi, base_y = make_rows(kind, zero, sample_period)
    stencils = {}
    for name in sorted(names - {'voltage'}):
        impulse = dict(zero, **{name: np.eye(1, span, history)[0]})
        phi, y = make_rows(kind, impulse, sample_period)
        stencils[name] = ((y - base_y)[::-1], (phi - base_phi)[::-1])  # the last row sees the impulse first
    return stencils


class RowStream:
    """Regression rows of `kinds` from consecutive frames of samples: each frame gets the last HISTORY samples
    of the previous one in front, so the frames together give exactly the rows of the whole record."""

    def __init__(self, kinds, sample_period):
        self.kinds = tuple(kinds)
        self.sample_period = float(sample_period)
        self.signals = sorted({s for kind in self.kinds for s in SIGNALS[kind]})
        self.reset()

    def reset(self):
        self.restart()
        self.samples = 0

    def restart(self):
        """The next frame does not follow on from the last one (samples were lost in between): no row spans
        the gap. The count of samples stays."""
        self._tail = {name: np.empty(0) for name in self.signals}

    def rows(self, frame):
        """{kind: (Phi, Y, instruments or None)} of the rows the frame {signal: 1-D array of equal lengths}
        completes."""
        new = {name: np.asarray(frame[name], dtype=float).reshape(-1) for name in self.signals}
        lengths = {len(values) for values in new.values()}
        if len(lengths) != 1:
            raise ValueError(f'frame signals have different lengths {sorted(lengths)}')
        joined = {name: np.concatenate((self._tail[name], values)) for name, values in new.items()}
        self._tail = {name: values[-HISTORY:].copy() for name, values in joined.items()}
        self.samples += lengths.pop()
        return {kind: (*rows(kind, joined, self.sample_period), instruments(kind, joined, self.sample_period))
                for kind in self.kinds}
