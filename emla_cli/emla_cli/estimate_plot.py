"""Plot of a bag's online estimates (/emla/parameters) against an offline estimate and the plant's truth.

    python -m emla_cli.estimate_plot BAG IDENTIFY.json OUT.png

IDENTIFY.json is the output of `emla identify BAG --json`.
"""
import json
import sys
from pathlib import Path

import numpy as np

from emla_cli.identify_plot import LABELS
from emla_core.bag import read_bag
from emla_core.parameters import PARAMETER_NAMES


def plot_estimates(bag, offline, path):
    """Write a PNG with one panel per parameter: the online estimate over time (+- 1 sigma), the offline
    estimate of the whole bag (dash-dotted), and the true value as the plant had it (dashed); axes in SI
    units with a prefix that suits them, no offset tick labels, the bag's name in the title.

    Parameters
    ----------
    bag : str or Path
        A bag recorded by `emla launch` or `emla simulate`.
    offline : dict
        The JSON of `emla identify BAG`.
    path : str or Path
        The PNG to write.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from emla_core.plot_axes import si_axis

    contents = read_bag(bag)
    names = [n for n in PARAMETER_NAMES if any(n in values for _, values, _ in contents.estimates)]
    fig, axes = plt.subplots((len(names) + 1) // 2, 2, figsize=(11, 2.4 * ((len(names) + 1) // 2)),
                             sharex=True, squeeze=False)
    for ax, name in zip(axes.flat, names):
        t = np.array([e[0] for e in contents.estimates if name in e[1]])
        value = np.array([e[1][name] for e in contents.estimates if name in e[1]])
        std = np.array([e[2].get(name, np.nan) for e in contents.estimates if name in e[1]])
        ax.plot(t, value, color='C0', label='online (identifier node)')
        ax.fill_between(t, value - std, value + std, color='C0', alpha=0.2, linewidth=0)
        if name in offline.get('parameters', {}):
            ax.axhline(offline['parameters'][name], color='C1', linestyle='-.', label='offline (emla identify)')
        if contents.truth:
            ax.step([e[0] for e in contents.truth], [e[1].get(name, np.nan) for e in contents.truth],
                    where='post', color='k', linestyle='--', label='true (plant)')
        finite = value[np.isfinite(value)]
        if finite.size:       # the first estimates are far off; frame the last 80 % of the run
            tail = finite[len(finite) // 5:]
            span = max(np.ptp(tail), 0.005 * abs(tail[-1]))
            ax.set_ylim(tail.min() - span, tail.max() + span)
        si_axis(ax, 'y', *LABELS[name])
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names):]:
        ax.axis('off')
    for j, ax in enumerate(axes.flat[:len(names)]):
        si_axis(ax, 'x', 'simulated time', 's')
        if j < len(names) - 2:   # the lowest panel of each column has it
            ax.set_xlabel('')
    axes.flat[0].legend(loc='best', fontsize='small')
    fig.suptitle(f'{Path(bag).name}: online vs offline estimates')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    bag, offline_json, out = sys.argv[1:] if argv is None else argv
    with open(offline_json) as f:
        plot_estimates(bag, json.load(f), out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
