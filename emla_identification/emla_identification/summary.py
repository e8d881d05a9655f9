"""A result as a person reads it: the parameters with their one-sigma and relative sigma, each equation's fit
verdict, the notes and the warnings, as a plain-text table (statsmodels' summary(), MATLAB's present)."""
import math

from emla_core.parameters import PARAMETER_UNITS
from emla_core.physics import EFFECTS

from .noise_floor import MAX_RATIO


def unit_of(name):
    """The SI unit of a nominal or an effect's parameter ('' if unknown)."""
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    for effect in EFFECTS.values():
        for parameter in effect.parameters:
            if parameter.name == name:
                return parameter.unit
    return ''


def summary_text(title, parameters, std, fit, notes=(), warnings=()):
    """The table of an identification: `parameters` and `std` ({name: value}, SI), `fit` ({equation: the
    fit block's dict as in the JSON}), `notes` and `warnings` (lines)."""
    width = max([len(name) for name in parameters] + [9])
    lines = [title, '', f'{"parameter":<{width}}  {"value":>12}  {"one-sigma":>10}  {"sigma/|value|":>13}  unit',
             '-' * (width + 47)]
    for name, value in parameters.items():
        sigma = std.get(name, math.nan)
        relative = sigma / abs(value) if value else math.inf
        shown = f'{100 * relative:12.3g} %' if math.isfinite(relative) else f'{"-":>13}'
        lines.append(f'{name:<{width}}  {value:12.6g}  {sigma:10.3g}  {shown}  {unit_of(name)}')
    if fit:
        lines += ['', f'fit (low-band residual power over the sensor noise\'s; above {MAX_RATIO:g} it does not fit):']
        for equation, block in fit.items():
            verdict = 'adequate' if block['adequate'] else 'DOES NOT FIT'
            lines.append(f'  {equation:<10}  ratio {block["ratio"]:8.3g}   rms {block["rms"]:.3g} {block["unit"]}'
                         f'   {verdict}')
    for heading, items in (('notes', notes), ('warnings', warnings)):
        if items:
            lines += ['', f'{heading}:'] + [f'  - {item}' for item in items]
    return '\n'.join(lines) + '\n'
