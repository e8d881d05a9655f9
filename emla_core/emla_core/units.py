"""Units of the signals the suite reads: the names a user gives (`--units current=mA`) or a column header
carries (`x_mm`, `x [mm]`, `x (mm)`), as factors to SI.

A unit is a name of the signal's quantity or a plain number (the factor to SI); a leading minus flips the
sign, as for a current sensor mounted the other way (`current=-A`).
"""
import math
import re

from emla_core.errors import InputError

# The signals the suite knows, with their SI unit and quantity.
SIGNAL_UNITS = {'t': 's', 'voltage': 'V', 'current': 'A', 'position': 'm', 'velocity': 'm/s', 'force': 'N'}
SIGNAL_NAMES = tuple(name for name in SIGNAL_UNITS if name != 't')  # the signals a recording may hold
QUANTITIES = {'t': 'time', 'voltage': 'voltage', 'current': 'current', 'position': 'position',
              'velocity': 'velocity', 'force': 'force'}
# Unit names per quantity -> factor to SI. Positions and velocities may be angles (a DC motor's shaft).
FACTORS = {
    'time': {'s': 1.0, 'ms': 1e-3, 'us': 1e-6, 'ns': 1e-9, 'min': 60.0},
    'voltage': {'V': 1.0, 'mV': 1e-3, 'kV': 1e3},
    'current': {'A': 1.0, 'mA': 1e-3, 'uA': 1e-6},
    'position': {'m': 1.0, 'cm': 1e-2, 'mm': 1e-3, 'um': 1e-6, 'rad': 1.0, 'deg': math.pi / 180},
    'velocity': {'m/s': 1.0, 'mm/s': 1e-3, 'um/s': 1e-6, 'rad/s': 1.0, 'deg/s': math.pi / 180,
                 'rpm': 2 * math.pi / 60},
    'force': {'N': 1.0, 'mN': 1e-3, 'kN': 1e3},
}
_ALL_NAMES = {name for units in FACTORS.values() for name in units}


def parse_unit(signal, text):
    """(factor to SI, label) of `text` for `signal`: a unit name of its quantity or a number, maybe negated."""
    text = text.strip()
    sign, body = (-1.0, text[1:].strip()) if text.startswith('-') else (1.0, text)
    known = FACTORS.get(QUANTITIES.get(signal), {})
    if body in known:
        return sign * known[body], text
    folded = [name for name in known if name.lower() == body.lower()]
    if len(folded) == 1:
        return sign * known[folded[0]], f'{"-" if sign < 0 else ""}{folded[0]}'
    try:
        factor = float(body)
    except ValueError:
        names = ', '.join(known) or 'none'
        raise InputError(f'unit {text!r} of {signal}: not a number nor one of {names}') from None
    if not (math.isfinite(factor) and factor != 0.0):
        raise InputError(f'unit {text!r} of {signal}: the factor must be finite and non-zero')
    return sign * factor, text


_BRACKETED = re.compile(r'^(.*?)\s*[\[(]\s*([^\])]+?)\s*[\])]$')   # "x [mm]", "x (mm)"
_SUFFIXED = re.compile(r'^(.*?)_([A-Za-z/]+)$')                    # "x_mm"


def split_header(column):
    """(name, unit or None) of a column header that may carry a unit: 'x_mm', 'x [mm]' or 'x (mm)'. A suffix
    after '_' counts as a unit only if it is a unit name the suite knows (so 'coil_current' stays whole)."""
    column = column.strip()
    match = _BRACKETED.match(column)
    if match and match.group(1):
        return match.group(1), match.group(2)
    match = _SUFFIXED.match(column)
    if match and match.group(1) and match.group(2) in _ALL_NAMES:
        return match.group(1), match.group(2)
    return column, None


def parse_assignments(flag, text, keys=None, what='VALUE'):
    """{KEY: VALUE} of 'KEY=VALUE[,KEY=VALUE...]' given to `flag`; keys checked against `keys` if given. None is
    the flag not given ({}); a text without any assignment ('', ',') is an InputError: the flag given empty
    (`what` names what follows NAME= in its message)."""
    if text is not None and not any(part.strip() for part in text.split(',')):
        raise InputError(f'{flag} {text!r} is empty: give NAME={what}[,...]'
                         + (f' with NAME one of {", ".join(keys)}' if keys is not None else ''))
    pairs = {}
    for item in filter(None, (part.strip() for part in (text or '').split(','))):
        key, equals, value = item.partition('=')
        key, value = key.strip(), value.strip()
        if not equals or not key or not value:
            raise InputError(f'{flag} {text!r}: expected NAME=VALUE[,NAME=VALUE...], got {item!r}')
        if keys is not None and key not in keys:
            raise InputError(f'{flag}: unknown name {key!r}; use one of {", ".join(keys)}')
        if key in pairs:
            raise InputError(f'{flag}: {key} is given twice')
        pairs[key] = value
    return pairs
