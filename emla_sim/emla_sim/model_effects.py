"""A model file's effects (emla_core.model_file, in the discrepancy workflow's terms) as the plant's effects,
so that `emla simulate` and `emla launch` run the model that was identified (a digital twin)."""
from emla_core.errors import InputError

from .effects import CoulombFriction, ForceConstantVariation, InductanceSaturation, ReturnSpring


def _spring(effect, model):
    return ReturnSpring(stiffness=effect.values()['spring_stiffness'],
                        rest_position=float(effect.settings.get('center') or 0.0))


def _saturation(effect, model):
    # L0 + L2 I^2 / (1 + (I/I_s)^2) with L2 = -L0 / I_s^2 is the plant's L0 / (1 + (I/I_s)^2)
    quadratic = effect.values()['inductance_quadratic']
    if quadratic >= 0:
        raise InputError(f'inductance_saturation with inductance_quadratic {quadratic:g} >= 0 is no saturation')
    return InductanceSaturation(saturation_current=(model.values()['inductance'] / -quadratic) ** 0.5)


def _force_constant(effect, model):
    values = effect.values()
    km = model.values()['emf_constant']
    if abs(values.get('emf_constant_slope', 0.0)) > 1e-9 * km:
        raise InputError('force_constant_variation: the plant simulates a curvature of Km(x) only, not its slope '
                         f'({values["emf_constant_slope"]:g} N/(A m))')
    return ForceConstantVariation(curvature=-values['emf_constant_curvature'] / km,
                                  center=float(effect.settings.get('center') or 0.0))


# candidate name -> the plant effect that simulates it
SIMULATED = {
    'coulomb_friction': lambda effect, model: CoulombFriction(force=effect.values()['coulomb_force']),
    'return_spring': _spring,
    'inductance_saturation': _saturation,
    'force_constant_variation': _force_constant,
}


def plant_effects(model, source='model file'):
    """The plant effects of `model`'s effects; InputError naming one the plant cannot simulate."""
    out = []
    for effect in model.effects:
        if effect.candidate not in SIMULATED:
            raise InputError(f'{source}: the plant cannot simulate {effect.effect} yet (it simulates '
                             f'{", ".join(SIMULATED)})')
        out.append(SIMULATED[effect.candidate](effect, model))
    return tuple(out)
