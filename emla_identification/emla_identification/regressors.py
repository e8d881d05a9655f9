"""Grey-box regressions of the EMLA consistent with the zero-order-hold (ZOH) voltage.

Sample k holds the current I_k and position x_k measured at t_k and the voltage u_k applied over
[t_k, t_k+1]. Velocity is not measured; every regression below is exact for the continuous model

    u = R I + L dI/dt + Km v,      m dv/dt = F - B v - Fl,  F = Km I (or a measured force),

up to terms of second order in the sample period (noise-free error well under 0.1 %, tests/test_greybox.py).
Each uses samples k-2 .. k+2 for its row k, so rows exist for k = 2 .. N-3 and a stream carries the last
HISTORY samples from one frame to the next.

Electrical. Over one interval the coil obeys dI/dt = (u_k - R I - Km v) / L, hence exactly

    I_k+1 = alpha I_k + beta u_k - gamma [v_mean + eta Ts a],   alpha = exp(-h), h = R Ts / L,
    beta = (1 - alpha) / R,  gamma = Km beta,

where v_mean = (x_k+1 - x_k) / Ts is the interval's mean velocity and eta(h) Ts a corrects for the
exponential weighting of the back-EMF towards the interval's end (a: acceleration at its middle, from
positions). The regression is on [alpha, beta, gamma, gamma eta]; the last coefficient depends on h and is
tied to the others when the physical parameters are formed (greybox.py). The current noise then sits on the
output; regressing u_k on a central-difference dI/dt instead gives R some 37 % low.

Mechanical. The second difference of position is the exact triangle-weighted mean acceleration over
[t_k-1, t_k+1], so no derivative of a noisy signal enters a regressor:

    (x_k+1 - 2 x_k + x_k-1) / Ts^2 = F_tri / m - (B/m) v_tri - Fl/m,

F_tri and v_tri being the same triangle-weighted means of the force (Km I_tri for the coil) and of the
velocity. v_tri = (mean of x over [t_k, t_k+1] - mean over [t_k-1, t_k]) / Ts is the central difference
with a third-difference correction. A measured force is taken as linear between samples:
F_tri = (F_k-1 + 4 F_k + F_k+1) / 6.
The coil current is not linear within an interval but exponential with rate R/L; pinned to the sampled
values that shape adds eta(h) (I_k+1 - I_k-1) / 2 (its symmetric part, h^2/720 of the second difference,
is below 0.01 % and left out). The regression is on [Km/m, eta Km/m, B/m, Fl/m], the second tied to the
first by h from the electrical equation. The back-EMF's rise within an interval bends the current by an
amount proportional to the acceleration, which acts like an extra mass Km^2 eta Ts / R (to first order); added
when m is formed. The noise of the second difference (symmetric in time) is uncorrelated with that of
v_tri (antisymmetric), so quantisation does not bias B.

Instruments. In closed loop the controller turns the measured current and position into the voltage, so u_k
carries the noise of I_k and x_k, which the electrical row's error also holds (-alpha n_k, and the position
noise through v_mean). Least squares is then biased: under the suite's inverse-system controller at 10 kHz,
which feeds the measured current back at every sample, L came out 0.4 % low (17 standard deviations). The
electrical regression is therefore solved by instrumental variables: its instruments are the same signals
one sample earlier, [I_k-1, u_k-1, -(x_k-1 - x_k-2)/Ts, I_k-2], correlated with the regressors but not with
the noise of samples k .. k+2 in the row's error (x_k-1 enters that error only through the eta-weighted
column, ~0.1 % of the effect), whatever the loop does with them. The mechanical regression stays least
squares: its output, the second difference of position, is not fed back into its regressors.
"""
import functools
import math

import numpy as np

HISTORY = 4  # samples a stream keeps from one frame for the next (rows need k-2 .. k+2)

# Regressions and the signals each needs. 'mechanical' is driven by the coil current (force Km I, Km from
# the electrical regression); 'force' by a measured actuator force.
SIGNALS = {
    'electrical': ('voltage', 'current', 'position'),
    'mechanical': ('current', 'position'),
    'force': ('force', 'position'),
}
# Unknowns of each regression before the h-dependent coefficient is tied (see the module doc).
COLUMNS = {
    'electrical': ('alpha', 'beta', 'gamma', 'gamma_eta'),
    'mechanical': ('km_over_m', 'eta_km_over_m', 'b_over_m', 'fl_over_m'),
    'force': ('one_over_m', 'b_over_m', 'fl_over_m'),
}
MODELS = ('electrical', 'mechanical', 'full')
INSTRUMENTED = ('electrical',)  # regressions solved by instrumental variables (instruments())


def regressions_for(model, available):
    """The regressions `model` needs given the available signal names, or a ValueError naming what is missing.

    mechanical: force and position if there is a force signal. Otherwise every model needs the coil signals
    (voltage, current, position) and uses both equations: full shares Km between them, mechanical takes Km
    from the electrical one, and electrical uses the mechanical one to tell current noise from position
    noise in its uncertainties (noise.noise_variances).
    """
    if model not in MODELS:
        raise ValueError(f'unknown model {model!r}; choose one of {", ".join(MODELS)}')
    available = set(available)
    if model == 'mechanical' and available >= set(SIGNALS['force']):
        return ('force',)
    missing = [s for s in SIGNALS['electrical'] if s not in available]
    if missing:
        need = 'voltage, current, position' + (' (or force, position)' if model == 'mechanical' else '')
        raise ValueError(f'model {model} needs {need}; missing {", ".join(missing)}')
    return ('electrical', 'mechanical')


