"""A self-contained Markdown report of a Diagnosis with PNG figures (matplotlib, Agg backend)."""
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

from emla_core.plot_axes import si_axis, time_origin

from ..dependence import SMOOTHING, signals_of
from .data import regression_rows
from .diagnosis import Diagnosis
from .fit import FOLDS, STUDENT
from .judge import MIN_BLOCKS, MIN_SCORE, MIN_SHARE, MIN_T, MOST
from .locate import localise
from .residuals import CONFIDENCE

UNITS = {'current': 'A', 'position': 'm', 'voltage': 'V', 'force': 'N', 'time': 's', 'velocity': 'm/s',
         'acceleration': 'm/s^2', 'current rate': 'A/s', 'force rate': 'N/s', 'voltage rate': 'V/s'}
WINDOW = 0.08   # s of record shown in the time plots, around the largest discrepancy


def write_report(diagnosis: Diagnosis, directory: Path | str, json_text: str | None = None) -> Path:
    """Write report.md, gap.png, residuals.png, correlation.png, disagreement.png (and diagnosis.json) into
    `directory`. The figures' axes are in SI units with a prefix that suits them and no offset tick labels;
    their titles name the data.

    Parameters
    ----------
    diagnosis : Diagnosis
        What `emla discrepancy` found.
    directory : str or Path
        Created if missing.
    json_text : str, optional
        The diagnosis as JSON, written as diagnosis.json.

    Returns
    -------
    Path
        The report.md written.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    before, after = localise(diagnosis.nominal), localise(diagnosis.final)
    figures = {'gap.png': _gap_figure(plt, diagnosis), 'residuals.png': _residual_figure(plt, before, after),
               'correlation.png': _correlation_figure(plt, before, after),
               'disagreement.png': _disagreement_figure(plt, diagnosis)}
    name = Path(diagnosis.data.source).name or 'record'
    for figure in figures.values():
        title = figure.get_suptitle()
        figure.suptitle(f'{name}: {title}' if title else name, fontsize=10)
        figure.tight_layout()
    for name, figure in figures.items():
        figure.savefig(directory / name, dpi=90)
        plt.close(figure)
    if json_text is not None:
        (directory / 'diagnosis.json').write_text(json_text)
    (directory / 'report.md').write_text(markdown(diagnosis, before))
    return directory / 'report.md'


def _gap_figure(plt, diagnosis):
    signals = list(diagnosis.before)
    figure, axes = plt.subplots(2, len(signals), figsize=(6.5 * len(signals), 6.5), squeeze=False,
                                sharex='col')
    ts = diagnosis.data.sample_period
    for j, signal in enumerate(signals):
        b, a = diagnosis.before[signal], diagnosis.after[signal]
        common, ib, ia = np.intersect1d(b.index, a.index, return_indices=True)
        if not common.size:
            axes[0, j].text(0.5, 0.5, f'{signal}: nothing predicted (a horizon of {b.horizon} samples is longer '
                            'than the record)', ha='center', transform=axes[0, j].transAxes)
            continue
        error = np.abs(b.measured[ib] - b.predicted[ib])
        span = int(WINDOW / ts)
        centre = int(np.argmax(np.convolve(error, np.ones(span), mode='same')))
        window = slice(max(0, centre - span // 2), centre + span // 2)
        t = diagnosis.data.start_time + common[window] * ts
        unit = UNITS[signal]
        top, bottom = axes[0, j], axes[1, j]
        top.plot(t, b.measured[ib][window], 'k', lw=1.2, label='measured')
        top.plot(t, b.predicted[ib][window], 'tab:red', lw=1, label=f'nominal (NRMSE {b.nrmse:.3g})')
        top.plot(t, a.predicted[ia][window], 'tab:blue', lw=1, ls='--', label=f'with effect (NRMSE {a.nrmse:.3g})')
        top.set_title(f'{signal}: {b.horizon}-step-ahead prediction')
        top.legend(fontsize=8)
        bottom.plot(t, (b.measured[ib] - b.predicted[ib])[window], 'tab:red', lw=1, label='nominal')
        bottom.plot(t, (a.measured[ia] - a.predicted[ia])[window], 'tab:blue', lw=1, label='with effect')
        bottom.legend(fontsize=8)
        si_axis(top, 'y', signal, unit)
        si_axis(bottom, 'y', 'prediction error', unit)
        si_axis(bottom, 'x', 'time', 's', time_origin(t[0], t[-1]))
    return figure


def _residual_figure(plt, before, after):
    kinds = list(before)
    names = list(next(iter(before.values())).bins)
    figure, axes = plt.subplots(len(kinds), len(names), figsize=(3.3 * len(names), 3.0 * len(kinds)),
                                squeeze=False)
    for i, kind in enumerate(kinds):
        for j, name in enumerate(names):
            ax = axes[i, j]
            for loc, colour, label in ((before[kind], 'tab:red', 'nominal'), (after[kind], 'tab:blue', 'with effect')):
                b = loc.bins[name]
                ax.errorbar(b.centers, b.mean, yerr=2 * b.error, color=colour, marker='.', ms=4, lw=1,
                            capsize=2, label=label)
            ax.axhline(0.0, color='0.6', lw=0.8)
            si_axis(ax, 'x', name, UNITS[name])
            quantity = before[kind].quantity
            # each panel its own unit: the prefix follows its range
            si_axis(ax, 'y', f'{kind}: mean {quantity} residual' if j == 0 else f'mean {quantity} residual',
                    UNITS[quantity])
    axes[0, 0].legend(fontsize=8)
    figure.suptitle('One-step residuals (1 ms means) binned against the signals (bars: +-2 standard errors)')
    return figure


def _correlation_figure(plt, before, after):
    kinds = list(before)
    figure, axes = plt.subplots(len(kinds), 2, figsize=(11, 3.0 * len(kinds)), squeeze=False)
    for i, kind in enumerate(kinds):
        for j, attr in enumerate(('whiteness', 'cross')):
            ax = axes[i, j]
            for loc, colour, label in ((before[kind], 'tab:red', 'nominal'), (after[kind], 'tab:blue', 'with effect')):
                c = getattr(loc, attr)
                ax.plot(c.lags, c.values, color=colour, marker='.', ms=3, lw=0.8, label=label)
                ax.axhspan(-c.bound, c.bound, color=colour, alpha=0.12)
            title = 'autocorrelation of the residual' if attr == 'whiteness' else \
                f'cross-correlation with {before[kind].input_name}'
            ax.set_title(f'{kind}: {title}', fontsize=10)
            ax.set_xlabel('lag (samples)')
            si_axis(ax, 'y', 'correlation', '-')
    axes[0, 0].legend(fontsize=8)
    return figure


def markdown(diagnosis: Diagnosis, before: dict) -> str:
    """The text of report.md, its figures linked but not drawn (`write_report` draws them beside it).

    The verdict, the warnings, the effects named, where the model disagrees, the gap between model and
    measurement, the candidates, the residuals' correlations and the parameters.

    Parameters
    ----------
    diagnosis : Diagnosis
        What `emla discrepancy` found.
    before : dict
        {equation: Localisation} of the nominal model's residuals: `locate.localise(diagnosis.nominal)`.

    Returns
    -------
    str
        The Markdown, ending in a newline.
    """
    d = diagnosis.to_dict()
    data = diagnosis.data
    verdict = d['verdict']
    lines = [f'# Model discrepancy: {verdict}', '',
             f'Data: `{data.source}`, {len(data)} samples at {1 / data.sample_period:g} Hz '
             f'({"voltage, current, position" if data.electrical else "force, position"}).', '']
    lines += {'adequate': ['**The nominal model is adequate**: its held-out residuals are at the sensor-noise floor '
                           'in every equation; nothing is left to explain.', ''],
              'explained': ['**Explained**: the named effects, added to the model and re-identified with it, leave '
                            'the residuals at the sensor-noise floor.', ''],
              'unexplained': ['**Unexplained**: a disagreement remains that no candidate effect explains'
                              + (' after the named ones' if d['effects'] else '') + '; where it lies is below, and a '
                              'new candidate (`register_candidate`) must depend on the signal at the top of its list.',
                              '']}[verdict]
    if d['warnings']:
        lines += ['**Warnings** (an implausible estimate, or a choice of model the parameters depend on):', '',
                  *(f'- {w}' for w in d['warnings']), '']
    if d['effects']:
        lines += ['## Effects named, in turn', '',
                  '| effect | parameters (final joint fit, one sigma) | share of the disagreement removed | '
                  'gap after (NRMSE) |', '|---|---|---|---|']
        for effect in d['effects']:
            params = '; '.join(f'{k} held at 0' if k in d['held_at_zero'] else
                               f'{k} = {v:.6g} +- {effect["std"][k]:.2g}' for k, v in effect['parameters'].items())
            gaps = ', '.join(f'{s} {_figure(v)}' for s, v in effect['gap_after'].items())
            lines.append(f'| {effect["effect"]} | {params} | {100 * effect["share"]:.0f} % | {gaps} |')
        lines.append('')
    if diagnosis.partial is not None:
        lines += [f'`{diagnosis.partial.name}` is significant but only a partial match: it removes '
                  f'{100 * diagnosis.partial.share:.0f} % of the disagreement left (naming takes '
                  f'{100 * MIN_SHARE:.0f} %).', '']
    lines += ['## Where the model disagrees', '',
              'Each equation\'s held-out one-step residual in physical units (volts of the voltage balance, newtons '
              'of the force balance), in the band below the noise\'s (0-500 Hz at 10 kHz): its RMS beyond what the '
              'sensor noise puts there, against that noise floor. Where it is not adequate, the signals a smooth '
              'function of which explains most of it (beside the model\'s own terms).', '',
              '| equation | model | beyond the noise (RMS) | noise floor (RMS) | power ratio | depends on |',
              '|---|---|---|---|---|---|']
    for label, key in (('nominal', 'disagreement_nominal'), ('final', 'disagreement')):
        for equation, q in d[key].items():
            unit = UNITS[q['quantity']]
            depends = ', '.join(f'{x["signal"]} ({100 * x["explained"]:.0f} %)' for x in q.get('depends_on', [])[:3])
            jointly = '; jointly: ' + ', '.join(f'{" and ".join(x["signals"])} ({100 * x["explained"]:.0f} %)'
                                                for x in q.get('jointly', [])) if q.get('jointly') else ''
            lines.append(f'| {equation} | {label} | {q["size"]:.3g} {unit} | {q["noise_floor"]:.3g} {unit} | '
                         f'{q["ratio"]:.3g} | {depends or "(adequate)"}{jointly} |')
    lines += ['', '![disagreement](disagreement.png)', '',
              '## Gap between model and measurement', '', d['method'] + '.', '',
              '| signal | NRMSE nominal | NRMSE final |', '|---|---|---|']
    lines += [f'| {s} | {_figure(d["gap_before"][s])} | {_figure(d["gap_after"][s])} |' for s in d['gap_before']]
    lines += ['', 'NRMSE = ||y - yhat|| / ||y - mean(y)||.', '', '![prediction](gap.png)', '',
              '## Candidate effects', '',
              f'Significant = better on at least {MIN_BLOCKS} of {FOLDS} held-out blocks (sign test; one fewer '
              f'for a score of {MOST:g} or more), score '
              f'at least {MIN_SCORE:g} (fraction of the held-out one-step error removed, summed over the '
              f'equations), a parameter at least {MIN_T:g} jackknife sigmas from zero, and parameters of a sign '
              f'physics allows. Named = significant and removing at least {100 * MIN_SHARE:.0f} % of the '
              'disagreement left.', '',
              '| effect | score | significant | evidence |', '|---|---|---|---|']
    lines += [f'| {c["effect"]} | {c["score"]:.4f} | {"yes" if c["significant"] else "no"} | {c["evidence"]} |'
              for c in d['candidates']]
    lines += ['', '## Residuals against the signals', '',
              'One-step residuals binned against time, velocity, position, the drive and its rate; an effect shows '
              'as a systematic pattern (Coulomb friction: a step at zero velocity; a spring: a slope in position; '
              'resistance drift: a trend in time).', '', '![residuals](residuals.png)', '']
    for kind, loc in before.items():
        lines.append(f'- {kind}: {100 * loc.whiteness.outside:.0f} % of autocorrelation lags and '
                     f'{100 * loc.cross.outside:.0f} % of cross-correlation lags with {loc.input_name} outside '
                     f'the {100 * CONFIDENCE:.0f} % bounds (nominal model; peak cross-correlation at lag '
                     f'{loc.cross.peak_lag}).')
    lines += ['', '![correlation](correlation.png)', '', '## Parameters', '',
              f'One sigma: block jackknife ({FOLDS} blocks, times {STUDENT:.3f}: the standard deviation of Student\'s '
              f't with {FOLDS - 1} degrees of freedom), with a systematic part (the change under another prefilter) '
              'for the final model.', '',
              '| parameter | nominal | final (with the named effects) |', '|---|---|---|']
    final_std = diagnosis.final_std[0]
    for name, value in diagnosis.nominal.parameters.items():
        if name != 'sample_period':
            lines.append(f'| {name} | {_pm(value, STUDENT * diagnosis.nominal.std.get(name, np.nan))} | '
                         f'{_pm(diagnosis.final.parameters[name], final_std.get(name))} |')
    return '\n'.join(lines) + '\n'


def _disagreement_figure(plt, diagnosis):
    """Each equation's residual (smoothed) against the signal it depends on most, for the final model (the
    nominal one where the final one is adequate)."""
    final = diagnosis.disagreement('final')
    adequacy = diagnosis.final_adequacy
    figure, axes = plt.subplots(1, len(adequacy), figsize=(6.0 * len(adequacy), 4.0), squeeze=False)
    data = diagnosis.final.data
    index = regression_rows(data)
    width = max(1, int(round(SMOOTHING / data.sample_period)))
    against = signals_of(data, index)
    for ax, (equation, a) in zip(axes[0], adequacy.items()):
        top = final[equation].get('depends_on')
        name = top[0]['signal'] if top else 'time'
        ax.plot(uniform_filter1d(against[name], width), uniform_filter1d(a.residual, width), ',', alpha=0.5,
                color='tab:purple')
        ax.axhline(0.0, color='0.6', lw=0.8)
        si_axis(ax, 'x', name, UNITS.get(name, '-'), time_origin(*ax.get_xlim()) if name == 'time' else 0.0)
        si_axis(ax, 'y', f'{a.quantity} residual, {SMOOTHING * 1e3:g} ms means', UNITS[a.quantity])
        state = 'at the noise floor' if a.adequate else f'{a.size:.3g} {UNITS[a.quantity]} beyond the noise'
        ax.set_title(f'{equation} ({"final" if diagnosis.stages else "nominal"} model): {state}', fontsize=10)
    return figure


def _figure(value):
    """A figure of the report, or 'n/a' where it could not be computed."""
    return f'{value:.4g}' if np.isfinite(value) else 'n/a'


def _pm(value, sigma):
    return f'{value:.6g} +- {sigma:.2g}' if sigma is not None and np.isfinite(sigma) else f'{value:.6g}'
