"""Monte Carlo campaigns: sampling, batched runs on Dask, robust start sets and reports."""
