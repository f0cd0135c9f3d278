"""Contact pressure and clearance of the rough surfaces at one time step (docs/model.md §4.1).

``dry``: elastic–perfectly-plastic FFT contact (Polonsky–Keer); ``mixed``: the fast mixed
lubrication model of [M10]/[B11]; ``levels``: the choice among smooth / dry / mixed and the
friction map.
"""
