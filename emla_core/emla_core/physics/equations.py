"""The electromechanical equations of an actuator, in the general form every actuator family shares.

With the flux linkage psi(x, I) of the coil and the co-energy W'(x, I) = integral of psi dI (docs/physics.md §2):

    u = R I + d psi/dt = R I + l dI/dt + e v,      l = d psi/dI (incremental inductance),
                                                  e = d psi/dx (back-EMF coefficient)
    F = d W'/dx                                   (the coil's force on the moving part)
    m dv/dt = F - B v - load - friction,          dx/dt = v

A moving coil has psi = L I + Km x, so l = L, e = Km and F = Km I. A position-dependent inductance L(x) adds
I L'(x) to e and I^2 L'(x) / 2 to F; a saturating iron makes l depend on I. The callers evaluate l, e and F at
the state with their effects and pass them here, so this right-hand side is the only one in the suite.
"""
import numba


@numba.njit(cache=True)
def friction_force(velocity, drive_force, mass, coulomb_force, relaxation_time):
    """Coulomb friction Fc sign(v) with sticking resolved in the time-stepping way (N, opposing +v).

    The friction is the force that would stop the mass within `relaxation_time` (the integration sub-step),
    limited to +-Fc, with the driving force first limited to +-Fc. So: a mass driven by less than Fc sticks
    (its velocity decays to exactly zero, no creep); a sliding mass feels Fc sign(v); a velocity reversal
    switches the friction over a band |v| < 2 Fc tau / m around zero. The right-hand side stays continuous,
    so RK4 does not chatter.
    """
    if coulomb_force <= 0.0:
        return 0.0
    drive = min(max(drive_force, -coulomb_force), coulomb_force)
    return min(max(mass * velocity / relaxation_time + drive, -coulomb_force), coulomb_force)


@numba.njit(cache=True)
def coil_rates(current, velocity, voltage, resistance, inductance, emf_coefficient, coil_force, mass, damping,
               load, coulomb_force, relaxation_time):
    """(dI/dt, dv/dt) of the coil and the moving part.

    Parameters
    ----------
    current, velocity, voltage : float
        I (A), v (m/s) and the coil voltage u (V).
    resistance, inductance, emf_coefficient : float
        R (ohm), the incremental inductance d psi/dI (H) and the back-EMF coefficient d psi/dx (V s/m) at
        the state.
    coil_force : float
        The coil's force d W'/dx (N) at the state (Km I for a moving coil).
    mass, damping, load : float
        m (kg), B (N s/m) and the load force (N, opposing +x: Fl plus position- and velocity-dependent forces).
    coulomb_force, relaxation_time : float
        Fc (N, 0 for none) and the sub-step over which `friction_force` resolves sticking (s).

    Returns
    -------
    tuple of float
        (dI/dt in A/s, dv/dt in m/s^2).
    """
    drive = coil_force - damping * velocity - load
    friction = friction_force(velocity, drive, mass, coulomb_force, relaxation_time)
    return ((voltage - resistance * current - emf_coefficient * velocity) / inductance,
            (drive - friction) / mass)
