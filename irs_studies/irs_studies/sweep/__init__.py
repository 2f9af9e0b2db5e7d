"""Design sweeps: a scenario's offline closed loop over parameter spaces, on Dask."""
