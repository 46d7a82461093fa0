"""The Isometric Unwrap operation without Blender.

What the operator does between reading the meshes and writing their UVs, in plain
Python: its options and their defaults (:mod:`.options`), one mesh's part as arrays
(:mod:`.selection`), each mesh solved as Blender's unwrap would take it, with its
retries, placed in UV space and packed by Fill Shapes (:mod:`.unwrap`), the run's record
(:mod:`.record`) and its words (:mod:`.messages`). Nothing here imports ``bpy``:
:mod:`isoparam_addon.blender` reads and writes the meshes, runs Blender's packer and
registers the operators, as glTF-Blender-IO keeps its ``io`` apart from its ``blender``.
"""
