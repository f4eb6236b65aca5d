"""application: one framework for every task on ReFrESH (the paper's visual servoing, the patrol,
the tutorial's tank).

An application declares what it is (`declaration`); from that one declaration the framework
makes its command, its runs in process and across processes, their records, reports and
campaigns. One concept per module:

=================  ================================================================================
``errors``         the exception tree under ApplicationError
``scenario``       `Scenario`: what goes wrong when (module faults, a power drop, an outage)
``declaration``    `Application`: database, scenarios, natives, guests, plant, samples, figure,
                   settings; and its `Figure`, `SampleField` and `Campaign`
``plant``          `WorldPlant`: the world around the robots' nodes, wherever a run's parts are
``prepared``       a scenario made ready: guests built, the database loaded with its faults
``records``        `Sample` and `Outcome`: what a run produced
``recording``      `RunPlant`: the application's plant plus the framework's faults and samples
``local_world``    `LocalWorld`: the robots' nodes in this process, stepped together
``outages``        a node's outage in process (switched off) and across processes (cut, killed)
``relay``          the TCP relay through which a scenario cuts a node's link
``runs``           one run: in process, or managing node processes (`refresh.manager.manage`)
``node``           a robot's node in its own process (``python -m APP node``)
``launch``         ``run --processes``: the plant's processes, the nodes and the manager
``report``         summary, table, JSON, timeline, MCAP and the figure
``campaign_runs``  the campaign of an application: its draws, each run in process on Dask
``cli``            ``python -m APP run | scenarios | node | manager | campaign``
=================  ================================================================================
"""