def default_model(available):
    """'full' for coil signals, 'mechanical' for force data, None if neither is complete."""
    available = set(available)
    if available >= set(SIGNALS['electrical']):
        return 'full'
    if available >= set(SIGNALS['force']):
        return 'mechanical'
    return None


def rows(kind, signals, sample_period):
    """(Phi, Y) of regression `kind` from a dict of equally long 1-D arrays; row j is sample k = j + 2."""
    ts = float(sample_period)
    x = np.asarray(signals['position'], dtype=float)
    if len(x) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind]))), np.empty(0)
    # x at k-2 .. k+2 for k = 2 .. N-3
    xm2, xm1, x0, xp1, xp2 = (x[j:len(x) - HISTORY + j] for j in range(HISTORY + 1))
    if kind == 'electrical':
        u = np.asarray(signals['voltage'], dtype=float)[2:-2]
        i = np.asarray(signals['current'], dtype=float)
        v_mean = (xp1 - x0) / ts
        lag = (xp2 - xp1 - x0 + xm1) / (2.0 * ts)  # Ts a at t_k + Ts/2 (mean of two second differences)
        return np.column_stack((i[2:-2], u, -v_mean, -lag)), i[3:-1].copy()
    drive = np.asarray(signals['force' if kind == 'force' else 'current'], dtype=float)
    fm1, f0, fp1 = drive[1:-3], drive[2:-2], drive[3:-1]
    f_lin = (fm1 + 4.0 * f0 + fp1) / 6.0
    v_tri = (xp1 - xm1) / (2.0 * ts) - (xp2 - 2.0 * xp1 + 2.0 * xm1 - xm2) / (24.0 * ts)
    y = (xp1 - 2.0 * x0 + xm1) / ts ** 2
    ones = np.ones_like(y)
    if kind == 'force':
        return np.column_stack((f_lin, -v_tri, -ones)), y
    return np.column_stack((f_lin, 0.5 * (fp1 - fm1), -v_tri, -ones)), y


def instruments(kind, signals, sample_period):
    """The instruments of regression `kind`, one row per row of rows() (N-4 x n), or None for a regression
    solved by least squares (its regressors are their own instruments). See the module doc."""
    if kind not in INSTRUMENTED:
        return None
    i = np.asarray(signals['current'], dtype=float)
    u = np.asarray(signals['voltage'], dtype=float)
    x = np.asarray(signals['position'], dtype=float)
    if len(x) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind])))
    # samples k-1 (slice [1:-3]) and k-2 ([:-4]) for k = 2 .. N-3
    return np.column_stack((i[1:-3], u[1:-3], -(x[1:-3] - x[:-4]) / float(sample_period), i[:-4]))


def emf_lag(h):
    """eta(h) = coth(h/2)/2 - 1/h (= h/12 - h^3/720 + ...), h = R Ts / L; 0 where h is not positive or NaN.

    Both the back-EMF weighting of the electrical equation and the antisymmetric part of the exponential
    current shape in the mechanical one reduce to this function. Elementwise on arrays.
    """
    if isinstance(h, float):  # a scalar (the tie, at every online estimate): math is 10x faster than numpy here
        return 0.5 / math.tanh(0.5 * h) - 1.0 / h if h > 1e-2 else h / 12.0 - h ** 3 / 720.0 if h > 0.0 else 0.0
    h = np.asarray(h, dtype=float)
    closed = h > 1e-2  # below, the closed form loses digits to cancellation; NaN compares False
    half = 0.5 * np.where(closed, h, 1.0)
    return np.where(closed, 0.5 / np.tanh(half) - 0.5 / half, np.where(h > 0.0, h / 12.0 - h ** 3 / 720.0, 0.0))


def tie(kind, h, extra=0):
    """T (n_reduced x n) with coefficients = T' theta_reduced: ties the h-dependent coefficient of `kind`;
    `extra` further columns (online_effects.py) are kept as they are."""
    eta = float(emf_lag(h))
    if kind == 'electrical':   # [alpha, beta, gamma] -> [alpha, beta, gamma, gamma eta]
        T = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, eta]])
    elif kind == 'mechanical':   # [Km/m, B/m, Fl/m] -> [Km/m, eta Km/m, B/m, Fl/m]
        T = np.array([[1.0, eta, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    else:
        T = np.eye(len(COLUMNS[kind]))
    if not extra:
        return T
    return np.block([[T, np.zeros((len(T), extra))], [np.zeros((extra, T.shape[1])), np.eye(extra)]])


@functools.lru_cache(maxsize=32)
def noise_stencils(kind, sample_period):
    """How white noise on each measured signal enters row k: {signal: (dY, dPhi)}, index j = 0..HISTORY for
    the noise of sample k - 2 + j, read off rows() itself (an impulse through the row construction).

    The voltage is the applied one and taken as exact; current, position and force are measured.
    """
    span = 2 * HISTORY + 1  # rows k = 2 .. 6 all see the impulse at sample HISTORY
    zero = {name: np.zeros(span) for name in SIGNALS[kind]}
    base_phi, base_y = rows(kind, zero, sample_period)
    stencils = {}
    for name in SIGNALS[kind]:
        if name == 'voltage':
            continue
        impulse = dict(zero, **{name: np.eye(1, span, HISTORY)[0]})
        phi, y = rows(kind, impulse, sample_period)
        stencils[name] = ((y - base_y)[::-1], (phi - base_phi)[::-1])  # row k = 6 - j sees offset j - 2
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
