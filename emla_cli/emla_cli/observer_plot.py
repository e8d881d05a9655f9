"""The solenoid's sensorless position plot (`emla identify --actuator solenoid --observer-from ... --plot`):
matplotlib, Agg; no pyplot state is touched."""
import numpy as np
from matplotlib.figure import Figure

from emla_core.plot_axes import si_axis, time_origin


def observer_figure(time, estimate, measured=None, title=''):
    """A Figure of the observer's estimate over time: the position with its 3-sigma band (and the measured
    position, where the record has one: then also the error against it within the band), and the tracked R with
    its one-sigma.

    Parameters
    ----------
    time : (N,) array_like
        The samples' times, s.
    estimate : emla_identification.solenoid_observer.PositionEstimate
    measured : (N,) array_like, optional
        The record's own position (m), to judge the estimate by.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    time = np.asarray(time, dtype=float)
    origin = time_origin(time[0], time[-1]) if time.size else 0.0
    ratios = (2, 1, 1) if measured is not None else (2, 1)
    fig = Figure(figsize=(9.0, 2.0 + 1.8 * len(ratios)), layout='constrained')
    axes = fig.subplots(len(ratios), 1, sharex=True, height_ratios=ratios)
    position, resistance = axes[0], axes[-1]
    band = 3.0 * estimate.position_std
    position.fill_between(time, estimate.position - band, estimate.position + band, color='C0', alpha=0.25,
                          linewidth=0, label='3 sigma')
    position.plot(time, estimate.position, color='C0', linewidth=0.9, label='estimate from the coil')
    if measured is not None:
        error = estimate.position - np.asarray(measured, dtype=float)
        position.plot(time, measured, color='k', linewidth=0.7, linestyle='--', label='measured')
        axes[1].fill_between(time, -band, band, color='C0', alpha=0.25, linewidth=0, label='3 sigma')
        axes[1].plot(time, error, color='C3', linewidth=0.7,
                     label=f'estimate - measured (RMS {1e6 * float(np.sqrt(np.mean(error ** 2))):.3g} um)')
        axes[1].set_ylim(-1.5 * np.percentile(band, 99), 1.5 * np.percentile(band, 99))
        si_axis(axes[1], 'y', 'error', 'm')
        axes[1].legend(loc='lower left', bbox_to_anchor=(0.0, 1.0), ncol=2, fontsize='small', frameon=False)
    si_axis(position, 'y', 'position x', 'm')
    position.legend(loc='lower left', bbox_to_anchor=(0.0, 1.0), ncol=3, fontsize='small', frameon=False)
    resistance.fill_between(time, estimate.resistance - estimate.resistance_std,
                            estimate.resistance + estimate.resistance_std, color='C1', alpha=0.25, linewidth=0,
                            label='one sigma')
    resistance.plot(time, estimate.resistance, color='C1', label='R tracked')
    si_axis(resistance, 'y', 'resistance R', 'ohm')
    si_axis(resistance, 'x', 'time', 's', origin)
    resistance.legend(loc='lower right', fontsize='small')
    for ax in axes:
        ax.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title)
    return fig


def save_observer_plot(path, time, estimate, measured=None, title=''):
    """Write `observer_figure` as a PNG to `path`."""
    observer_figure(time, estimate, measured, title).savefig(path, format='png', dpi=110)
