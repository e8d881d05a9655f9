"""Estimates that physics forbids or that point to a slip in the data's units or signs, as warnings that name
the signal, the likely cause and the flag that fixes it.

Signs. The model u = R I + L dI/dt + Km v, m dv/dt = Km I - B v - Fl fixes R, L, m > 0 and Km > 0 (a positive
current pushes towards +x). A signal that runs the other way round gives a pattern of signs:
  current negated    R, L < 0, Km > 0, m, B < 0   (u = -R (-I) ..., the force Km I changes sign)
  position negated   Km < 0 alone                 (the back-EMF and the force both change sign; m, B stay)
  voltage negated    R, L, Km, m, B < 0           (the same as current and position negated together)
so only the one signal whose pattern matches is advised; signs that match none point to poorly determined
parameters instead. A pattern is taken for a flipped signal only where each of its negative estimates lies beyond
SIGN_SIGMAS of zero and, with forgetting, the memory 1/(1 - lambda) holds at least MIN_SIGN_MEMORY samples:
otherwise the signs are the estimate's noise (a memory too short for the data), and that is said instead.

Outliers. One sample far off its neighbours (a logging glitch: 1e6 V among volts) distorts every estimate (R
many times too large) and then looks like a voltage that is not the coil's. Each signal is measured against its
running median (OUTLIER_WINDOW samples, which follows steps and runs of more than half its width): a sample is an
isolated outlier when it lies more than OUTLIER_MADS robust deviations (1.4826 MAD of the differences from that
median) from it and outside the signal's central span (its OUTLIER_PERCENTILE percentiles) widened by that span
on each side. Outliers are named first (signal, sample, time, value), ahead of the unit and sign hints.

Units. A unit slip rescales the parameters consistently (a current in mA divides R and L by 1000 and
multiplies m, B and Fl by 1000), so the equations cannot show it; the magnitudes do: a coil's current is
milliamps to tens of amps, its supply volts to hundreds, the power it draws at most kilowatts, its stroke
millimetres to centimetres, its sample period well under 10 ms. And the current can never exceed what the
voltage drives through the coil's resistance (R I_peak <= U_peak but for back-EMF): against a model of
known R (emla compare) a current too large points to a slip; with R identified from the data themselves (a
slip keeps the ratio) to a voltage that is not the coil's.

Data compared with a model (emla compare): the model's balances on the measured signals, fitted as
u = a (R I + L dI/dt) + b Km v and Km I = c (m dv/dt + B v) + const, give a = b = c = 1 on consistent data.
A signal read k times its value (k = 1000: mA, mV or mm; k = -1: flipped) gives
  current    a = 1/k, b = 1, c = k
  voltage    a = b = k, c = 1
  position   a = 1, b = c = 1/k
so the force constant the force balance implies agreeing with the voltage balance's (c = b/a) tells a single
misread signal from a model that does not fit (or a time slip), and the pattern names it and its factor.
"""
from dataclasses import dataclass

import numpy as np

