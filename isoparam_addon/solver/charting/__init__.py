"""Beyond one solve: searches that cut islands further and solve them again.

:func:`.parametrize` charts the mesh (overlaps repaired on the way), or solves it with
:func:`.pipeline.solve` or the extra cuts and then repairs what overlaps itself; the last
three modules are their machinery. In pipeline order:

``charts.py``
    Charting: islands cut into charts until each is within the stretch budget.
``cuts.py``
    Extra cuts: islands cut open automatically get longer cuts while distortion falls.
``untangle.py``
    Overlap repair: islands that overlap themselves cut where their layers are least apart.
``resolve.py``
    Some islands solved again with more seams and put back beside the others.
``mincut.py``
    Seams as minimum cuts of the faces' adjacency graph.
``stress.py``
    The charting's prediction: how far from isometric a chart will lay out, from linear
    solves.
"""
