"""`emla compare`: a model file (or two) driven by a record's measured inputs against its measured outputs,
as MATLAB's compare does; the subsystem predictions of the discrepancy workflow (discrepancy/predict.py)."""
import math
import sys
from pathlib import Path

from emla_core.errors import InputError
from emla_core.parameters import FAMILIES

from .inputs import DATA_HELP, add_data_arguments, load_data, understood, unknown_figures, warn
from .output import add_force_argument, check_outputs, emit_json

HELP = 'Compare a model file (or two) with measured data: each subsystem predicted from its measured inputs.'
SIGNAL_UNITS = {'current': 'A', 'position': 'm'}


def description():
    return """\
Drive the model of a model file with a record's measured inputs and compare its outputs with the measured
ones, as MATLAB's compare does. A closed loop has an integrator in it, so each subsystem is run from its
own measured inputs and every sample is predicted from the measured state a horizon before it:
  current   from the measured voltage and the back-EMF of the measured position, 5 L/R ahead (the initial
            current is forgotten by then: a free run in effect)
  position  from the measured current (the force Km I and the model's effects) or force, 10 ms ahead
Fit (%) = 100 (1 - |y - yhat| / |y - mean y|) and NRMSE = |y - yhat| / |y - mean y| per signal. With two
--model-file the two models are compared side by side on the same data (the nominal and the augmented
model: the gap shrinking). A solenoid's model file (`actuator: solenoid`, from `emla identify --actuator solenoid
--model-out`) runs free under the measured voltage from the first sample (an open-loop solenoid is stable: its
spring and stops bring it back), current and position over the whole record. The JSON goes to stdout unless
--json is given; --plot draws measured against predicted over the stretch where they differ most. A signal
the data seem to read in another unit or sign than the model expects (the model's voltage and force balances
on the data name it and its factor: a current in mA, a flipped position, a shunt's gain; a time in ms from the
sample period) is warned about on stderr with the flag that fixes it, as is a figure that cannot be computed
(null in the JSON); both are listed under "warnings".

""" + DATA_HELP


def add_arguments(parser):
    parser.add_argument('data', metavar='DATA', help='CSV or MAT file, rosbag2 directory or .mcap file')
    parser.add_argument('--actuator', metavar='FAMILY',
                        help='moving_coil or solenoid: the family the model files must be (default: theirs)')
    parser.add_argument('--model-file', metavar='M.yaml', action='append', required=True,
                        help='a model file (give it twice to compare two models)')
    parser.add_argument('--json', metavar='FILE', help='write the result here instead of stdout')
    parser.add_argument('--plot', metavar='FILE.png', help='PNG of measured and predicted signals')
    add_force_argument(parser)
    add_data_arguments(parser)


def run(args):
    from emla_core.bag.report import read_warnings
    from emla_core.model_file import read
    from emla_identification.checks import check_magnitudes, numerical_failures
    from emla_identification.discrepancy.predict import predict
    from emla_identification.model import model_on_data
    from emla_identification.solenoid_predict import predict_solenoid

    if len(args.model_file) > 2:
        raise InputError('--model-file: give one model, or two to compare them')
    check_outputs({'--json': args.json, '--plot': args.plot}, [args.data, *args.model_file], args.force)
    with read_warnings() as lost:  # a bag's skipped chunks and the data they cost, for the JSON too
        recording = load_data(args)
    check_magnitudes(recording)
    predictions = {}
    models = {path: read(path) for path in args.model_file}
    if args.actuator is not None:
        if args.actuator not in FAMILIES:
            raise InputError(f'--actuator {args.actuator!r}: choose one of {", ".join(FAMILIES)}')
        models = {path: model.require(args.actuator, path) for path, model in models.items()}
    families = {model.actuator for model in models.values()}
    if len(families) > 1:
        raise InputError(f'--model-file: {" and ".join(args.model_file)} are models of different actuators')
    with numerical_failures(recording.source, 'the models cannot be predicted'):
        for path, model in models.items():
            predictions[path] = (predict_solenoid(model.solenoid(), recording) if model.actuator == 'solenoid'
                                 else predict(model_on_data(model, recording, path)))
    result = {'models': list(predictions),
              'fit_percent': {m: {s: round(100.0 * (1.0 - p.nrmse), 4) for s, p in pred.items()}
                              for m, pred in predictions.items()},
              'nrmse': {m: {s: round(p.nrmse, 6) for s, p in pred.items()} for m, pred in predictions.items()},
              'horizon': {s: {'samples': p.horizon, 'seconds': p.horizon * recording.sample_period}
                          for s, p in next(iter(predictions.values())).items()},
              **understood(recording, 'compare')}
    if len(predictions) == 1:   # one model: its figures directly, as the contract's single-model form
        (only,) = predictions
        result['fit_percent'], result['nrmse'] = result['fit_percent'][only], result['nrmse'][only]
    result['warnings'] = lost + warn(_warnings(args.model_file, recording) + unknown_figures(result), 'compare')
    emit_json(result, args.json, [(args.plot, lambda temporary: plot(predictions, recording, temporary))])
    for model, pred in predictions.items():
        fits = ', '.join(f'{s} {_percent(p.nrmse)}' for s, p in pred.items())
        print(f'emla compare: {Path(model).name}: fit {fits}', file=sys.stderr)
    return 0


