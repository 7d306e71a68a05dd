"""Files in and out: atomic writes (nothing half-written), JSON of numpy results."""

from tendyn.io.files import atomic_write_bytes, atomic_write_text, to_jsonable

__all__ = ["atomic_write_bytes", "atomic_write_text", "to_jsonable"]
