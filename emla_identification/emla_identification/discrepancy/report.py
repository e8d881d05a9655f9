"""A self-contained Markdown report of a Diagnosis with PNG figures (matplotlib, Agg backend)."""
from pathlib import Path

import numpy as np

from .fit import FOLDS
from .residuals import CONFIDENCE
from .workflow import MIN_BLOCKS, MIN_SCORE, MIN_T, localise

UNITS = {'current': 'A', 'position': 'm', 'voltage': 'V', 'force': 'N', 'time': 's', 'velocity': 'm/s',
         'current rate': 'A/s', 'force rate': 'N/s'}
WINDOW = 0.08   # s of record shown in the time plots, around the largest discrepancy


def write_report(diagnosis, directory, json_text=None):
    """Write report.md, gap.png, residuals.png, correlation.png (and diagnosis.json) into `directory`."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    before, after = localise(diagnosis.nominal), localise(diagnosis.final)
    figures = {'gap.png': _gap_figure(plt, diagnosis), 'residuals.png': _residual_figure(plt, before, after),
               'correlation.png': _correlation_figure(plt, before, after)}
    for name, figure in figures.items():
        figure.savefig(directory / name, dpi=90)
        plt.close(figure)
    if json_text is not None:
        (directory / 'diagnosis.json').write_text(json_text)
    (directory / 'report.md').write_text(_markdown(diagnosis, before))
    return directory / 'report.md'


def _gap_figure(plt, diagnosis):
    signals = list(diagnosis.before)
    figure, axes = plt.subplots(2, len(signals), figsize=(6.5 * len(signals), 6.5), squeeze=False,
                                sharex='col')
    ts = diagnosis.data.sample_period
    for j, signal in enumerate(signals):
        b, a = diagnosis.before[signal], diagnosis.after[signal]
        common, ib, ia = np.intersect1d(b.index, a.index, return_indices=True)
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
        top.set_ylabel(f'{signal} ({unit})')
        top.set_title(f'{signal}: {b.horizon}-step-ahead prediction')
        top.legend(fontsize=8)
        bottom.plot(t, (b.measured[ib] - b.predicted[ib])[window], 'tab:red', lw=1, label='nominal')
        bottom.plot(t, (a.measured[ia] - a.predicted[ia])[window], 'tab:blue', lw=1, label='with effect')
        bottom.set_ylabel(f'prediction error ({unit})')
        bottom.set_xlabel('time (s)')
        bottom.legend(fontsize=8)
    figure.tight_layout()
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
            ax.set_xlabel(f'{name} ({UNITS[name]})')
            if j == 0:
                ax.set_ylabel(f'{kind}: mean {before[kind].quantity} residual ({UNITS[before[kind].quantity]})')
    axes[0, 0].legend(fontsize=8)
    figure.suptitle('One-step residuals (1 ms means) binned against the signals (bars: +-2 standard errors)')
    figure.tight_layout()
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
    axes[0, 0].legend(fontsize=8)
    figure.tight_layout()
    return figure


def _markdown(diagnosis, before):
    d = diagnosis.to_dict()
    data = diagnosis.data
    main, second = diagnosis.main, diagnosis.second_effect
    lines = [f'# Model discrepancy: {d["missing_effect"]}', '',
             f'Data: `{data.source}`, {len(data)} samples at {1 / data.sample_period:g} Hz '
             f'({"voltage, current, position" if data.electrical else "force, position"}).', '']
    if main:
        lines += [f'**Missing effect: `{main.name}`** ({100 * main.score:.1f} % of the held-out one-step error '
                  'of the nominal model explained). Added parameters:', ''] + _parameter_table(main)
    else:
        lines += ['**No missing effect**: no candidate explains a significant part of what the nominal model '
                  'leaves unexplained.', '']
    if second:
        gaps = ', '.join(f'{s} {v:.4g}' for s, v in d['second_effect']['gap_after'].items())
        lines += [f'**A second effect is significant once the first is in the model: `{second.name}`** '
                  f'(NRMSE with both: {gaps}).', ''] + _parameter_table(second)
    lines += ['## Gap between model and measurement', '', d['method'] + '.', '',
              '| signal | NRMSE nominal | NRMSE with the effect |', '|---|---|---|']
    lines += [f'| {s} | {d["gap_before"][s]:.4g} | {d["gap_after"][s]:.4g} |' for s in d['gap_before']]
    lines += ['', 'NRMSE = ||y - yhat|| / ||y - mean(y)||.', '', '![prediction](gap.png)', '',
              '## Candidate effects', '',
              f'Significant = better on at least {MIN_BLOCKS} of {FOLDS} held-out blocks (sign test), score '
              f'at least {MIN_SCORE:g} (fraction of the held-out one-step error removed, summed over the '
              f'equations), a parameter at least {MIN_T:g} jackknife sigmas from zero, and parameters of the '
              'sign physics gives them.', '',
              '| effect | score | significant | evidence |', '|---|---|---|---|']
    lines += [f'| {c["effect"]} | {c["score"]:.4f} | {"yes" if c["significant"] else "no"} | {c["evidence"]} |'
              for c in d['candidates']]
    lines += ['', '## Where the nominal model disagrees', '',
              'One-step residuals of each equation in physical units (electrical: volts of the voltage balance, '
              'mechanical: newtons of the force balance), binned against time, velocity, position, the drive '
              'and its rate; an effect shows as a systematic pattern (Coulomb friction: a step at zero '
              'velocity; a spring: a slope in position; resistance drift: a trend in time).', '',
              '![residuals](residuals.png)', '']
    for kind, loc in before.items():
        lines.append(f'- {kind}: {100 * loc.whiteness.outside:.0f} % of autocorrelation lags and '
                     f'{100 * loc.cross.outside:.0f} % of cross-correlation lags with {loc.input_name} outside '
                     f'the {100 * CONFIDENCE:.0f} % bounds (nominal model; peak cross-correlation at lag '
                     f'{loc.cross.peak_lag}).')
    lines += ['', 'The sensor noise gives the residuals structure of their own at lags 1-2 (current noise enters '
              'both sides of the electrical equation, the second difference of position noise the mechanical '
              'one); what matters is the correlation beyond that and with the input.', '',
              '![correlation](correlation.png)', '', '## Parameters', '',
              'One sigma from the delete-one-block jackknife.', '',
              '| parameter | nominal | re-identified with the effect |', '|---|---|---|']
    for name, value in diagnosis.nominal.parameters.items():
        if name != 'sample_period':
            new = diagnosis.final.parameters[name]
            lines.append(f'| {name} | {_pm(value, diagnosis.nominal.std.get(name))} | '
                         f'{_pm(new, diagnosis.final.std.get(name))} |')
    return '\n'.join(lines) + '\n'


def _parameter_table(assessment):
    lines = ['| parameter | value | one sigma (block jackknife) |', '|---|---|---|']
    lines += [f'| {k} | {v:.6g} | {s:.2g} |' for k, (v, s) in assessment.parameters.items()]
    settings = ', '.join(f'{k} = {v:.4g}' for k, v in assessment.settings.items())
    return lines + ([''] + [f'Found by search: {settings}.'] if settings else []) + ['']


def _pm(value, sigma):
    return f'{value:.6g} +- {sigma:.2g}' if sigma is not None and np.isfinite(sigma) else f'{value:.6g}'