MAX_STROKE = 0.5            # m: beyond this the position is probably not in metres
MAX_SAMPLE_PERIOD = 0.01    # s: beyond this the time is probably not in seconds (or the coil is not resolved)
MAX_CURRENT = 1e3           # A: tens of amps are plausible, thousands an mA slip
MAX_VOLTAGE = 1e3           # V
MAX_POWER = 1e4             # W: peak voltage times peak current of a coil of these actuators
SPLIT_RESISTANCE = 1.0      # ohm: U/I of an over-powered record below this means a current slip, above a voltage one
MAX_RESISTIVE_RATIO = 5.0   # R I_peak / U_peak: the coil's resistance alone needs more voltage than was applied
MIN_TIME_CONSTANT = 0.1     # L/R in sample periods below which the coil's current is not resolved at all
MAX_TIME_CONSTANT = 0.1     # s: a coil's L/R is microseconds to tens of milliseconds
MIN_MASS = 1e-5             # kg, and N/A: both below these beside an ordinary R, the position is not in
MIN_FORCE_CONSTANT = 0.1    # metres (a position c times too large divides m by c^2 and Km by c, leaves R)
MIN_RESISTANCE = 1e-3       # ohm: (a voltage too small divides R, Km and m alike)
MAX_MASS = 1e4              # kg: above this beside an L/R above MAX_TIME_CONSTANT, the time is not in seconds
PEAK_PERCENTILE = 99.9      # of |signal|, taken as its peak: one glitch does not count
BALANCE_TOLERANCE = 1.5     # a model's balances on data agree with one misread signal to within this factor
BALANCE_FACTOR = 2.0        # and name it when it is misread by more than this factor (or flipped)
SIGN_SIGMAS = 3.0           # a negative estimate within this many sigma of zero is noise, not a flipped signal
MIN_SIGN_MEMORY = 10.0      # samples: a shorter memory 1/(1 - lambda) makes an estimate whose signs say nothing
OUTLIER_WINDOW = 7          # samples of the running median an outlier is measured from (runs up to 3 stand out)
OUTLIER_MADS = 50.0         # robust deviations from the running median from which a sample may be an outlier
OUTLIER_PERCENTILE = 1.0    # the signal's central span: its OUTLIER_PERCENTILE and 100 - it percentiles
MIN_OUTLIER_SAMPLES = 16    # shorter signals are not checked
SHOWN_OUTLIERS = 3          # outliers named in a warning (the count says the rest)

SI_UNITS = {'t': 's', 'voltage': 'V', 'current': 'A', 'position': 'm', 'velocity': 'm/s', 'force': 'N'}
PREFIXES = {1e-3: 'm', 1e-6: 'u'}
# (sign of R and L, of Km, of m) each negated signal gives; see the module doc
SIGN_PATTERNS = {'current': (-1, 1, -1), 'position': (1, -1, 1), 'voltage': (-1, -1, -1)}
# (a, b, c) of a model's balances on data (module doc) with one signal read k times its value: (the estimates of
# k from them, (a, b, c) as a function of k)
BALANCE_HYPOTHESES = {
    'current': (lambda a, b, c: (1 / a, c), lambda k: (1 / k, 1.0, k)),
    'voltage': (lambda a, b, c: (a, b), lambda k: (k, k, 1.0)),
    'position': (lambda a, b, c: (1 / b, 1 / c), lambda k: (1.0, 1 / k, 1 / k)),
}
SIGN_CAUSES = {'current': 'against the voltage and the force', 'position': 'against the force of the current',
               'voltage': 'against the current and the back-EMF', 'force': 'against the position'}
UNITS = {'resistance': 'ohm', 'inductance': 'H', 'emf_constant': 'N/A', 'mass': 'kg', 'damping': 'N s/m',
         'load_force': 'N'}


@dataclass(frozen=True)
class Magnitudes:
    """Peak |voltage| (V), peak |current| (A), the stroke (m) and the sample period (s) of a record; None for
    a signal it lacks."""

    sample_period: float
    voltage: float | None = None
    current: float | None = None
    stroke: float | None = None

    @classmethod
    def of(cls, recording):
        """The magnitudes of a Recording (or anything with `signals` and `sample_period`)."""
        voltage, current, position = (_finite(recording.signals.get(n)) for n in ('voltage', 'current', 'position'))
        peak = lambda values: None if values is None else float(np.percentile(np.abs(values), PEAK_PERCENTILE))  # noqa: E731
        return cls(recording.sample_period, peak(voltage), peak(current),
                   None if position is None else float(np.ptp(position)))

    @property
    def power(self):
        """Peak voltage times peak current (W), or None."""
        return None if self.voltage is None or self.current is None else self.voltage * self.current

    @property
    def apparent_resistance(self):
        """Peak voltage over peak current (ohm), or None."""
        return None if self.power is None or self.current == 0 else self.voltage / self.current


