"""Seeded random routings shared by the transmission tests (one definition: :mod:`tendyn.claims.routings`)."""

from tendyn.claims.routings import random_routing

__all__ = ["random_routing"]