def _warnings(paths, recording):
    """The data's implausible magnitudes against each model, each warning once."""
    from emla_core.model_file import read
    from emla_identification.plausibility import plausibility_warnings

    models = [read(path) for path in paths]
    return list(dict.fromkeys(w for model in models if model.actuator == 'moving_coil'
                              for w in plausibility_warnings(model.values(), {}, recording, identified=False)))


def _percent(nrmse):
    """The fit in percent for the text line, or 'n/a'."""
    return f'{100.0 * (1.0 - nrmse):.2f} %' if math.isfinite(nrmse) else 'n/a'


def plot(predictions, recording, path, window=0.08):
    """PNG: per signal, measured and each model's prediction over the `window` s where the first model errs
    most, and the prediction errors below."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from emla_core.plot_axes import si_axis, time_origin

    first = next(iter(predictions.values()))
    signals = list(first)
    figure, axes = plt.subplots(2, len(signals), figsize=(6.5 * len(signals), 6.5), squeeze=False, sharex='col')
    ts = recording.sample_period
    colours = ('tab:red', 'tab:blue')
    for j, signal in enumerate(signals):
        reference = first[signal]
        if not reference.index.size:
            axes[0, j].text(0.5, 0.5, f'{signal}: nothing predicted (a horizon of {reference.horizon} samples is '
                            'longer than the record)', ha='center', transform=axes[0, j].transAxes)
            continue
        span = int(window / ts)
        error = np.abs(reference.measured - reference.predicted)
        centre = int(np.argmax(np.convolve(error, np.ones(span), mode='same')))
        lo, hi = max(0, centre - span // 2), centre + span // 2
        unit = SIGNAL_UNITS.get(signal, '')
        top, bottom = axes[0, j], axes[1, j]
        shown = (reference.index >= reference.index[lo]) & (reference.index < reference.index[min(hi, len(error) - 1)])
        t = recording.start_time + reference.index[shown] * ts
        top.plot(t, reference.measured[shown], 'k', lw=1.2, label='measured')
        for (model, pred), colour in zip(predictions.items(), colours):
            p = pred[signal]
            mask = np.isin(p.index, reference.index[shown])
            label = f'{Path(model).stem} (fit {_percent(p.nrmse)})'
            top.plot(recording.start_time + p.index[mask] * ts, p.predicted[mask], color=colour, lw=1, label=label)
            bottom.plot(recording.start_time + p.index[mask] * ts, (p.measured - p.predicted)[mask], color=colour,
                        lw=1, label=Path(model).stem)
        top.set_title(f'{signal}: free run from the first sample' if reference.horizon >= len(recording) - 1 else
                      f'{signal}: {reference.horizon}-step-ahead prediction ({reference.horizon * ts * 1e3:g} ms)')
        top.legend(fontsize=8)
        bottom.axhline(0.0, color='0.6', lw=0.8)
        bottom.legend(fontsize=8)
        si_axis(top, 'y', signal, unit)
        si_axis(bottom, 'y', 'measured - predicted', unit)
        si_axis(bottom, 'x', 'time', 's', time_origin(t[0], t[-1]) if t.size else 0.0)
    figure.suptitle(f'{Path(recording.source).name or "record"}: measured and predicted')
    figure.tight_layout()
    figure.savefig(path, dpi=90, format='png')
    plt.close(figure)
