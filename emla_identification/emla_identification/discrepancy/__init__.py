"""Model-discrepancy workflow: which effect is the two-equation EMLA model missing?

    from emla_identification.discrepancy import diagnose
    diagnosis = diagnose(recording)          # a Recording of t, voltage, current, position (or force, position)
    diagnosis.to_dict()                      # the `emla discrepancy` JSON
    write_report(diagnosis, 'out/')          # Markdown + PNG

Modules: data (signals analysed), candidates (the effect library and its registry), fit (augmented
regressions, held-out blocks), simulate (k-step-ahead prediction of each subsystem), residuals (whiteness,
cross-correlation, binning), workflow (rank, add, re-identify, gap), report (Markdown + PNG).
The bundled example bag bags/example_discrepancy is written by tests/test_discrepancy_cli.py.
"""
from .candidates import CANDIDATES, Candidate, register_candidate
from .diagnosis import Diagnosis
from .report import write_report
from .workflow import diagnose

__all__ = ['CANDIDATES', 'Candidate', 'Diagnosis', 'diagnose', 'register_candidate', 'write_report']
