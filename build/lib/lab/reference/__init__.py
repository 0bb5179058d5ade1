"""Mitsuba 3 references and labelled-pixel inputs.

Import the submodules (``render``, ``labelled``, ``mitsuba_scene``, ``coc``); Mitsuba loads on
the first render, never on import.
"""