def _finite(values):
    """The finite values of a signal as a float array, or None for no signal or no finite value."""
    values = None if values is None else np.asarray(values, dtype=float)
    values = None if values is None else values[np.isfinite(values)]
    return values if values is not None and values.size else None


def plausibility_warnings(parameters, std, recording, identified=True, forgetting=1.0, samples=None):
    """One-line warnings about a model of an actuator and the record it was identified from or compared with.

    Parameters
    ----------
    parameters : dict
        {name: value} in SI units (resistance, inductance, emf_constant, mass, damping, load_force; any
        subset, or none: then only the record's magnitudes are checked).
    std : dict
        {name: one-sigma} of the parameters (to tell a negative damping from zero).
    recording : Recording
        The record (its signals, sample period and, if foreign, `inputs`: how each signal was read, so the
        advised flag keeps its unit and sign).
    identified : bool, optional
        Whether the parameters were identified from this record (then a slip's warning names the parameters
        it distorted) or come from elsewhere, a model file (then they are only measured against the record).
    forgetting : float, optional
        The forgetting factor the parameters were identified with (1: none); a memory 1/(1 - forgetting) too
        short for the data is named as the cause of negative estimates rather than a flipped signal.
    samples : int, optional
        The record's samples (for the message; default: those of `recording`).

    Returns
    -------
    list of str
        Each names the signal or parameter, the likely cause and the flag that fixes it; empty when all is
        plausible. Isolated outliers in the signals come first.
    """
    magnitudes = Magnitudes.of(recording)
    inputs = getattr(recording, 'inputs', None) or {}
    shown = parameters if identified else {}
    found = outlier_warnings(recording)
    if identified:
        memory = Memory(forgetting, samples if samples is not None else _samples(recording.signals))
        found += [_signs(parameters, std, recording.signals, inputs, memory), _coil_voltage(parameters, magnitudes)]
        named = ()
    else:
        against = _against_model(parameters, recording.signals, recording.sample_period, inputs)
        found, named = (found + [against[1]], (against[0],)) if against else (found, ())
    found += [check(parameters, magnitudes, inputs, shown) for signal, check in UNIT_CHECKS.items()
              if signal not in named]
    return [message for message in found if message]


def outlier_warnings(recording):
    """One warning for each signal of `recording` with isolated outliers (module doc), naming the signal, how
    many, and the first SHOWN_OUTLIERS of them by sample (1-based), time and value; [] for none."""
    warnings = []
    start, ts = getattr(recording, 'start_time', 0.0) or 0.0, recording.sample_period
    for name, values in recording.signals.items():
        found = isolated_outliers(values)
        if not len(found):
            continue
        unit = f' {SI_UNITS[name]}' if name in SI_UNITS else ''
        values = np.asarray(values, dtype=float)
        shown = '; '.join(f'{values[i]:.4g}{unit} at sample {i + 1} (t = {start + i * ts:.6g} s)'
                          for i in found[:SHOWN_OUTLIERS])
        more = f' and {len(found) - SHOWN_OUTLIERS} more' if len(found) > SHOWN_OUTLIERS else ''
        low, high = np.percentile(values, (OUTLIER_PERCENTILE, 100 - OUTLIER_PERCENTILE))
        count = 'an isolated outlier' if len(found) == 1 else f'{len(found)} isolated outliers'
        warnings.append(f'the {name} has {count}, far off its neighbours and its range ({low:.3g} to {high:.3g}'
                        f'{unit}): {shown}{more}; a logging glitch? it distorts every estimate: remove or repair '
                        f'{"it" if len(found) == 1 else "them"}')
    return warnings


def isolated_outliers(values):
    """Indices of the isolated outliers of a signal (module doc), in order; empty for none or a signal too
    short or too flat to tell."""
    from scipy.ndimage import median_filter
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size < MIN_OUTLIER_SAMPLES or not np.all(np.isfinite(values)):
        return np.empty(0, dtype=int)
    low, high = np.percentile(values, (OUTLIER_PERCENTILE, 100 - OUTLIER_PERCENTILE))
    span = high - low
    if not span > 0:
        return np.empty(0, dtype=int)
    deviation = np.abs(values - median_filter(values, size=OUTLIER_WINDOW, mode='nearest'))
    spread = 1.4826 * np.median(deviation)
    beyond = (deviation > OUTLIER_MADS * spread) & ((values < low - span) | (values > high + span))
    return np.flatnonzero(beyond)


