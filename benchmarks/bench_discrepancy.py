"""The model-discrepancy workflow on 3 s of 10 kHz closed-loop data with a hidden effect, and the model file it
writes identified again on the same record (`emla identify --model-file`)."""
import dataclasses
import time

from benchmarks.harness import Row
from emla_bench import scenarios
from emla_core.physics import CoulombFriction
from emla_identification.discrepancy import diagnose
from emla_identification.model import from_fit, identified_structure


def _timed(function):
    start, cpu = time.perf_counter(), time.process_time()
    value = function()
    return value, time.perf_counter() - start, time.process_time() - cpu


def run():
    scenario = dataclasses.replace(scenarios.get('default'), effects=(CoulombFriction(coulomb_force=1.0),),
                                   cases={'adaptive': (True, True)})
    recording = scenario.run_case('adaptive', duration=3.0).recording
    diagnose(recording)           # compile and warm caches outside the timing
    diagnosis, wall, cpu = _timed(lambda: diagnose(recording))
    result = diagnosis.to_dict()  # the JSON: verdict, effects, disagreement located
    names = [e['effect'] for e in result['effects']]
    model = from_fit(diagnosis.final, names, 'bench', 'bench', diagnosis.final_std)
    (identified, _), model_wall, model_cpu = _timed(lambda: identified_structure(model, recording, 'bench', 'bench'))
    return [Row('discrepancy workflow, 3 s of 10 kHz data (JSON, no report)', wall, 's', target='<= 10 s',
                met=wall <= 10,
                note=f'{cpu:.2f} s CPU; {result["verdict"]}, named {result["missing_effect"]!r} '
                     f'(hidden: {CoulombFriction.name})'),
            Row(f'identify --model-file on the same record ({len(names)} effect(s): {", ".join(names)})',
                model_wall, 's', baseline=wall, baseline_name='the discrepancy workflow', target='<= the workflow',
                met=model_wall <= wall,
                note=f'{model_cpu:.2f} s CPU; R {identified["parameters"]["resistance"]:.4g} ohm')]
