"""Axes of the suite's plots in SI units with a prefix that suits the values (inductance (mH), position (um)),
tick labels in those units and never an offset or a power-of-ten factor beside them (matplotlib's default
writes '+3.2' or '1e-3' at the axis end, which a reader easily misses).

The data are plotted in SI as they are; a formatter shows the ticks scaled, so the label and the ticks always
agree whatever is plotted later.
"""
import math

from matplotlib.ticker import ScalarFormatter

PREFIXES = {-15: 'f', -12: 'p', -9: 'n', -6: 'µ', -3: 'm', 0: '', 3: 'k', 6: 'M', 9: 'G', 12: 'T'}
# Units written with a prefix on another base: a mass of 0.036 kg reads 36 g.
BASES = {'kg': ('g', 1e3)}
DIMENSIONLESS = ('', '1', '-')


def si_unit(unit, magnitude):
    """(factor, unit with prefix): values in `unit` times factor are in the prefixed unit, in which
    `magnitude` (the largest absolute value shown) lies in [1, 1000) where a prefix can make it so.

    Parameters
    ----------
    unit : str
        An SI unit, possibly compound ('V s/m': the prefix goes in front); '', '1' or '-' for a number; one
        that starts with '[' (the unit of a column, '[y]/[u]') is written as it is.
    magnitude : float
        The largest absolute value of the axis, in `unit`.

    Returns
    -------
    (float, str)
        The factor and the unit to write, e.g. (1e3, 'mH') for `unit` 'H' and `magnitude` 0.0021.
    """
    if unit in DIMENSIONLESS:
        return 1.0, '-'
    if unit.startswith('['):
        return 1.0, unit
    base, factor = BASES.get(unit, (unit, 1.0))
    magnitude = abs(float(magnitude)) * factor
    if not (math.isfinite(magnitude) and magnitude > 0.0):
        return 1.0, unit
    exponent = min(max(math.floor(math.log10(magnitude) / 3) * 3, min(PREFIXES)), max(PREFIXES))
    if base == 'g' and exponent == 3:
        return 1.0, 'kg'
    return factor * 10.0 ** -exponent, PREFIXES[exponent] + base


def time_origin(start, end):
    """The time to count a time axis from: 0, unless the times lie far from it (stamps since 1970) compared
    with their span, then `start`."""
    return float(start) if abs(start) > 1e3 * max(abs(end - start), 1e-12) else 0.0


def si_axis(ax, which, label, unit, origin=0.0):
    """Label the 'x' or 'y' axis of `ax` '<label> (<prefixed unit>)' from its current limits, with tick
    labels in that unit and no offset text; with an `origin` (a time axis far from 0), the ticks count from
    it and the label says so.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Its limits should be final (set them, or plot everything, first).
    which : {'x', 'y'}
    label : str
        What the axis shows, e.g. 'inductance L'.
    unit : str
        The SI unit of the values plotted (see `si_unit`).
    origin : float, optional
        Subtracted from the values in the tick labels (in `unit`).

    Returns
    -------
    (float, str)
        The factor and the prefixed unit used.
    """
    axis = ax.xaxis if which == 'x' else ax.yaxis
    low, high = ax.get_xlim() if which == 'x' else ax.get_ylim()
    factor, shown = si_unit(unit, max(abs(low - origin), abs(high - origin)))
    axis.set_major_formatter(ScaledFormatter(factor, origin))
    since = f' from {origin:.10g} {unit}' if origin else ''
    axis.set_label_text(f'{label} ({shown}){since}')
    return factor, shown


def plain_ticks(ax):
    """No offset and no power-of-ten factor on either axis of `ax` (for axes whose values are scaled
    already)."""
    ax.ticklabel_format(axis='both', style='plain', useOffset=False)


class ScaledFormatter(ScalarFormatter):
    """A ScalarFormatter of (value - origin) * factor: plain numbers, without offset or factor text."""

    def __init__(self, factor=1.0, origin=0.0):
        super().__init__(useOffset=False)
        self.set_scientific(False)
        self.factor, self.origin = float(factor), float(origin)

    def _scaled(self, value):
        return (value - self.origin) * self.factor

    def set_locs(self, locs):
        super().set_locs([self._scaled(loc) for loc in locs])

    def __call__(self, x, pos=None):
        return super().__call__(self._scaled(x), pos)

    def format_data_short(self, value):
        return super().format_data_short(self._scaled(value))
