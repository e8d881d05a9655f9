"""`emla discrepancy`: the effect a model lacks named and added, the gap shown shrinking (the workflow is
emla_identification.discrepancy; what the command does for its user is description(), its help)."""
import contextlib
import sys
from pathlib import Path

from emla_core.errors import InputError
from emla_core.parameters import FAMILIES

from .inputs import DATA_HELP, add_data_arguments, load_data, understood, unknown_figures, warn
from .output import REPORT, add_force_argument, check_outputs, emit_json, json_text

HELP = 'Find what the model is missing: name the effect, add it, show the gap shrink.'


def description():
    return """\
Find what the actuator model is missing: name the effect, add it, show the gap shrink.

Fits the nominal model (u = R I + L dI/dt + Km v, m dv/dt = Km I - B v - Fl) to DATA, predicts each
subsystem from its measured inputs (current 5 L/R ahead, position 10 ms ahead), and ranks the candidate
effects by the share of the held-out prediction error each removes: every effect of the physics layer
(emla_core.physics; their forms and parameters are in docs/physics.md sections 6 and 7) and any you add
from Python with register_candidate.
The best one is named only when it is significant; it is added, the model re-identified and the gap
(NRMSE per signal) reported before and after; then a second effect is looked for. Nominal estimates that
point to a slip in units or signs (a current in mA, a time in ms, a sensor mounted the other way) are
warned about on stderr with the flag that fixes it, and listed under "warnings" in the JSON.

The JSON goes to stdout unless --json is given.

""" + DATA_HELP


def add_arguments(parser):
    parser.add_argument('data', metavar='DATA', help='CSV or MAT file, rosbag2 directory or .mcap file')
    parser.add_argument('--json', metavar='FILE', help='write the result here instead of stdout')
    parser.add_argument('--report', metavar='DIR',
                        help='write report.md with PNG figures (and diagnosis.json) into DIR (new or empty; '
                             'with --force it may hold a previous report emla wrote, which is replaced)')
    parser.add_argument('--candidates', metavar='NAMES',
                        help='comma-separated candidate effects to consider (default: all registered)')
    parser.add_argument('--model-out', metavar='M.yaml',
                        help='write the final model (nominal parameters and the effects named) as a model file')
    parser.add_argument('--actuator', default='moving_coil', metavar='FAMILY',
                        help='moving_coil (default) or solenoid (the solenoid model, with a friction of its armature, '
                        'the iron\'s saturation and its residual magnetism as the candidates: docs/physics.md 9.5)')
    add_force_argument(parser)
    add_data_arguments(parser)


def run(args):
    from emla_core.bag.report import read_warnings
    from emla_identification.discrepancy import CANDIDATES, diagnose

    if args.actuator not in FAMILIES:
        raise InputError(f'--actuator {args.actuator!r}: choose one of {", ".join(FAMILIES)}')
    if args.actuator == 'solenoid':
        return _solenoid(args)
    names = None
    if args.candidates is not None:   # given empty ('' or ','): refused below, not taken for all
        names = list(dict.fromkeys(n.strip() for n in args.candidates.split(',') if n.strip()))   # each once
        unknown = [n for n in names if n not in CANDIDATES]
        if unknown or not names:
            raise InputError(f'--candidates {args.candidates!r}: unknown effect(s) '
                             f'{", ".join(unknown) or "(none given)"}; known: {", ".join(CANDIDATES)}')
    check_outputs({'--json': args.json, '--model-out': args.model_out}, [args.data], args.force,
                  {'--report': (args.report, REPORT)})
    with read_warnings() as lost:  # a bag's skipped chunks and the data they cost, for the JSON too
        recording = load_data(args)
    with progress_bar(sys.stderr) as progress:
        diagnosis = diagnose(recording, names, progress=progress)
    result = {**diagnosis.to_dict(), **understood(recording, 'discrepancy')}
    hints = []
    if diagnosis.verdict == 'unexplained' and not diagnosis.warnings:   # another actuator family's record?
        from emla_identification.solenoid import solenoid_hint
        hints = [hint for hint in (solenoid_hint(recording),) if hint]
    result['warnings'] = lost + warn(hints + diagnosis.warnings + unknown_figures(result), 'discrepancy')
    files = []
    if args.report:
        files.append((args.report, lambda temporary: _write_report(diagnosis, temporary, json_text(result)), REPORT))
    if args.model_out:
        from emla_core.model_file import write
        from emla_identification.model import from_fit
        names = [stage.assessment.name for stage in diagnosis.stages]
        files.append((args.model_out, lambda temporary: write(
            from_fit(diagnosis.final, names, args.data, 'emla ' + ' '.join(sys.argv[1:]), diagnosis.final_std),
            temporary)))
    emit_json(result, args.json, files)
    return 0


@contextlib.contextmanager
def progress_bar(stream):
    """diagnose's `progress` as a bar on `stream` when it is a terminal (tqdm: the stage, its candidates done of
    all, the one being worked on, the time taken), None elsewhere: nothing goes into a log or a pipe."""
    if not stream.isatty():
        yield None
        return
    from tqdm import tqdm
    with tqdm(file=stream, leave=False, bar_format='{desc}: {n}/{total} {postfix} [{elapsed}]') as bar:
        def progress(stage, done, total, name):
            bar.total, bar.n = total, done
            bar.set_description_str(stage, refresh=False)
            bar.set_postfix_str(name, refresh=False)
            bar.refresh()
        yield progress


def _solenoid(args):
    """`emla discrepancy --actuator solenoid`: emla_identification.solenoid_discrepancy's JSON."""
    from emla_core.bag.report import read_warnings
    from emla_identification.solenoid_discrepancy import diagnose_solenoid
    given = [flag for flag, value in (('--candidates', args.candidates), ('--report', args.report))
             if value is not None]
    if given:
        raise InputError(f'{", ".join(given)} applies to the moving coil, not yet to --actuator solenoid')
    check_outputs({'--json': args.json, '--model-out': args.model_out}, [args.data], args.force)
    with read_warnings() as lost:
        recording = load_data(args)
    diagnosis = diagnose_solenoid(recording)
    result = {**diagnosis.to_dict(), **understood(recording, 'discrepancy')}
    result['warnings'] = lost + warn(result['warnings'] + unknown_figures(result), 'discrepancy')
    files = []
    if args.model_out:   # the solenoid with the effects named
        from emla_core.model_file import write
        model = diagnosis.final.model_file(args.data, 'emla ' + ' '.join(sys.argv[1:]))
        files.append((args.model_out, lambda temporary: write(model, temporary)))
    emit_json(result, args.json, files)
    return 0


def _write_report(diagnosis, directory, text):
    """The report (report.md, its figures and diagnosis.json) in the new directory `directory` (and its parents)."""
    from emla_identification.discrepancy.report import write_report

    Path(directory).mkdir(parents=True)
    write_report(diagnosis, directory, text)
