"""The discrepancy workflow's library of candidate effects: the candidates of the physics layer's effects
(emla_core.physics, one file each, docs/physics.md §6) and any registered with `register_candidate`."""
from emla_core.physics import CANDIDATES, Candidate, register_candidate

__all__ = ['CANDIDATES', 'Candidate', 'library', 'register_candidate']


def library(data, names=None):
    """Instances of the registered candidates (or of `names`) that can act on `data`'s equations."""
    chosen = [CANDIDATES[n]() for n in dict.fromkeys(names or CANDIDATES)]   # a name given twice: once
    return [c for c in chosen if set(c.acts_on) & set(data.kinds)]
