"""`emla scenario`: a closed-loop adaptive-control comparison of emla_bench.scenarios, its JSON and plot (the
user's help is description())."""
import textwrap

from .output import add_force_argument, check_outputs, emit_json

HELP = 'Run a closed-loop adaptive-control comparison (nominal / changed fixed / changed adaptive).'


def description():
    from emla_bench.scenarios import catalogue
    return f"""\
Run a closed-loop adaptive-control comparison in this process and report the tracking of each case:
  nominal           plant unchanged, controller with the exact parameters
  changed_fixed     plant changed, controller not updated
  changed_adaptive  plant changed, controller updated from the online identifier
Scenarios:
{catalogue(cases=True)}
Prints {{"scenario": NAME, "cases": {{CASE: {{rms_tracking_error, max_overshoot, settling_time, peak_current}}}}}}
in SI units (or writes it with --json); --plot draws position, tracking error and current of each case over
the last cycle, as Figures 6-7 of the EMLA paper.
"""


def add_arguments(parser):
    parser.add_argument('name', metavar='NAME', help='scenario name (see above)')
    parser.add_argument('--json', metavar='FILE', help='write the metrics here instead of printing them')
    parser.add_argument('--plot', metavar='FILE.png', help='write a plot of the cases')
    add_force_argument(parser)


def run(args):
    from emla_bench import scenarios  # numba and the identifier load only when a scenario runs

    scenario = scenarios.get(args.name)
    check_outputs({'--json': args.json, '--plot': args.plot}, force=args.force)
    result = scenarios.run_scenario(scenario)
    emit_json(result.to_json(), args.json, [(args.plot, lambda tmp: plot(result, tmp))])
    return 0


def plot(result, path):
    """PNG of the last whole cycle of each case: position with the reference, tracking error, coil current."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    reference = result.scenario.reference
    fig, (ax_x, ax_e, ax_i) = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    for case, run in result.runs.items():
        t = run.recording.time
        end = np.floor((t[-1] + run.recording.sample_period) / reference.period + 1e-9) * reference.period
        cycle = (t >= end - reference.period) & (t < end)
        tc = 1e3 * (t[cycle] - (end - reference.period))
        x = run.truth['position'][cycle]
        ax_x.plot(tc, 1e3 * x, label=case.replace('_', ' '))
        ax_e.plot(tc, 1e6 * (x - run.recording.signals['reference'][cycle]), label=case.replace('_', ' '))
        ax_i.plot(tc, run.truth['current'][cycle], label=case.replace('_', ' '))
    ax_x.plot(tc, 1e3 * run.recording.signals['reference'][cycle], 'k:', label='reference')
    ax_x.set_ylabel('position [mm]')
    ax_e.set_ylabel('position - reference [um]')
    ax_i.set_ylabel('coil current [A]')
    ax_i.set_xlabel(f'time within the last {1e3 * reference.period:g} ms cycle [ms]')
    for ax in (ax_x, ax_e, ax_i):
        ax.ticklabel_format(axis='both', style='plain', useOffset=False)   # the values are scaled already
        ax.grid(True, alpha=0.3)
        ax.legend(loc='upper right', fontsize=8)
    fig.suptitle(textwrap.fill(f'{result.scenario.name}: {result.scenario.description}', 90), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format='png')
    plt.close(fig)
