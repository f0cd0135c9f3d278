"""Contact pressure and clearance of the rough surfaces at one time step (docs/model.md §4.1).

``smooth``: no roughness, p = p̄; ``dry``: elastic–perfectly-plastic FFT contact
(Polonsky–Keer); ``mixed``: the fast mixed lubrication model of [M10]/[B11]. Which level a
position gets: :func:`micropit_hpc.plan.choose_level`; the solver of each level:
the table in :mod:`micropit_hpc.cycle`.
"""

#: The contact levels (``lubrication.model`` takes these and ``auto``), docs/model.md §4.1.
LEVELS = ("smooth", "dry", "mixed")
