"""What a solenoid's model lacks (`emla discrepancy --actuator solenoid`, docs/physics.md §9.5): is the solenoid
model (emla_identification.solenoid) adequate, and if not, which of its candidate effects explains what is left?

The nominal model is identified and each equation's fit judged against its sensor-noise floor (the fit block of
the identification: low-band residual power over the noise's, adequate up to noise_floor.MAX_RATIO). Each
candidate (CANDIDATES) is identify_solenoid with one effect added, tried on every record:
- friction of the armature, Fc tanh(v / v_s) (its `friction`: v along the armature's path between the samples,
  v_s searched, 0 for a dry Fc sign(v)), judged on the force balance: a weak friction hides in the damping and the
  preload (0.05 N left the force balance within its floor, B and F0 7 and 8 sigmas off);
- iron saturation, I = psi / L(x) + c psi^3 (its `saturation`), judged on the electrical equation: a weak one
  hides in the inductance curve and biases the mechanics through the force;
- residual magnetism, I = psi / L(x) - I_r (its `remanence`), judged on the force balance, where it shows most
  (the force goes with (I + I_r)^2; the voltage only through the back-EMF I_r L'(x) v);
- eddy currents, I = psi / L(x) + G dpsi/dt (its `eddy`), judged on the electrical equation: the current jumps
  with the voltage and the flux lags it.
A candidate qualifies when it is significant, its strength at least MIN_T of its sigmas above zero (a friction
opposes the motion, the iron's saturation raises the current, its remanence lowers it), and either the nominal model
fitted its equation or it removes at least MIN_SHARE of that equation's excess over its noise floor. The ones that
qualify are then fitted together, and the least significant of those under MIN_T sigmas in that fit dropped until
none is (an effect can stand in for another: a remanence for a saturation, 22 sigma alone and 0 with it); the rest
are named and the verdict is `explained` if both equations fit with them, else `unexplained` with them named (and
with none named, located on the signals the residual depends on). The gap is the NRMSE of each signal's free run
under the measured voltage (solenoid_predict.py), before and after. Not in the library: the iron's hysteresis.
"""
from dataclasses import dataclass
from typing import Any

import numpy as np

from emla_core.data import as_recording

from .solenoid import SolenoidResult, identify_solenoid
from .solenoid_predict import predict_solenoid

MIN_T = 3.0        # sigmas of a candidate's strength from zero for it to be significant
MIN_SHARE = 0.5    # of its equation's excess power over its noise floor a candidate must remove


@dataclass(frozen=True)
class Candidate:
    """An effect the solenoid's discrepancy tries: identify_solenoid's `option`, the `parameter` that is its
    strength (in `unit`), the `equation` it is judged on."""

    name: str
    option: str
    parameter: str
    unit: str
    equation: str


CANDIDATES = (Candidate('friction', 'friction', 'coulomb_force', 'N', 'mechanical'),
              Candidate('iron_saturation', 'saturation', 'saturation_coefficient', 'A/Wb^3', 'electrical'),
              Candidate('residual_magnetism', 'remanence', 'remanence_current', 'A', 'mechanical'),
              Candidate('eddy_currents', 'eddy', 'eddy_conductance', 'S', 'electrical'))


