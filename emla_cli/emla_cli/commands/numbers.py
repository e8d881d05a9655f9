"""Numeric options checked as they are parsed: a number that is not finite or not in its range is one line
('--timeout nan: must be a number in (0, 86400] s') and exit 2, before any work, as every command's bad input.
Each range is what the option can sensibly mean (a play rate of 1e-9 would wait for ever, a simulated duration
of 1e9 s would not fit in memory), and the message says it."""
import math

from emla_core.errors import InputError


def _interval(low, high, open_low):
    def shown(bound):
        return f'{bound:g}' if isinstance(bound, float) else str(bound)
    return f'{"(" if open_low else "["}{shown(low)}, {shown(high)}]'


def number(flag, low, high, *, integer=False, open_low=False, zero=False, unit=''):
    """An argparse `type` for the option `flag`: the text as a finite number in its range, else InputError.

    Parameters
    ----------
    flag : str
        The option as the user writes it, for the message ('--timeout').
    low, high : float
        The range; `high` is included, `low` too unless `open_low`.
    integer : bool
        Whether the value must be a whole number (an int is returned).
    open_low : bool
        Whether `low` itself is refused (a positive duration: low 0, open).
    zero : bool
        Whether 0 is taken besides the range (a play rate of 0: as fast as possible).
    unit : str
        The unit, for the message ('s').

    Returns
    -------
    callable
        text -> int or float, raising InputError with one line naming the option, the value and the range.

    Examples
    --------
    >>> number('--rate', 0.01, 1000, zero=True)('2')
    2.0
    """
    kind = 'an integer' if integer else 'a number'
    wanted = f'{"0 or " if zero else ""}{kind} in {_interval(low, high, open_low)}{f" {unit}" if unit else ""}'

    def parse(text):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        inside = low < value <= high if open_low else low <= value <= high
        if not (inside or (zero and value == 0)):
            raise InputError(f'{flag} {text}: must be {wanted}')
        return value
    return parse


def add_number(parser, *flags, low, high, integer=False, open_low=False, zero=False, unit='', **options):
    """parser.add_argument(*flags, **options) with the `number` check of the first long flag (see there)."""
    flag = next((f for f in flags if f.startswith('--')), flags[0])
    return parser.add_argument(*flags, type=number(flag, low, high, integer=integer, open_low=open_low, zero=zero,
                                                   unit=unit), **options)
