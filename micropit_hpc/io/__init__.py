"""Result and checkpoint files: the only place that opens HDF5 files for writing."""
