"""Where islands go: fitted to their pins, turned to a canonical frame, packed, and placed
in Blender's UV space.

In pipeline order:

``pins.py``
    Pinned UVs: which corners hold them, and islands fitted (and, with three or more,
    refined) onto them.
``placement.py``
    The solver's placement: canonical frames, similarity fits and shelf packing
    (:func:`.pipeline.solve`'s last stage).
``packing.py``
    Fill Shapes, the operator's packer: islands turned and fitted together by their
    shapes into the UV square.
``uv_space.py``
    The layout as the operator writes it: into the unit square, corrected for the
    image's aspect, or in place of the old UVs, with pinned and locked corners kept.
"""
