"""emla_control: adaptive inverse-system position control of an electromagnetic linear actuator.

    InverseSystemController(params)   the inverse-system law with state feedback, an observer, and a guard
                                      on the identified parameters it is offered
    StrokeReference()                 the 40 ms out-and-back stroke with continuous s', s'', s'''

The closed loop with a simulated plant and the named scenarios are emla_bench's.
"""
from emla_core.exports import lazy_exports

_EXPORTS = {  # name -> the module that holds it
    'InverseSystemController': 'controller',
    'StrokeReference': 'reference',
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