def _samples(signals):
    """The samples of the longest signal, or None."""
    return max((len(v) for v in signals.values()), default=None) or None


@dataclass(frozen=True)
class Memory:
    """The forgetting factor an estimate was made with and the samples of its record."""

    forgetting: float = 1.0
    samples: int | None = None

    @property
    def samples_remembered(self):
        """1/(1 - forgetting), or inf without forgetting."""
        return np.inf if self.forgetting >= 1.0 else 1.0 / (1.0 - self.forgetting)

    def words(self):
        """'the forgetting factor L remembers only 1/(1 - L) = N samples (of the record's M)'."""
        of = f' (of the record\'s {self.samples})' if self.samples else ''
        return (f'the forgetting factor {self.forgetting:g} remembers only 1/(1 - {self.forgetting:g}) = '
                f'{self.samples_remembered:.3g} samples{of}')


def unit_flag(inputs, name, factor):
    """The `--units NAME=UNIT` that reads signal `name` `factor` times its present scale (a negative factor
    flips it), from how it was read (`inputs`, Recording.inputs; SI when absent)."""
    scale = inputs.get(name, {}).get('scale', 1.0) * factor
    size, sign = abs(scale), '-' if scale < 0 else ''
    prefix = next((p for f, p in {1.0: '', **PREFIXES}.items() if np.isclose(size, f, rtol=1e-9)), None)
    return f'--units {name}={sign}{prefix}{SI_UNITS[name]}' if prefix is not None else f'--units {name}={scale:g}'


def _slip(signal, what, inputs, factor, shown, names):
    """'WHAT (hence the parameters `names` of `shown`): is the SIGNAL in UNIT? give its unit with --units
    SIGNAL=UNIT'; factor None: no usual unit fits, the SIGNAL is not in SI."""
    listed = ', '.join(f'{n} {shown[n]:.3g} {UNITS[n]}' for n in names if np.isfinite(shown.get(n, np.nan)))
    consequence = f' (hence {listed})' if listed else ''
    name = 'time' if signal == 't' else signal
    if factor is None:
        return f'{what}{consequence}: the {name} is not in {SI_UNITS[signal]}; give its unit with --units {signal}=UNIT'
    flag = unit_flag(inputs, signal, factor)
    return f'{what}{consequence}: is the {name} in {flag.split("=")[-1]}? give its unit with {flag}'


def _usual_factor(size, limit):
    """The usual unit's factor (milli, then micro) that brings `size` within `limit`, or None."""
    return next((f for f in PREFIXES if size * f <= limit), None)


