"""Finite-element check of the contact model (optional extra: ``pip install cyclomesh[fe]``).

2-D plane-strain linear elasticity with frictionless unilateral contact: gmsh meshes
(:mod:`cyclomesh.fe.mesh`), scikit-fem assembly and an exact active-set contact solver
(:mod:`cyclomesh.fe.solve`), the Hertz classics (:mod:`cyclomesh.fe.hertz_check`) and the
tooth compliance of the cycloid disc (:mod:`cyclomesh.fe.tooth`). The core never imports
this package.
"""
