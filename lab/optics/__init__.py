"""Optics in Dr.Jit, the lab's single source of truth: ``thin_lens`` (paraxial thin lens, CoC),
``aperture`` (shape samplers registered by name). Importing this package loads nothing heavy.
"""