def _signs(parameters, std, signals, inputs, memory=None):
    """The sign slip whose pattern the parameters' signs match, advised alone; or the negative ones named; or,
    where they are the estimate's noise (within SIGN_SIGMAS of zero, or from a memory below MIN_SIGN_MEMORY
    samples), that."""
    memory = memory or Memory()
    value = parameters.get
    sigma = std.get('damping', 0.0)
    negative = [n for n in ('resistance', 'inductance', 'emf_constant', 'mass') if value(n, 1.0) < 0]
    if value('damping', 0.0) < -SIGN_SIGMAS * (sigma if np.isfinite(sigma) else 0.0):
        negative.append('damping')
    if not negative:
        return None
    listed = ', '.join(f'{n} {parameters[n]:.4g} {UNITS[n]}' for n in negative)
    if negative == ['damping'] and memory.samples_remembered >= MIN_SIGN_MEMORY:   # no flip makes B < 0 alone
        return (f'{listed} is negative beyond its uncertainty: an effect the model lacks (a sensor delay, a '
                f'friction; emla discrepancy looks for it) or too little motion to resolve it')
    noise = _sign_noise(parameters, std, negative, memory)
    if noise:
        return noise
    if 'force' in signals:   # m dv/dt = F - B v - Fl: a negated force and a negated position look the same
        return (f'{listed} must be positive: the force runs {SIGN_CAUSES["force"]}; flip one of them with '
                f'{unit_flag(inputs, "force", -1)} or {unit_flag(inputs, "position", -1)}')
    observed = tuple(None if any(n not in parameters for n in names) else
                     (-1 if any(value(n) < 0 for n in names) else 1)
                     for names in (('resistance', 'inductance'), ('emf_constant',), ('mass',)))
    matches = [signal for signal, pattern in SIGN_PATTERNS.items()
               if all(o is None or o == p for o, p in zip(observed, pattern, strict=True))]
    if len(matches) == 1:
        (signal,) = matches
        return (f'{listed} {"is" if len(negative) == 1 else "are"} negative: the {signal} runs the other way '
                f'round ({SIGN_CAUSES[signal]}; its sensor mounted the other way?); flip it with '
                f'{unit_flag(inputs, signal, -1)}')
    if matches:   # the mechanical model alone: m < 0 comes from a negated current or a negated voltage
        return (f'{listed} must be positive: the {" or the ".join(matches)} runs the other way round (--model '
                f'full tells which); flip it with ' + ' or '.join(unit_flag(inputs, s, -1) for s in matches))
    return (f'{listed} must be positive, and no single flipped signal gives these signs: the record probably '
            f'does not determine them (does it excite the actuator?)')


def _sign_noise(parameters, std, negative, memory):
    """The warning for `negative` estimates that are the estimate's noise rather than a flipped signal: some
    within SIGN_SIGMAS of zero (a missing or non-finite sigma: undetermined), or all from a memory shorter than
    MIN_SIGN_MEMORY samples; None when the signs are significant."""
    def within(name):
        sigma = std.get(name, 0.0)
        return not abs(parameters[name]) > SIGN_SIGMAS * sigma if np.isfinite(sigma) else True
    weak = [n for n in negative if within(n)]
    short = memory.samples_remembered < MIN_SIGN_MEMORY
    if not weak and not short:
        return None
    listed = ', '.join(f'{n} {parameters[n]:.4g} +- {std[n]:.2g} {UNITS[n]}' if n in std else
                       f'{n} {parameters[n]:.4g} {UNITS[n]}' for n in negative)
    verb = 'is' if len(negative) == 1 else 'are'
    near = f' ({", ".join(weak)} within {SIGN_SIGMAS:g} sigma of zero)' if weak else ''
    if memory.forgetting < 1.0:
        return (f'{listed} {verb} negative: {memory.words()}, a memory too short for these data: the estimate is '
                f'mostly noise{near}, not a flipped signal; take a forgetting factor closer to 1 (--forgetting 1 '
                f'uses the whole record) or a longer --memory-time')
    return (f'{listed} {verb} negative but within {SIGN_SIGMAS:g} sigma of zero ({", ".join(weak)}): the '
            f'estimate\'s noise, not a flipped signal; the record does not determine them (does it excite the '
            f'actuator?)')


