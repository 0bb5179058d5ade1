"""User-facing errors for the lab; the same type as the runtime's (the CLI exits with 2)."""
from runtime_cl.errors import InputError as UserError

__all__ = ["UserError"]
