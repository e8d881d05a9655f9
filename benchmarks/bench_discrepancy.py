"""The model-discrepancy workflow beside the identification of the same record (issue target: within 3 times its
wall time), on 3 s of 10 kHz closed-loop data with a hidden Coulomb friction and on 10 s of clean data; and the
model file it writes identified again on the friction record (`emla identify --model-file`)."""
import dataclasses
import time

from benchmarks.harness import Row
from emla_bench import scenarios
from emla_core.physics import CoulombFriction
from emla_identification.discrepancy import diagnose
from emla_identification.greybox import identify
from emla_identification.model import from_fit, identified_structure

RATIO = 3.0   # the workflow's wall time within this many times identify's on the same record


def _timed(function):
    start, cpu = time.perf_counter(), time.process_time()
    value = function()
    return value, time.perf_counter() - start, time.process_time() - cpu


def _record(effects, duration):
    scenario = dataclasses.replace(scenarios.get('default'), effects=effects, cases={'adaptive': (True, True)})
    return scenario.run_case('adaptive', duration=duration).recording


def _side_by_side(label, recording):
    """(rows of identify and the workflow on `recording`, timed one after the other; the Diagnosis)."""
    identify(recording, points=1)   # compile and warm caches outside the timing
    _, identify_wall, identify_cpu = _timed(lambda: identify(recording, points=1))
    diagnose(recording)
    diagnosis, wall, cpu = _timed(lambda: diagnose(recording))
    result = diagnosis.to_dict()    # the JSON: verdict, effects, disagreement located
    return [Row(f'identify, {label}', identify_wall, 's', note=f'{identify_cpu:.2f} s CPU'),
            Row(f'discrepancy workflow, {label} (JSON, no report)', wall, 's', baseline=identify_wall,
                baseline_name='identify on the same record', target=f'<= {RATIO:g} x identify',
                met=wall <= RATIO * identify_wall,
                note=f'{wall / identify_wall:.1f} x identify; {cpu:.2f} s CPU; {result["verdict"]}, named '
                     f'{result["missing_effect"]!r}')], diagnosis


def run():
    recording = _record((CoulombFriction(coulomb_force=1.0),), 3.0)
    rows, diagnosis = _side_by_side(f'3 s of 10 kHz data, hidden {CoulombFriction.name}', recording)
    rows += _side_by_side('10 s of clean 10 kHz data', _record((), 10.0))[0]
    names = [stage.assessment.name for stage in diagnosis.stages]
    wall = rows[1].value
    model = from_fit(diagnosis.final, names, 'bench', 'bench', diagnosis.final_std)
    (identified, _), model_wall, model_cpu = _timed(lambda: identified_structure(model, recording, 'bench', 'bench'))
    return rows + [
        Row(f'identify --model-file on the friction record ({len(names)} effect(s): {", ".join(names)})',
            model_wall, 's', baseline=wall, baseline_name='the discrepancy workflow', target='<= the workflow',
            met=model_wall <= wall, note=f'{model_cpu:.2f} s CPU; R {identified["parameters"]["resistance"]:.4g} ohm')]
