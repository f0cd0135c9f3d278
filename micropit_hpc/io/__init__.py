"""Result and checkpoint files: the only place that opens HDF5 files for writing, and the reader
of a run's results (:func:`micropit_hpc.io.results.load_results`)."""
