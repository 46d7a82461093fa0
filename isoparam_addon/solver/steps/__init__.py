"""Sun & Hancock's four steps: every island laid out at once, exactly on developable ones.

In pipeline order (each step reads the one before; :func:`.pipeline.solve` runs them):

``local.py``
    Step 1, Eqs. (1)-(5): every vertex's fan flattened by classical MDS.
``weights.py``
    Step 2, Eqs. (6)-(11): minimum-norm affine weights reconstructing each vertex from
    its flattened fan.
``embed.py``
    Step 3, Eqs. (12)-(14): the spectral embedding, the near-null space of
    ``M = (I - W)^T (I - W)`` per island, without forming M.
``align.py``
    Step 4, Eqs. (15)-(18): rotation and anisotropic scale fitted to the 3D edge lengths.
"""
