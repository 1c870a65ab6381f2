"""Monte Carlo campaigns: the resumable result store on Dask, run statistics, the
tables beside the paper's and the HTML report."""

from .store import Campaign, CampaignError, open_runs, run_units

__all__ = ["Campaign", "CampaignError", "open_runs", "run_units"]
