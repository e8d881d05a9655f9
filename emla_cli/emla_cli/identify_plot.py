"""Convergence plots of identified parameters (matplotlib, Agg; no pyplot state is touched)."""
import math

import numpy as np
from matplotlib.figure import Figure

from emla_core.plot_axes import si_axis, time_origin

# name -> (what the axis shows, SI unit)
LABELS = {
    'resistance': ('resistance R', 'ohm'), 'inductance': ('inductance L', 'H'),
    'emf_constant': ('EMF constant Km', 'V s/m'), 'mass': ('mass m', 'kg'), 'damping': ('damping B', 'N s/m'),
    'load_force': ('load force Fl', 'N'),
}


def convergence_figure(time, estimates, std, truth=None, title='', units=None):
    """A Figure with one panel per parameter: estimate over time, one-sigma band, true value dashed if known.

    Each axis is labelled with its unit, scaled to an SI prefix that suits its values (inductance L (mH)), and
    its ticks carry no offset; a time axis of stamps far from 0 counts from its first one.

    Parameters
    ----------
    time : (K,) array_like
        Time of each estimate, s.
    estimates, std : dict of str to (K,) array_like
        Each parameter's estimate and one-sigma uncertainty over time, in SI.
    truth : dict of str to float, optional
        True values where known (a simulated run's); drawn dashed.
    title : str, optional
        The figure's title: the data's name (file name) and the model.
    units : dict of str to str, optional
        SI unit of parameters not in LABELS (ARX coefficients: '-' for a number, 'A/V', ...).

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The vertical range leaves out the first 5 % of the time, where estimates from a few samples run far off.
    """
    truth, units = truth or {}, units or {}
    time = np.asarray(time, dtype=float)
    names = list(estimates)
    columns = 2 if len(names) > 3 else 1
    panels = math.ceil(len(names) / columns)
    fig = Figure(figsize=(5.5 * columns, 1.9 * panels + 0.6), layout='constrained')
    origin = time_origin(time[0], time[-1]) if time.size else 0.0
    for j, name in enumerate(names):
        ax = fig.add_subplot(panels, columns, j + 1)
        value, sigma = np.asarray(estimates[name], dtype=float), np.asarray(std[name], dtype=float)
        ax.fill_between(time, value - sigma, value + sigma, color='C0', alpha=0.25, linewidth=0,
                        label='one sigma')
        ax.plot(time, value, color='C0', label='estimate')
        known = truth.get(name)
        if known is not None:
            ax.axhline(known, color='C3', linestyle='--', label='true')
        ax.set_ylim(*_limits(time, value, sigma, known))
        label, unit = LABELS.get(name, (name, units.get(name, '-')))
        si_axis(ax, 'y', label, unit)
        si_axis(ax, 'x', 'time', 's', origin)
        if j < len(names) - columns:
            ax.set_xlabel('')
        ax.grid(True, alpha=0.3)
        if j == 0:
            ax.legend(loc='upper right', fontsize='small')
    if title:
        fig.suptitle(title)
    return fig


def _limits(time, value, sigma, known):
    settled = time >= time[0] + 0.05 * (time[-1] - time[0])
    sigma = np.nan_to_num(sigma[settled], nan=0.0, posinf=0.0)
    low = np.nanmin(np.append(value[settled] - sigma, known if known is not None else np.nan))
    high = np.nanmax(np.append(value[settled] + sigma, known if known is not None else np.nan))
    pad = 0.1 * (high - low) + 1e-6 * max(abs(low), abs(high), 1e-300)
    return low - pad, high + pad


def save_convergence_plot(path, time, estimates, std, truth=None, title='', units=None):
    """Write the convergence figure (see `convergence_figure`) as a PNG to `path` (any name; the format is
    PNG)."""
    convergence_figure(time, estimates, std, truth, title, units).savefig(path, format='png', dpi=110)
