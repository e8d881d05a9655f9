"""Convergence plots of identified parameters (matplotlib, Agg; no pyplot state is touched)."""
import math

import numpy as np
from matplotlib.figure import Figure

LABELS = {
    'resistance': 'R (ohm)', 'inductance': 'L (H)', 'emf_constant': 'Km (V s/m)',
    'mass': 'm (kg)', 'damping': 'B (N s/m)', 'load_force': 'Fl (N)',
}


def convergence_figure(time, estimates, std, truth=None, title=''):
    """A Figure with one panel per parameter: estimate over time, one-sigma band, true value dashed if known.

    time: (K,) s; estimates, std: {name: (K,) array}; truth: {name: value} (missing names: unknown).
    The vertical range leaves out the first 5 % of the time, where estimates from a few samples run far off.
    """
    truth = truth or {}
    names = list(estimates)
    columns = 2 if len(names) > 3 else 1
    panels = math.ceil(len(names) / columns)
    fig = Figure(figsize=(5.5 * columns, 1.9 * panels + 0.6), layout='constrained')
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
        ax.set_ylabel(LABELS.get(name, name))
        ax.grid(True, alpha=0.3)
        if j == 0:
            ax.legend(loc='upper right', fontsize='small')
        if j >= len(names) - columns:
            ax.set_xlabel('time (s)')
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


def save_convergence_plot(path, time, estimates, std, truth=None, title=''):
    """Write the convergence figure as a PNG to `path` (any name; the format is PNG)."""
    convergence_figure(time, estimates, std, truth, title).savefig(path, format='png', dpi=110)