def _balances(parameters, signals, sample_period):
    """(a, b, c) of the model's balances on the measured signals, fitted: u = a (R I + L dI/dt) + b Km v and
    Km I = c (m dv/dt + B v) + a constant; None without a coil model or coil signals."""
    names = ('voltage', 'current', 'position')
    if any(n not in parameters for n in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')) or \
            any(n not in signals for n in names) or len(signals['position']) < 3:
        return None
    voltage, current, position = (np.asarray(signals[n], dtype=float) for n in names)
    velocity = np.gradient(position, sample_period)
    coil = parameters['resistance'] * current + parameters['inductance'] * np.gradient(current, sample_period)
    force = parameters['mass'] * np.gradient(velocity, sample_period) + parameters['damping'] * velocity
    with np.errstate(all='ignore'):
        (a, b), *_ = np.linalg.lstsq(np.column_stack((coil, parameters['emf_constant'] * velocity)), voltage,
                                     rcond=None)
        (c, _), *_ = np.linalg.lstsq(np.column_stack((force, np.ones_like(force))),
                                     parameters['emf_constant'] * current, rcond=None)
    return (a, b, c) if np.all(np.isfinite((a, b, c))) else None


def _misread_signal(a, b, c):
    """(signal, k): the one signal whose reading k times its true value explains the balances (a, b, c) to
    within BALANCE_TOLERANCE (module doc), or None."""
    best = None
    for signal, (estimates, predicted) in BALANCE_HYPOTHESES.items():
        guesses = np.array(estimates(a, b, c))
        if not (np.all(guesses > 0) or np.all(guesses < 0)):
            continue
        k = np.sign(guesses[0]) * np.exp(np.mean(np.log(np.abs(guesses))))
        expected = np.array(predicted(k))
        if np.any(np.sign(expected) != np.sign((a, b, c))):
            continue
        error = np.max(np.abs(np.log(np.abs((a, b, c)) / np.abs(expected))))
        if error <= np.log(BALANCE_TOLERANCE) and (best is None or error < best[0]):
            best = (error, signal, k)
    return None if best is None else best[1:]


def _against_model(parameters, signals, sample_period, inputs):
    """(signal, warning) for a signal the model's balances say is misread by a factor beyond BALANCE_FACTOR or
    flipped, or None."""
    balances = _balances(parameters, signals, sample_period)
    with np.errstate(all='ignore'):   # a balance of 0 has no single-signal explanation
        found = None if balances is None else _misread_signal(*balances)
    if found is None:
        return None
    signal, k = found
    if 1 / BALANCE_FACTOR <= k <= BALANCE_FACTOR:
        return None
    decade = 10.0 ** np.round(np.log10(abs(k)))
    k = np.sign(k) * decade if abs(abs(k) / decade - 1) < 0.1 else k   # a unit's factor, not a fitted one
    how = (f'runs the other way round, {SIGN_CAUSES[signal]}' if k == -1 else
           f'reads {k:.4g} times what the model expects')
    a, b, c = balances
    return signal, (f'against the model, the {signal} {how}: its voltage balance on the data is u = {a:.3g} (R I + '
                    f'L dI/dt) {"+" if b >= 0 else "-"} {abs(b):.3g} Km v, its force balance Km I = {c:.3g} (m dv/dt '
                    f'+ B v); give the {signal}\'s unit with {unit_flag(inputs, signal, 1 / k)}')


def _resistive_voltage(parameters, magnitudes):
    """R I_peak, when it exceeds MAX_RESISTIVE_RATIO times the peak voltage (the coil's resistance alone would
    need more voltage than was applied), else None."""
    resistance, current, voltage = parameters.get('resistance', 0.0), magnitudes.current, magnitudes.voltage
    needed = resistance * current if resistance > 0 and current and voltage else None
    return needed if needed is not None and needed > MAX_RESISTIVE_RATIO * voltage else None


def _coil_voltage(parameters, magnitudes):
    """Identified parameters whose R cannot drive the current from the voltage: the voltage is not the coil's.
    (A unit slip keeps R I_peak / U_peak: R is fitted to the data.)"""
    needed = _resistive_voltage(parameters, magnitudes)
    return None if needed is None else (
        f'R = {parameters["resistance"]:.3g} ohm needs {needed:.3g} V to drive the {magnitudes.current:.3g} A the '
        f'current reaches, the voltage reaches {magnitudes.voltage:.3g} V: is the voltage the one across the coil '
        f'(not a supply or a set-point)? is the current the coil\'s?')


def _current(parameters, magnitudes, inputs, shown):
    """A current in mA read as A: thousands of amps, more than a model's R lets the voltage drive, or the power
    of a small power station at a low apparent resistance."""
    current, voltage, power = magnitudes.current, magnitudes.voltage, magnitudes.power
    if current is None:
        return None
    needed = None if shown else _resistive_voltage(parameters, magnitudes)   # R from a model, not these data
    overpowered = power is not None and power > MAX_POWER and magnitudes.apparent_resistance < SPLIT_RESISTANCE
    if current > MAX_CURRENT:
        why = ''
    elif needed is not None:
        why = (f'; R = {parameters["resistance"]:.3g} ohm needs {needed:.3g} V to drive it, the voltage reaches '
               f'{voltage:.3g} V')
    elif overpowered:
        why = f' at {voltage:.3g} V, a coil drawing {power / 1e3:.3g} kW'
    else:
        return None
    return _slip('current', f'the current reaches {current:.3g} A{why}', inputs, 1e-3, shown,
                 ('resistance', 'inductance', 'mass'))


def _voltage(parameters, magnitudes, inputs, shown):
    """A voltage in mV read as V: kilovolts, or the power of a small power station at a high apparent
    resistance."""
    voltage, power = magnitudes.voltage, magnitudes.power
    if voltage is None:
        return None
    if voltage > MAX_VOLTAGE:
        why = ''
    elif power is not None and power > MAX_POWER and magnitudes.apparent_resistance >= SPLIT_RESISTANCE:
        why = f' with {magnitudes.current:.3g} A, a coil drawing {power / 1e3:.3g} kW'
    else:
        return None
    return _slip('voltage', f'the voltage reaches {voltage:.3g} V{why}', inputs, 1e-3, shown,
                 ('resistance', 'inductance', 'emf_constant'))


def _position(parameters, magnitudes, inputs, shown):
    """A position in mm or um read as m: a stroke of metres, or micrograms moved by newtons per amp."""
    stroke, mass = magnitudes.stroke, parameters.get('mass', 1.0)
    if stroke is not None and stroke > MAX_STROKE:
        factor, names = _usual_factor(stroke, MAX_STROKE), ('emf_constant', 'mass')
        what = f'the position spans {stroke:.3g} m, a stroke of metres'
    elif 0 < mass < MIN_MASS and abs(parameters.get('emf_constant', 0.0)) < MIN_FORCE_CONSTANT and \
            parameters.get('resistance', 1.0) > MIN_RESISTANCE:
        factor, names = 1e-3, ()
        what = f'the mass {mass:.3g} kg' + (f' and the force constant {parameters["emf_constant"]:.3g} N/A are'
                                            if 'emf_constant' in parameters else ' is') + ' implausibly small'
    else:
        return None
    return _slip('position', what, inputs, factor, shown, names)


def _time(parameters, magnitudes, inputs, shown):
    """A time in ms or us read as s: a slow sample period, one the coil's L/R is a small fraction of, or a mass
    of tonnes."""
    ts, mass = magnitudes.sample_period, parameters.get('mass', 0.0)
    resistance, inductance = parameters.get('resistance', 0.0), parameters.get('inductance', 0.0)
    tau = inductance / resistance if resistance > 0 and inductance > 0 else None
    if ts > MAX_SAMPLE_PERIOD or (tau is not None and tau < MIN_TIME_CONSTANT * ts):
        factor, names = _usual_factor(ts, min(MAX_SAMPLE_PERIOD, tau / MIN_TIME_CONSTANT if tau else np.inf)), ('mass',)
        what = f'the sample period is {ts:.3g} s, slow for a coil'
    elif mass > MAX_MASS and (tau is None or tau > MAX_TIME_CONSTANT):   # a time slip stretches L/R too
        factor, names = 1e-3, ()
        what = f'the mass {mass:.3g} kg is implausibly large'
    else:
        return None
    if tau is not None:   # identified: stretched with the time axis; from a model: the coil's own
        what += f', its L/R {tau:.3g} s' if shown else f' whose L/R is {tau:.3g} s'
    return _slip('t', what, inputs, factor, shown, names) + ' (or --sample-period in s)'


UNIT_CHECKS = {'current': _current, 'voltage': _voltage, 'position': _position, 't': _time}
