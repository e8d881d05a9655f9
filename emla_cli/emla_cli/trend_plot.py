"""The plot of a trend: each parameter against time with its band and the changes marked; the resistance also as
the coil's temperature (matplotlib, Agg; no pyplot state is touched)."""
import math

import numpy as np
from matplotlib.figure import Figure

from emla_cli.identify_plot import LABELS
from emla_core.plot_axes import si_axis

HOUR = 3600.0


def trend_figure(result, reference=None):
    """A Figure with one panel per parameter of a fleet.Trend: the estimates against time (hours, or the
    recording's index when they have no time), a band of two standard deviations, the true values dashed where
    the recordings carry them, each change as a vertical line labelled with its step.

    Parameters
    ----------
    result : emla_identification.fleet.Trend
    reference : (float, float, float), optional
        (R0 ohm, T0 degC, alpha 1/K): the resistance axis also in coil temperature T = T0 + (R / R0 - 1) / alpha.

    Returns
    -------
    matplotlib.figure.Figure
    """
    recordings = result.recordings
    names = list(dict.fromkeys(n for r in recordings for n in r['parameters']))
    timed = recordings and all(r['start'] is not None for r in recordings)
    origin = min(r['start'] for r in recordings) if timed else 0.0
    x = (np.array([(r['start'] - origin) / HOUR for r in recordings]) if timed
         else np.arange(len(recordings), dtype=float))
    columns = 2 if len(names) > 3 else 1
    panels = max(1, math.ceil(len(names) / columns))
    fig = Figure(figsize=(6.0 * columns, 2.1 * panels + 0.8), layout='constrained')
    for j, name in enumerate(names):
        ax = fig.add_subplot(panels, columns, j + 1)
        value = np.array([_value(r['parameters'].get(name)) for r in recordings])
        sigma = np.array([_value(r['std'].get(name)) for r in recordings])
        ax.fill_between(x, value - 2 * sigma, value + 2 * sigma, color='C0', alpha=0.25, linewidth=0,
                        label='two sigma')
        ax.plot(x, value, '.-', color='C0', markersize=3, linewidth=0.8, label='estimate')
        truth = np.array([_value((r.get('truth') or {}).get(name)) for r in recordings])
        if np.isfinite(truth).any():
            ax.plot(x, truth, '--', color='C3', linewidth=0.9, label='true')
        for change in (c for c in result.changes if c['parameter'] == name):
            ax.axvline(x[change['index']], color='C1', linewidth=1.0)
            ax.annotate(f'{change["sigma"]:+.3g} sigma', (x[change['index']], 1.0), xycoords=('data', 'axes fraction'),
                        xytext=(3, -10), textcoords='offset points', fontsize='x-small', color='C1')
        label, unit = LABELS.get(name, (name, '-'))
        si_axis(ax, 'y', label, unit)
        ax.set_xlabel('time (h) from the first recording' if timed else 'recording')
        ax.grid(True, alpha=0.3)
        if name == 'resistance' and reference is not None:
            ax.secondary_yaxis('right', functions=_temperature(*reference)).set_ylabel('coil temperature (degC)')
        if j == 0:
            ax.legend(loc='best', fontsize='small')
    fig.suptitle(f'{len(recordings)} recordings, {len(result.changes)} change(s)'
                 + (f', {len(result.failed)} failed' if result.failed else ''))
    return fig


def _temperature(r0, t0, alpha):
    """(R -> T, T -> R) of a coil whose resistance is r0 at t0 degC with temperature coefficient alpha (1/K)."""
    return (lambda r: t0 + (r / r0 - 1.0) / alpha), (lambda t: r0 * (1.0 + alpha * (t - t0)))


def _value(v):
    return float(v) if v is not None else math.nan


def save_trend_plot(path, result, reference=None):
    """trend_figure(result, reference) as a PNG at `path`."""
    trend_figure(result, reference).savefig(path, dpi=110, format='png')
