"""What a solenoid's model lacks (`emla discrepancy --actuator solenoid`, docs/physics.md §9.5): is the solenoid
model (emla_identification.solenoid) adequate, and if not, does a friction of the armature explain what is left?

The nominal model is identified and each equation's fit judged against its sensor-noise floor (the fit block of
the identification: low-band residual power over the noise's, adequate up to noise_floor.MAX_RATIO). The candidate
is a friction Fc tanh(v / v_s) of the armature (identify_solenoid's `friction`: v along the armature's path between
the samples, v_s searched, 0 for a dry Fc sign(v)), tried on every record: a weak friction hides in the damping and
the preload (0.05 N left the force balance within its floor, B and F0 7 and 8 sigmas off). It is named when it is
significant, Fc at least MIN_T of its sigmas above zero (a friction opposes the motion), and either the nominal
force balance fitted or the friction removes at least MIN_SHARE of its excess over its noise floor; the verdict is
then `explained` if both equations fit with it, else `unexplained` with the friction named. A misfit of the
electrical equation has no candidate yet (iron saturation, eddy currents and residual magnetism are not in the
family's library): it is reported `unexplained`, located on the signals its residual depends on. The gap is the
NRMSE of each signal's free run under the measured voltage (solenoid_predict.py), before and after.
"""
from dataclasses import dataclass

import numpy as np

from emla_core.data import as_recording

from .solenoid import SolenoidResult, identify_solenoid
from .solenoid_predict import predict_solenoid

MIN_T = 3.0        # sigmas of Fc from zero for the friction to be significant
MIN_SHARE = 0.5    # of the force balance's excess power over its noise floor the friction must remove


@dataclass
class SolenoidDiagnosis:
    """The solenoid model on a record (`nominal`), the friction fitted with it (`friction`), and the verdict."""

    nominal: SolenoidResult
    friction: SolenoidResult | None
    gaps: dict             # 'before' / 'after': {signal: NRMSE of the free run}

    @property
    def share(self) -> float:
        """The share of the force balance's excess power over its floor that the friction removes, in [-1, 1]."""
        if self.friction is None:
            return 0.0
        before, after = (max(r.fit['mechanical'].ratio - 1.0, 0.0) for r in (self.nominal, self.friction))
        largest = max(before, after)
        return float((before - after) / largest) if largest > 0 else 0.0

    @property
    def significant(self) -> bool:
        if self.friction is None:
            return False
        value, std = self.friction.parameters['coulomb_force'], self.friction.std['coulomb_force']
        return bool(value > 0 and value >= MIN_T * std)

    @property
    def named(self) -> bool:
        return self.significant and (self.nominal.fit['mechanical'].adequate or self.share >= MIN_SHARE)

    @property
    def final(self) -> SolenoidResult:
        return self.friction if self.named else self.nominal

    @property
    def verdict(self) -> str:
        if not self.named and all(f.adequate for f in self.nominal.fit.values()):
            return 'adequate'
        return 'explained' if self.named and all(f.adequate for f in self.final.fit.values()) else 'unexplained'

    def to_dict(self) -> dict:
        """The `emla discrepancy --actuator solenoid` JSON (the moving coil's keys where they apply)."""
        verdict = self.verdict
        effects, candidates = [], []
        if self.friction is not None:
            f = self.friction
            parameters = {'coulomb_force': f.parameters['coulomb_force']}
            evidence = (f'coulomb_force = {f.parameters["coulomb_force"]:.4g} +- {f.std["coulomb_force"]:.2g} N '
                        f'(friction_speed {f.settings["friction_speed"]:.3g} m/s); the force balance from '
                        f'{self.nominal.fit["mechanical"].ratio:.3g} to {f.fit["mechanical"].ratio:.3g} times its '
                        f'noise floor (power), {100 * self.share:.0f} % of its excess removed')
            candidates.append({'effect': 'friction', 'score': round(self.share, 6),
                               'significant': self.significant, 'evidence': evidence})
            if self.named:
                effects.append({'effect': 'friction', 'parameters': parameters,
                                'std': {'coulomb_force': f.std['coulomb_force']},
                                'settings': dict(f.settings), 'share': round(self.share, 4),
                                'gap_after': dict(self.gaps['after'])})
        return {'actuator': 'solenoid', 'verdict': verdict,
                'missing_effect': effects[0]['effect'] if effects else ('none' if verdict == 'adequate'
                                                                        else 'unexplained'),
                'effects': effects,
                'disagreement': {name: fit.to_dict() for name, fit in self.final.fit.items()},
                'disagreement_nominal': {name: fit.to_dict() for name, fit in self.nominal.fit.items()},
                'candidates': candidates, 'gap_before': dict(self.gaps['before']),
                'gap_after': dict(self.gaps['after']),
                'added_parameters': {k: v for e in effects for k, v in e['parameters'].items()},
                'nominal_parameters': dict(self.nominal.parameters),
                'reidentified_parameters': dict(self.final.parameters),
                'reidentified_parameters_std': dict(self.final.std), 'warnings': self.final.warnings()}


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
    friction = identify_solenoid(recording, friction=True)
    diagnosis = SolenoidDiagnosis(nominal, friction, {})
    diagnosis.gaps['before'] = _gaps(nominal, recording)
    diagnosis.gaps['after'] = _gaps(diagnosis.final, recording) if diagnosis.named else dict(diagnosis.gaps['before'])
    return diagnosis


def _gaps(result, recording):
    """{signal: NRMSE} of the result's free run under the record's voltage (a friction with its v_s)."""
    return {name: round(p.nrmse, 6) if np.isfinite(p.nrmse) else None
            for name, p in predict_solenoid(result.solenoid(), recording).items()}
