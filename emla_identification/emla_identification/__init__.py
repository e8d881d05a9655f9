"""emla_identification: identify an electromagnetic linear actuator's parameters and find what its model misses.

Entry points (each takes a Recording, a CSV file or bag path, or numpy arrays, unless noted):
    identify(data)            R, L, Km, m, B, Fl with one-sigma uncertainties from a whole record (grey box)
    identify_solenoid(data)   a solenoid's R, L0, a, g0, m, B, k, F0 with one-sigma uncertainties (offline)
    OnlineIdentifier          the same, frame by frame, with forgetting (the identifier node, adaptive control)
    identify_chunks(parts)    a record too long for memory, part by part (e.g. emla_core.bag.iter_chunks)
    identify_arx(u, y, ...)   a black-box ARX model by recursive least squares (arrays)
    RecursiveLeastSquares     the RLS estimator itself (forgetting, instruments, covariance guard)
    diagnose(data)            the model-discrepancy workflow: the missing effect, named, added, gap shown
    register_candidate(...)   add your own effect to the discrepancy workflow's library
    trend(paths)              many recordings (a fleet, a long run) identified on Dask: parameter trends, changes

Examples
--------
>>> from emla_identification import identify
>>> result = identify('run.csv')                         # doctest: +SKIP
>>> result.parameters['resistance'], result.std['resistance']  # doctest: +SKIP
(4.0001, 0.0003)
"""
from emla_core.exports import lazy_exports

_EXPORTS = {  # name -> the module that holds it
    'identify': 'greybox', 'GreyBoxResult': 'greybox',
    'identify_solenoid': 'solenoid', 'SolenoidResult': 'solenoid',
    'OnlineIdentifier': 'online',
    'identify_chunks': 'streaming',
    'identify_arx': 'arx', 'ArxModel': 'arx', 'ArxEstimator': 'arx',
    'RecursiveLeastSquares': 'rls',
    'diagnose': 'discrepancy', 'Diagnosis': 'discrepancy', 'register_candidate': 'discrepancy',
    'Candidate': 'discrepancy', 'write_report': 'discrepancy',
    'trend': 'fleet', 'Trend': 'fleet',
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
