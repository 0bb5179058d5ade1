"""Runtime passes, one module each, registered by name (:mod:`runtime_cl.passes.registry`).

Importing this package registers every pass, in the order reports list them.
"""
from runtime_cl.passes import spreadlets  # noqa: F401  (registers "spreadlets", "splat", "filter")
from runtime_cl.passes import polygon  # noqa: F401  (registers "polygon")
from runtime_cl.passes import identity  # noqa: F401  (registers "identity")
