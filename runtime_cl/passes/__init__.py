"""Runtime passes, one module each, registered by name (:mod:`runtime_cl.passes.registry`).

Importing this package registers every pass, in the order reports list them; use the registry
through it: ``from runtime_cl.passes import get_pass, pass_names, run_pass``.
"""
from runtime_cl.passes import spreadlets  # noqa: F401  (registers "spreadlets", "splat", "filter")
from runtime_cl.passes import polygon  # noqa: F401  (registers "polygon")
from runtime_cl.passes import layered  # noqa: F401  (registers "layered")
from runtime_cl.passes import identity  # noqa: F401  (registers "identity")
from runtime_cl.passes import stochastic  # noqa: F401  (registers "stochastic_spreadlets", "stochastic_splat")
from runtime_cl.passes.registry import (RuntimePass, get_pass, integrating_passes, pass_names, pass_options,
                                       register_pass, run_pass)

__all__ = ["RuntimePass", "get_pass", "integrating_passes", "pass_names", "pass_options", "register_pass",
           "run_pass"]
