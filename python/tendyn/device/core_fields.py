"""The fields of the core transmission model (``tendyn._core.TransmissionModel``) derived from the device
file's field tables: the one route from a TOML key to the C++ step (:data:`TRANSMISSION_MODEL_FIELDS`)."""

from __future__ import annotations

from dataclasses import dataclass

from .schema_fields import BEARING_FIELDS, FRICTION_FIELDS, TRANSMISSION_FIELDS, FieldSpec

BEARING_PREFIX = "bearing_"
"""A bearing field ``x`` of the device file is the routing array / core field ``bearing_x``."""

BEARING_ARRAY_NAMES = tuple(spec.name for spec in BEARING_FIELDS)
"""Keys of a ``bearings`` entry, in order (derived from :data:`BEARING_FIELDS`)."""

NO_BEARING = {"radius": 1.0}
"""Array values of a branch without bearings where not 0 (a radius of 1 m: no division by zero)."""


@dataclass(frozen=True)
class ModelField:
    """One field of the core transmission model (``tendyn._core.TransmissionModel``), derived from the
    device-file field tables: the one route from a TOML key to the C++ step.

    Attributes
    ----------
    name : str
        Core field name = key of :meth:`Device.routing_arrays` = model-file key.
    dims : int
        1: (m,) per transmission; 2: (m, n), [i, j] = joint j (``K``) or branch j of transmission i.
    unit : str
        SI unit (as in the field table it comes from).
    toml : str
        Where it comes from in the device file (``transmissions.bearings.static_coefficient``).
    attribute : str
        The dataclass attribute that holds it (``Bearing.static_coefficient``).
    default : float
        Value when the file does not give it (lossless, no bearing).
    """

    name: str
    dims: int
    unit: str
    toml: str
    attribute: str
    default: float


def _spec_default(spec: FieldSpec) -> float:
    return float(spec.default) if isinstance(spec.default, (int, float)) else 0.0


_TRANSMISSION_SPECS = {spec.name: spec for spec in TRANSMISSION_FIELDS}

TRANSMISSION_MODEL_FIELDS: tuple[ModelField, ...] = (
    ModelField("motor_radius", 1, _TRANSMISSION_SPECS["motor_radius"].unit, "transmissions.motor_radius",
               "TransmissionSpec.motor_radius", 0.0),
    ModelField("K", 2, "m", "transmissions.crosses, crossed_radii, driven_radius * reducer_ratio",
               "TransmissionSpec.crosses, crossed_radii, generalized_radius", 0.0),
) + tuple(
    ModelField(name, 1, _TRANSMISSION_SPECS[name].unit, f"transmissions.{name}", f"TransmissionSpec.{name}",
               _spec_default(_TRANSMISSION_SPECS[name]))
    for name in ("driven_radius", "reducer_ratio", "reducer_efficiency", "pretension")
) + tuple(
    ModelField(spec.name, 2, spec.unit, f"transmissions.friction.{spec.name}", f"BranchFriction.{spec.name}",
               _spec_default(spec))
    for spec in FRICTION_FIELDS
) + tuple(
    ModelField(BEARING_PREFIX + spec.name, 2, spec.unit, f"transmissions.bearings.{spec.name}",
               f"Bearing.{spec.name}", NO_BEARING.get(spec.name, 0.0))
    for spec in BEARING_FIELDS
)
"""Every field of the core transmission model, in the order of the C++ parameter table
(``TENDYN_TRANSMISSION_FIELDS`` in ``include/tendyn/routing.hpp``; a test checks they agree). The routing
arrays, the Python -> C++ fill, the friction-free model, the twin's truth and the docs derive from it."""

LOSS_FIELD_NAMES = tuple(f.name for f in TRANSMISSION_MODEL_FIELDS if f.dims == 2 and f.name != "K")
"""The per-branch loss and bearing fields (everything but the routing) of the core model."""
