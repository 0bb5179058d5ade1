"""Polygonal bokeh kernels in the lab (MHU21): rectification and the kernels' statistics.

- :mod:`.rectify` - the minimum-area enclosing polygon with edges along a direction set D.
- :mod:`.graph` - its two numeric stages (candidate-edge graph, cycle DP), compiled by Numba.
- :mod:`.table` - MHU21 Table 1: non-zero counts of Laplacian, dxdy and directional differences.
- :mod:`.ship` - writes the rectified built-in shapes the runtime ships
  (``runtime_cl/polygon/shapes.json``; the outlines are :mod:`runtime_cl.polygon.shapes`).
"""
