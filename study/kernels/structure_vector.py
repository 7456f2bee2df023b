"""The structure vector the kernels read: its entries, in order, declared once.

The exact two-way orbit kernel and the integrators take a structure as one float64
array (numba compiles one signature for every structure). The solvers fill it from a
:class:`study.model.structure.Structure` and the chosen contact laws; the kernels read
it by these names. The contact laws' entries come last: the friction law's code and
every parameter a declared law needs (:data:`study.model.contact.LAWS`), so a new law's
parameter gets its entry from its declaration.
"""

from study.model.contact import LAWS

#: The entries of the structure vector, in order, with their units.
ENTRIES = (
    ("damping", "s-1", "w0 / Q"),
    ("stiffness", "s-2", "w0^2"),
    ("cos_alpha", "1", "cos of the plate's tilt"),
    ("sin_alpha", "1", "sin of the plate's tilt"),
    ("mass_ratio", "1", "M, the plate's mass over the total mass"),
    ("static_friction", "1", "cs"),
    ("kinetic_friction", "1", "ck"),
    ("gravity", "m s-2", "g"),
    ("two_way", "1", "1.0 for two-way coupling, 0.0 for one-way"),
    ("restitution", "1", "normal coefficient of restitution e of impacts on the table"),
    ("lift_off_law", "1", "code of the lift-off law: 0 stop (LIFT_OFF), 1 flight"),
    ("friction_law", "1", "code of the friction law (study.model.contact.LAWS)"),
    *(
        (parameter.name, parameter.units, parameter.long_name)
        for law in LAWS["friction"].values()
        for parameter in law.parameters
    ),
)
_NAMES = tuple(name for name, _, _ in ENTRIES)


def index(name: str) -> int:
    """Position of entry ``name`` in the structure vector."""
    return _NAMES.index(name)


# Numba reads module-level integers as compile-time constants.
DAMPING = _NAMES.index("damping")
STIFFNESS = _NAMES.index("stiffness")
COS_ALPHA = _NAMES.index("cos_alpha")
SIN_ALPHA = _NAMES.index("sin_alpha")
MASS_RATIO = _NAMES.index("mass_ratio")
STATIC_FRICTION = _NAMES.index("static_friction")
KINETIC_FRICTION = _NAMES.index("kinetic_friction")
GRAVITY = _NAMES.index("gravity")
TWO_WAY = _NAMES.index("two_way")
FRICTION_LAW = _NAMES.index("friction_law")
RESTITUTION = _NAMES.index("restitution")
LIFT_OFF_LAW = _NAMES.index("lift_off_law")
#: Length of the structure vector.
SIZE = len(ENTRIES)
