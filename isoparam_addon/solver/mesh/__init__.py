"""Before the four steps: the mesh as arrays and its topology.

:func:`.topology.build_topology` validates the mesh, splits it along seams, finds and
orients its islands, opens every island that is not a disk and walks the fans Step 1
flattens; every later stage reads the islands and orders built here. In pipeline order:

``topology.py``
    :func:`~.topology.build_topology`, the stage itself, calling the two below in turn.
``halfedges.py``
    The mesh as arrays: validation (:func:`~.halfedges.check`), half-edges, vertices
    split along cut edges, orientation, fans.
``cutgraph.py``
    Cuts that open every island that is not a topological disk into one.
``islands.py``
    Per-island reductions over the islands found here: every later stage's sums, means,
    minima and small dense algebra per island.
``ordering.py``
    Geometric nested dissection: the fill-reducing order of Step 3's and the refinement's
    sparse factorizations (and the charting's prediction).
"""
