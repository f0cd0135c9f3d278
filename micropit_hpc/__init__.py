"""micropit_hpc: MPI-parallel prediction of micropitting on rough, lubricated rolling-sliding
contacts.

Implements and extends Morales-Espejel, Rycerz & Kadiric, Wear 398-399 (2018) 99-115.
SI units everywhere inside the package; engineering units only in scene-file keys and reports.
"""

__version__ = "0.1.0"