@dataclass
class SolenoidDiagnosis:
    """The solenoid model on a record (`nominal`), each candidate fitted with it (`tried`: {name: SolenoidResult}),
    the candidates named (`names`), the model with them (`final`) and the gaps."""

    nominal: SolenoidResult
    tried: dict
    names: list | None = None
    final: SolenoidResult | None = None
    gaps: dict | None = None      # 'before' / 'after': {signal: NRMSE of the free run}

    def share(self, candidate: Candidate) -> float:
        """The share of its equation's excess power over the floor that the candidate removes, in [-1, 1]."""
        before, after = (max(r.fit[candidate.equation].ratio - 1.0, 0.0)
                         for r in (self.nominal, self.tried[candidate.name]))
        largest = max(before, after)
        return float((before - after) / largest) if largest > 0 else 0.0

    def significant(self, candidate: Candidate) -> bool:
        result = self.tried[candidate.name]
        value, std = result.parameters[candidate.parameter], result.std[candidate.parameter]
        return bool(value > 0 and value >= MIN_T * std)

    def qualifies(self, candidate: Candidate) -> bool:
        """Significant alone, and the nominal model fitted its equation or it removes MIN_SHARE of its excess."""
        return self.significant(candidate) and (self.nominal.fit[candidate.equation].adequate
                                                or self.share(candidate) >= MIN_SHARE)

    @property
    def verdict(self) -> str:
        if not self.names:
            return 'adequate' if all(f.adequate for f in self.nominal.fit.values()) else 'unexplained'
        assert self.final is not None   # diagnose_solenoid sets it with the names
        return 'explained' if all(f.adequate for f in self.final.fit.values()) else 'unexplained'

    def to_dict(self) -> dict:
        """The `emla discrepancy --actuator solenoid` JSON (the moving coil's keys where they apply)."""
        verdict = self.verdict
        final, names, gaps = self.final, self.names, self.gaps
        assert final is not None and names is not None and gaps is not None, 'diagnose_solenoid sets them'
        effects: list[dict[str, Any]] = []
        candidates = []
        for c in CANDIDATES:
            tried, share = self.tried[c.name], self.share(c)
            setting = (f' (friction_speed {tried.settings["friction_speed"]:.3g} m/s)'
                       if 'friction_speed' in tried.settings else '')
            evidence = (f'{c.parameter} = {tried.parameters[c.parameter]:.4g} +- {tried.std[c.parameter]:.2g} '
                        f'{c.unit}{setting}; the {c.equation} equation from {self.nominal.fit[c.equation].ratio:.3g} '
                        f'to {tried.fit[c.equation].ratio:.3g} times its noise floor (power), {100 * share:.0f} % of '
                        f'its excess removed')
            candidates.append({'effect': c.name, 'score': round(share, 6), 'significant': self.significant(c),
                               'evidence': evidence})
            if c in names:
                effects.append({'effect': c.name, 'parameters': {c.parameter: final.parameters[c.parameter]},
                                'std': {c.parameter: final.std[c.parameter]},
                                'settings': dict(tried.settings), 'share': round(share, 4),
                                'gap_after': dict(gaps['after'])})
        return {'actuator': 'solenoid', 'verdict': verdict,
                'missing_effect': effects[0]['effect'] if effects else ('none' if verdict == 'adequate'
                                                                        else 'unexplained'),
                'effects': effects,
                'disagreement': {name: fit.to_dict() for name, fit in final.fit.items()},
                'disagreement_nominal': {name: fit.to_dict() for name, fit in self.nominal.fit.items()},
                'candidates': candidates, 'gap_before': dict(gaps['before']),
                'gap_after': dict(gaps['after']),
                'added_parameters': {k: v for e in effects for k, v in e['parameters'].items()},
                'nominal_parameters': dict(self.nominal.parameters),
                'reidentified_parameters': dict(final.parameters),
                'reidentified_parameters_std': dict(final.std), 'warnings': final.warnings()}


def diagnose_solenoid(data) -> SolenoidDiagnosis:
    """Find what the solenoid model lacks in a record of a solenoid's voltage, current and position.

    Parameters
    ----------
    data : Recording, str or Path
        The record (or a CSV file or bag to load).

    Returns
    -------
    SolenoidDiagnosis
        `verdict` ('adequate', 'explained', 'unexplained'); `to_dict()` gives the JSON.

    Raises
    ------
    InputError
        Data the solenoid model cannot be identified from (identify_solenoid's reasons).

    Examples
    --------
    >>> diagnosis = diagnose_solenoid('valve.csv')           # doctest: +SKIP
    >>> diagnosis.verdict, diagnosis.to_dict()['missing_effect']   # doctest: +SKIP
    ('explained', 'friction')
    """
    recording = as_recording(data)
    nominal = identify_solenoid(recording)
    diagnosis = SolenoidDiagnosis(nominal, {c.name: identify_solenoid(recording, **{c.option: True})
                                            for c in CANDIDATES})
    named = [c for c in CANDIDATES if diagnosis.qualifies(c)]
    final = nominal if not named else diagnosis.tried[named[0].name]
    while len(named) > 1:   # together: the least significant under MIN_T sigmas out, until none is
        final = identify_solenoid(recording, **{c.option: True for c in named})
        t = {c: final.parameters[c.parameter] / final.std[c.parameter] for c in named}
        weakest = min(named, key=t.__getitem__)
        if t[weakest] >= MIN_T:
            break
        named.remove(weakest)
        final = diagnosis.tried[named[0].name]
    diagnosis.names, diagnosis.final = named, final
    before = _gaps(nominal, recording)
    diagnosis.gaps = {'before': before, 'after': _gaps(diagnosis.final, recording) if named else dict(before)}
    return diagnosis


def _gaps(result, recording):
    """{signal: NRMSE} of the result's free run under the record's voltage (with its effects)."""
    return {name: round(p.nrmse, 6) if np.isfinite(p.nrmse) else None
            for name, p in predict_solenoid(result.solenoid(), recording).items()}
