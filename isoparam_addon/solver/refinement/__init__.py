"""Beyond the paper: isometric refinement of the four-step layout, without folds.

The symmetric Dirichlet energy is lowered island by island from a fold-free start, every
step capped before a face collapses or a boundary crosses itself (docs/refinement.md).
In pipeline order:

``proxy.py``
    The quadratic proxy (cotangent Laplacian, SLIM-weighted where far from isometric),
    factored beside Steps 1-3.
``second_order.py``
    The proxy of a descent that goes on long: the energy's Hessian made positive
    semi-definite, with the contact barrier's curvature, over u and v together.
``descent.py``
    :func:`~.descent.refine`, the stage itself: each island's start, then local/global
    steps and L-BFGS until converged; :func:`~.descent.unfolded` without refinement.
``start.py``
    Where each island starts: its four-step layout, or the best fold-free alternative.
``seeds.py``
    Those alternatives: a least-squares conformal map and a Tutte embedding.
``per_face.py``
    The descent's per-face kernels: frames, Jacobians, the energy and its derivative,
    the collapse step, SLIM's weights, the energy's projected Hessians.
``contact.py``
    The barrier and step cap that keep an island's boundary from crossing itself.
``watch.py``
    Where the descent follows contact, and where it only tests a step's end.
"""
