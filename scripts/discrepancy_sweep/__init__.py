"""The discrepancy workflow's real accuracy: diagnose many independent records with hidden effects, judge each."""
from .cases import ACTUATORS, BENCH, DURATION, LEVELS, LIBRARY, NOMINAL, OUTSIDE, RATES, make_case
from .classify import ACCEPTED, FIVE, OUTCOMES, counted, expected, numeric_problems, outcome, right_model, success
from .report import write_headline, write_report
from .run import read_results, run_case, simulate, substeps, sweep
from .snapshot import code_snapshot, use_code

__all__ = ['ACCEPTED', 'ACTUATORS', 'BENCH', 'DURATION', 'FIVE', 'LEVELS', 'LIBRARY', 'NOMINAL', 'OUTCOMES',
           'OUTSIDE', 'RATES', 'code_snapshot', 'counted', 'expected', 'make_case', 'main', 'numeric_problems',
           'outcome', 'read_results', 'right_model', 'run_case', 'simulate', 'substeps', 'success', 'sweep',
           'use_code', 'write_headline', 'write_report']


def main(argv=None):
    """The command (`python -m scripts.discrepancy_sweep`); see its __main__ module."""
    from .__main__ import main as command
    return command(argv)
