"""An effect beyond the nominal two-equation model, with ONE parameterisation that every package reads
(docs/physics.md §6).

An effect is a frozen dataclass, a subclass of `Effect`, in a file of its own under `physics/effects/`. Its
`parameters` are what the data fix (fitted by the discrepancy workflow, written to the model file, simulated
by the plant); its `settings` are fixed per variant (searched on a grid, or given). Both are `Parameter`s
with names, SI units, bounds and defaults, and the dataclass has one field for each. The same file holds:

- the plant: the hooks below (`flux_terms`, `extra_force`, `friction_level`, `resistance_factor`,
  `temperature_rate`), and `kernel_values` for the compiled right-hand side (kernel.py) where one exists;
- the batch regression: `candidate`, a `Candidate` subclass (candidate.py) of the same name;
- online: `online`, an `OnlineColumn` (online.py), or `online_refusal` saying why it cannot run online;
- the inverse law: `compensation()`, or `control_refusal` saying why it is not compensated;
- the model file: `from_model` (the entry's parameters and settings are the fields, by name).
`register_effect` makes it known by name to all of them; a user's own effect is registered the same way.
"""
import dataclasses
import math
import numbers
from typing import TYPE_CHECKING, ClassVar, Self

if TYPE_CHECKING:   # for the annotation only: register_effect imports candidate.py when it is first needed
    from .candidate import Candidate

AMBIENT_TEMPERATURE = 20.0  # deg C; the coil temperature when no thermal model is active


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A parameter or setting of an effect: name, SI unit, default, closed bounds and a one-line description.

    `infinite` allows +inf (an effect part switched off, e.g. a saturation current of inf)."""
    name: str
    unit: str
    default: float
    lower: float = -math.inf
    upper: float = math.inf
    doc: str = ''
    infinite: bool = False

    def checked(self, value: float, where: str) -> float:
        """`value` as a float within the bounds, or ValueError naming `where` and what is wrong."""
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(f'{where}.{self.name} must be a number, got {value!r}')
        value = float(value)
        if math.isnan(value) or (math.isinf(value) and not (self.infinite and value > 0)):
            raise ValueError(f'{where}.{self.name} must be finite{" or +inf" if self.infinite else ""}, '
                             f'got {value!r}')
        if not self.lower <= value <= self.upper:
            raise ValueError(f'{where}.{self.name} must be within [{self.lower:g}, {self.upper:g}] {self.unit}, '
                             f'got {value!r}')
        return value


class Effect:
    """Base class of the effects: every plant hook returns its neutral value; subclasses override some.

    Subclasses are frozen dataclasses with one field per entry of `parameters` and `settings`, whose bounds
    are checked on construction."""

    name: ClassVar[str] = ''
    parameters: ClassVar[tuple] = ()        # Parameter: fitted, in the model file's `parameters`
    settings: ClassVar[tuple] = ()          # Parameter: fixed per variant, in the model file's `settings`
    candidate: ClassVar['type[Candidate] | None'] = None   # the discrepancy workflow's Candidate of this effect
    online: ClassVar[object] = None         # an OnlineColumn, or None (then online_refusal says why)
    online_refusal: ClassVar[str] = ''
    online_by_forgetting: ClassVar[bool] = False   # followed online by the forgetting, not by a column
    control_refusal: ClassVar[str] = ''     # why the inverse law does not compensate it ('' when it does)
    simulation_refusal: ClassVar[str] = ''  # why the plant does not simulate it ('' when it does)
    ambient_temperature: float | None = None   # deg C, for an effect that models the coil temperature

    def __post_init__(self):
        where = type(self).__name__
        for spec in self.parameters + self.settings:
            object.__setattr__(self, spec.name, spec.checked(getattr(self, spec.name), where))

    @classmethod
    def specs(cls) -> dict[str, Parameter]:
        """{name: Parameter} of the parameters and settings."""
        return {p.name: p for p in cls.parameters + cls.settings}

    # ---- plant hooks: how the effect changes the equations of equations.py at a state ----
    def resistance_factor(self, temperature: float) -> float:
        """R(T) / R."""
        return 1.0

    def temperature_rate(self, temperature: float, joule_power: float) -> float:
        """dT/dt (K/s) of the coil given its Joule heating R(T) I^2 (W)."""
        return 0.0

    def flux_terms(self, position: float, current: float) -> tuple[float, float, float]:
        """(d psi_e/dI in H, d psi_e/dx in V s/m, d W'_e/dx in N) of the flux linkage psi_e(x, I) the effect adds
        to L I + Km x, and of its co-energy W'_e: added to the incremental inductance, the back-EMF
        coefficient and the coil force."""
        return 0.0, 0.0, 0.0

    def extra_force(self, position: float, velocity: float) -> float:
        """Extra force on the moving part (N), counted like Fl: positive opposes motion towards +x."""
        return 0.0

    def friction_level(self) -> float:
        """Coulomb friction level Fc (N); the plant applies it as Fc sign(v) with sticking."""
        return 0.0

    def kernel_values(self) -> dict[str, float] | None:
        """{kernel slot: value} for the compiled dynamics (kernel.py), or None to be integrated through the
        hooks (correct, about 100x slower)."""
        return None

    # ---- the inverse law ----
    def compensation(self) -> dict[str, float]:
        """{law coefficient: value} the inverse law compensates (emla_control.controller.EFFECTS); {} with
        `control_refusal` set when it does not."""
        return {}

    # ---- the model file ----
    @classmethod
    def from_model(cls, values: dict[str, float], settings: dict[str, float]) -> Self:
        """The effect of a model file's entry: its parameters `values` {name: value} and `settings`; ValueError
        when the plant does not simulate it."""
        if cls.simulation_refusal:
            raise ValueError(f'{cls.name}: the plant does not simulate it: {cls.simulation_refusal}')
        known = cls.specs()
        fields = {k: v for k, v in {**settings, **values}.items() if k in known and v is not None}
        return cls(**fields)


EFFECTS: dict[str, type[Effect]] = {}


def register_effect(cls: type[Effect]) -> type[Effect]:
    """Class decorator: make an Effect subclass (and its candidate) known under `cls.name`."""
    from .candidate import register_candidate
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise TypeError(f'register_effect needs a subclass of Effect, got {cls!r}')
    if not cls.name:
        raise ValueError(f'{cls.__name__} has no name')
    if EFFECTS.get(cls.name, cls) is not cls:
        raise ValueError(f'an effect named {cls.name!r} is already registered ({EFFECTS[cls.name].__name__})')
    if cls.candidate is not None:
        if cls.candidate.name != cls.name:
            raise ValueError(f'{cls.__name__}.candidate is named {cls.candidate.name!r}, not {cls.name!r}')
        register_candidate(cls.candidate)
    EFFECTS[cls.name] = cls
    return cls


def make_effect(name: str, **parameters: float) -> Effect:
    """An effect by its registered name with some of its parameters and settings (the rest at their defaults)."""
    if name not in EFFECTS:
        raise ValueError(f'unknown effect {name!r}; known: {sorted(EFFECTS)}')
    try:
        return EFFECTS[name](**parameters)
    except TypeError as error:
        raise ValueError(f'bad parameters for effect {name!r}: {error}') from None
