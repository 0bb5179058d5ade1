"""splatlab's precompute and validation lab (Dr.Jit, Mitsuba 3).

Importing ``lab`` is cheap: Dr.Jit and Mitsuba load only in the modules that need them.
"""
