"""PSF models, one module each, registered by name: ``get_model("simple_lens")``.

Importing this package registers every model (and loads Dr.Jit).
"""
from lab.psf_tracing.models.base import PSFModel, get_model, load_model, model_names, register_model
from lab.psf_tracing.models import simple_lens  # noqa: F401  (registers "simple_lens")
from lab.psf_tracing.models import combined  # noqa: F401  (registers "combined")
from lab.psf_tracing.models import stylized  # noqa: F401  (registers "stylized")
from lab.psf_tracing.models import physical_lens  # noqa: F401  (registers "physical_lens")
from lab.psf_tracing.models import volume  # noqa: F401  (registers "volume")
from lab.psf_tracing.models import volume_far  # noqa: F401  (registers "volume_far")
from lab.psf_tracing.models import volume_box  # noqa: F401  (registers "volume_box")

__all__ = ["PSFModel", "get_model", "load_model", "model_names", "register_model"]
