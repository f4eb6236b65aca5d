"""Campaigns of many randomised fault-injection runs, on Dask, and their statistics.

One concept per module:

============  ================================================================================
``plan``      the runs drawn from the campaign's seed: the same seed, the same runs
``record``    one run's record (JSON): the draw, ReFrESH's decisions, the timing apart
``engine``    the runs on Dask (a LocalCluster or an existing scheduler), a crash recorded
``store``     the campaign's folder: parameters, records as JSON lines, resuming
``summary``   detection, false detections, location accuracy per strategy, recovery, cost
``plots``     the CDFs of detection latency and recovery time, accuracy per fault type (PNG)
``html``      the page that puts the tables and plots together
``cli``       the ``campaign`` command an application adds (`CampaignSpec`)
``errors``    `CampaignError` and its kinds
============  ================================================================================

It sits above `refresh` (its records hold ReFrESH's decisions) and below the applications that
run campaigns of their task (`visual_servoing`, `patrol`).
"""
